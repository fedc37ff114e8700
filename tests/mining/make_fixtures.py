"""Writes the small trajectory fixtures in tests/mining/data/ (run it after changing them:
``python tests/mining/make_fixtures.py``). Synthetic traffic from simple kinematics, one file
(or file set) per format, with the cases the reader tests check by hand:

- NGSIM (feet, 10 frames/s, frames 1000-1019): a car braking in lane 2 from frame 1005, a truck
  following it, a car changing from lane 3 to lane 2, a motorcycle whose id is reused (frames
  1000-1007 and 1012-1019), a vehicle seen in one frame only.
- highD (recording 01, 25 frames/s, frames 1-10): two lanes per carriageway; cars driving
  towards +x in the lower half (one truck changing from lane 6 to lane 5) and towards -x in the
  upper half; a vehicle seen in one frame only.
- CommonRoad 2020a: a two-lane road running towards -x ending at a signalised stop line,
  a car keeping its lane, a car changing to the left lane, a bus, a pedestrian.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from lxml import etree

DATA = Path(__file__).resolve().parent / "data"

# --- NGSIM ----------------------------------------------------------------------------------

NGSIM_HEADER = [
    "Vehicle_ID", "Frame_ID", "Total_Frames", "Global_Time", "Local_X", "Local_Y", "Global_X",
    "Global_Y", "v_Length", "v_Width", "v_Class", "v_Vel", "v_Acc", "Lane_ID", "Preceding",
    "Following", "Space_Headway", "Time_Headway", "Location", "O_Zone", "D_Zone", "Int_ID",
    "Section_ID", "Direction", "Movement",
]
FIRST_FRAME = 1000
T0_MS = 1118846980000


def _lane_x(lane: int) -> float:
    """Lateral centre (ft) of an NGSIM lane 12 ft wide, lane 1 at the left."""
    return 6.0 + 12.0 * (lane - 1)


def _ngsim_vehicle(vid: int, frames: range, y0: float, v0: float, length: float,
                   width: float, cls: int, x_of, decel_from: int | None = None,
                   decel: float = 0.0) -> list[list]:
    """Rows of one vehicle: Local_Y integrates the speed; ``decel`` (ft/s^2) from a frame."""
    rows, y, v = [], y0, v0
    for frame in frames:
        x = x_of(frame)
        lane = 1 + int(x // 12.0)
        acc = -decel if decel_from is not None and frame >= decel_from else 0.0
        rows.append([vid, frame, len(frames), T0_MS + (frame - FIRST_FRAME) * 100, round(x, 3),
                     round(y, 3), 6451000.0 + x, 1873000.0 + y, length, width, cls,
                     round(v, 3), acc, lane, 0, 0, 0.0, 0.0, "us-101", 101, 201, 0, 0, 2, 1])
        y += v * 0.1
        v = max(0.0, v + acc * 0.1)
    return rows


def ngsim_rows() -> list[list]:
    frames = range(FIRST_FRAME, FIRST_FRAME + 20)
    rows = _ngsim_vehicle(10, frames, 200.0, 44.0, 15.0, 6.0, 2, lambda f: _lane_x(2),
                          decel_from=FIRST_FRAME + 5, decel=10.0)
    rows += _ngsim_vehicle(11, frames, 120.0, 44.0, 40.0, 8.5, 3, lambda f: _lane_x(2))
    rows += _ngsim_vehicle(
        12, frames, 150.0, 40.0, 14.0, 6.0, 2,
        lambda f: _lane_x(3) - 12.0 * min(1.0, max(0.0, (f - FIRST_FRAME - 5) / 10)))
    for part in (range(FIRST_FRAME, FIRST_FRAME + 8), range(FIRST_FRAME + 12, FIRST_FRAME + 20)):
        rows += _ngsim_vehicle(13, part, 60.0 + (part.start - FIRST_FRAME) * 5.0, 50.0, 7.0, 3.0,
                               1, lambda f: _lane_x(1))
    rows += _ngsim_vehicle(14, range(FIRST_FRAME + 3, FIRST_FRAME + 4), 10.0, 30.0, 15.0, 6.0,
                           2, lambda f: _lane_x(4))
    return sorted(rows, key=lambda r: (r[1], r[0]))


def write_ngsim(path: Path) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(NGSIM_HEADER)
        writer.writerows(ngsim_rows())


# --- highD ----------------------------------------------------------------------------------

HIGHD_TRACKS = [
    "frame", "id", "x", "y", "width", "height", "xVelocity", "yVelocity", "xAcceleration",
    "yAcceleration", "frontSightDistance", "backSightDistance", "dhw", "thw", "ttc",
    "precedingXVelocity", "precedingId", "followingId", "leftPrecedingId", "leftAlongsideId",
    "leftFollowingId", "rightPrecedingId", "rightAlongsideId", "rightFollowingId", "laneId",
]
HIGHD_META = [
    "id", "width", "height", "initialFrame", "finalFrame", "numFrames", "class",
    "drivingDirection", "traveledDistance", "minXVelocity", "maxXVelocity", "meanXVelocity",
    "minDHW", "minTHW", "minTTC", "numLaneChanges",
]
HIGHD_RECORDING = [
    "id", "frameRate", "locationId", "speedLimit", "month", "weekDay", "startTime", "duration",
    "totalDrivenDistance", "totalDrivenTime", "numVehicles", "numCars", "numTrucks",
    "upperLaneMarkings", "lowerLaneMarkings",
]
UPPER = (1.0, 4.5, 8.0)  # lanes 2 (y 1.0-4.5) and 3 (4.5-8.0), driving towards -x
LOWER = (12.0, 15.5, 19.0)  # lanes 5 (12.0-15.5) and 6 (15.5-19.0), driving towards +x
FPS = 25


def _lane_of(y_centre: float) -> int:
    """highD's laneId: 1 + the number of markings above the centre."""
    return 1 + sum(m < y_centre for m in (*UPPER, *LOWER))


#: id -> (class, direction, length, width, first frame, frames, x0 centre, vx, y centre(frame))
HIGHD_VEHICLES = {
    1: ("Car", 2, 4.5, 1.8, 1, 10, 20.0, 25.0, lambda f: 13.75),
    2: ("Truck", 2, 12.0, 2.5, 1, 10, 60.0, 22.0, lambda f: 17.25 - 3.5 * min(1, (f - 1) / 9)),
    3: ("Car", 1, 4.0, 1.9, 1, 10, 300.0, -30.0, lambda f: 6.25),
    4: ("Car", 1, 5.0, 2.0, 3, 8, 250.0, -20.0, lambda f: 2.75),
    5: ("Car", 2, 4.5, 1.8, 5, 1, 100.0, 20.0, lambda f: 13.75),
}


def write_highd(folder: Path) -> None:
    tracks, meta = [], []
    for vid, (cls, direction, length, width, first, n, x0, vx, y_of) in HIGHD_VEHICLES.items():
        for k in range(n):
            frame, yc = first + k, y_of(first + k)
            vy = (y_of(frame + 1) - y_of(frame)) * FPS if k < n - 1 else 0.0
            x = x0 + vx * k / FPS
            tracks.append([frame, vid, round(x - length / 2, 4), round(yc - width / 2, 4),
                           length, width, vx, round(vy, 4), 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                           0, 0, 0, 0, 0, 0, _lane_of(yc)])
        meta.append([vid, length, width, first, first + n - 1, n, cls, direction,
                     abs(vx) * n / FPS, vx, vx, vx, -1, -1, -1, int(vid == 2)])
    recording = [1, FPS, 2, 33.33, "09.2017", "Tue", "08:38", 0.4, 100.0, 10.0, 5, 4, 1,
                 ";".join(map(str, UPPER)), ";".join(map(str, LOWER))]
    for name, header, rows in (("tracks", HIGHD_TRACKS, sorted(tracks)),
                               ("tracksMeta", HIGHD_META, meta),
                               ("recordingMeta", HIGHD_RECORDING, [recording])):
        with (folder / f"01_{name}.csv").open("w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(header)
            writer.writerows(rows)


# --- CommonRoad -----------------------------------------------------------------------------

DT = 0.1
STEPS = 30


def _sub(parent: etree._Element, tag: str, text: object = None, **attrib: str) -> etree._Element:
    element = etree.SubElement(parent, tag, **attrib)
    if text is not None:
        element.text = str(text)
    return element


def _points(parent: etree._Element, tag: str, points: list[tuple[float, float]]) -> None:
    bound = _sub(parent, tag)
    for x, y in points:
        point = _sub(bound, "point")
        _sub(point, "x", x)
        _sub(point, "y", y)
    _sub(bound, "lineMarking", "dashed")


def _lanelet(root: etree._Element, lid: int, y_left: float, y_right: float,
             left: int | None, right: int | None) -> None:
    """A straight lanelet from x=100 to x=0 (driving towards -x); its left is -y."""
    lanelet = _sub(root, "lanelet", id=str(lid))
    _points(lanelet, "leftBound", [(100.0, y_left), (50.0, y_left), (0.0, y_left)])
    _points(lanelet, "rightBound", [(100.0, y_right), (50.0, y_right), (0.0, y_right)])
    if left is not None:
        _sub(lanelet, "adjacentLeft", ref=str(left), drivingDir="same")
    if right is not None:
        _sub(lanelet, "adjacentRight", ref=str(right), drivingDir="same")
    _sub(lanelet, "laneletType", "urban")
    _sub(lanelet, "trafficLightRef", ref="200")


def _light(root: etree._Element, lid: int, cycle: list[tuple[str, int]], offset: int) -> None:
    light = _sub(root, "trafficLight", id=str(lid))
    element = _sub(light, "cycle")
    for colour, duration in cycle:
        item = _sub(element, "cycleElement")
        _sub(item, "duration", duration)
        _sub(item, "color", colour)
    _sub(element, "timeOffset", offset)
    _sub(light, "active", "true")


def _state(parent: etree._Element, tag: str, step: int, x: float, y: float, heading: float,
           speed: float) -> None:
    state = _sub(parent, tag)
    point = _sub(_sub(state, "position"), "point")
    _sub(point, "x", round(x, 4))
    _sub(point, "y", round(y, 4))
    _sub(_sub(state, "orientation"), "exact", round(heading, 5))
    _sub(_sub(state, "time"), "exact", step)
    _sub(_sub(state, "velocity"), "exact", speed)
    _sub(_sub(state, "acceleration"), "exact", 0.0)


def _obstacle(root: etree._Element, oid: int, kind: str, length: float, width: float,
              x0: float, speed: float, y_of) -> None:
    """An obstacle driving towards -x at ``speed`` with lateral position ``y_of(step)``."""
    obstacle = _sub(root, "dynamicObstacle", id=str(oid))
    _sub(obstacle, "type", kind)
    rectangle = _sub(_sub(obstacle, "shape"), "rectangle")
    _sub(rectangle, "length", length)
    _sub(rectangle, "width", width)
    trajectory = None
    for step in range(STEPS):
        dy = y_of(step + 1) - y_of(step)
        heading = math.atan2(dy, -speed * DT)
        args = (step, x0 - speed * DT * step, y_of(step), heading, speed)
        if step == 0:
            _state(obstacle, "initialState", *args)
            trajectory = _sub(obstacle, "trajectory")
        else:
            _state(trajectory, "state", *args)


def write_commonroad(path: Path) -> None:
    root = etree.Element("commonRoad", commonRoadVersion="2020a", benchmarkID="ZAM_Fixture-1_1_T-1",
                         timeStepSize=str(DT), author="ScenWeave tests", affiliation="ScenWeave",
                         source="synthetic", date="2026-01-01")
    location = _sub(root, "location")
    for tag, value in (("geoNameId", -999), ("gpsLatitude", 48.26), ("gpsLongitude", 11.67)):
        _sub(location, tag, value)
    _sub(_sub(root, "scenarioTags"), "urban")
    _lanelet(root, 100, -3.5, 0.0, None, 101)   # left lane
    _lanelet(root, 101, 0.0, 3.5, 100, None)    # right lane
    _light(root, 200, [("green", 10), ("yellow", 5), ("red", 10), ("redYellow", 3),
                       ("inactive", 2)], 0)
    _obstacle(root, 1, "car", 4.5, 1.8, 90.0, 10.0, lambda k: 1.75)
    _obstacle(root, 2, "car", 4.0, 1.7, 70.0, 8.0,
              lambda k: 1.75 - 3.5 * min(1.0, max(0.0, (k - 10) / 10)))
    _obstacle(root, 3, "bus", 12.0, 2.5, 95.0, 6.0, lambda k: -1.75)
    _obstacle(root, 4, "pedestrian", 0.5, 0.5, 50.0, 1.0, lambda k: 5.0)
    etree.ElementTree(root).write(str(path), pretty_print=True, xml_declaration=True,
                                  encoding="UTF-8")


def main() -> None:
    DATA.mkdir(exist_ok=True)
    write_ngsim(DATA / "ngsim_small.csv")
    (DATA / "highd").mkdir(exist_ok=True)
    write_highd(DATA / "highd")
    write_commonroad(DATA / "commonroad_small.xml")


if __name__ == "__main__":
    main()

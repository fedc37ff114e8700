"""MOOVE variants are read tolerantly (issue 14, item 5): a field in a form we did not expect
but can read is read, with a warning naming it; the record is not rejected."""

from __future__ import annotations

import pytest

from scenweave import corpus
from scenweave.ingest import check_record, extract_params, ingest_directory
from scenweave.ingest.urban import canonicalize_scene, canonicalize_urban_file
from tests.ingest.builders import scene, write_scene

TIMES = [100.0, 101.0, 102.0, 103.0, 104.0]
ODOMETER = [0.0, 13.9, 27.8, 41.7, 55.6]


def _stop_scene(**climate) -> dict:
    data = scene("U4_1", [50, 50, 50, 50, 50], TIMES, ODOMETER, light=(60.0, 172))
    for frame in data["key_times"]:
        frame["temporal_climatic"].update(climate)
    return data


@pytest.mark.parametrize(("day_period", "weather"), [
    ("Night", "Night_Clear"), ("night", "Night_Clear"), ("Day", "Day_Clear"),
    ("2", "Night_Clear"), (2, "Night_Clear")])
def test_day_period_as_label_or_code(day_period, weather, tmp_path):
    path = write_scene(tmp_path, _stop_scene(day_period=day_period))
    record, issues = canonicalize_urban_file(path)
    assert record is not None, issues
    check_record(record)
    assert record["environment"]["weather_key"] == weather
    if isinstance(day_period, str):
        assert issues and all(i.severity == "warning" for i in issues)
        assert issues[0].field == "key_times[0].temporal_climatic.day_period"
    else:
        assert issues == []


def test_precipitation_as_its_label_is_rain():
    record = canonicalize_scene(_stop_scene(precipitation="Heavy Rain"), "U4_1/x.json",
                                notes=[])
    assert record["environment"]["weather_key"] == "Day_Rain"


def test_a_climate_text_that_is_no_label_is_still_an_error():
    from scenweave.ingest.issues import RecordIssue

    with pytest.raises(RecordIssue, match="neither a RT_DayPeriod code nor one of its labels"):
        canonicalize_scene(_stop_scene(day_period="dusk-ish"), "U4_1/x.json")


def test_fog_is_fog_in_the_scenario(tmp_path):
    record = canonicalize_scene(_stop_scene(fog=1), "U4_1/x.json")
    check_record(record)
    assert record["environment"]["weather_key"] == "Day_Fog"
    night = canonicalize_scene(_stop_scene(fog="yes", day_period=2), "U4_1/x.json", notes=[])
    assert night["environment"]["weather_key"] == "Night_Fog"
    params = extract_params(record) | {"spawn_id": 1, "ego_x": 0.0, "ego_y": 0.0, "ego_z": 0.0,
                                       "ego_h": 0.0, "tfl_x_carla": 10.0, "tfl_y_carla": 0.0,
                                       "spawn_stop_line_distance_m": 40.0,
                                       "spawn_tfl_distance_m": 45.0}
    out = corpus.generate(params, tmp_path / "fog.xosc")
    assert '<Fog visualRange="80.0"' in out.read_text()


@pytest.mark.parametrize("form", ["two elements", "a list"])
def test_a_light_changing_at_one_way_point_keeps_its_sequence(form):
    data = _stop_scene()
    point = data["environment"]["infrastructure"]["way_points"][1]
    point["infrastructure_elements"] = (
        [{"type": "TrafficSignType", "value": 170}, {"type": "TrafficSignType", "value": 172}]
        if form == "two elements" else [{"type": "TrafficSignType", "value": [170, 172]}])
    notes: list = []
    record = canonicalize_scene(data, "U4_1/x.json", notes=notes)
    check_record(record)
    (light,) = [s for s in record["infrastructure"]["traffic_signs"] if s["light_state"]]
    assert light["light_states"] == ["orange", "red"]
    assert light["light_state"] == "red"
    assert extract_params(record)["tfl_state"] == "red"
    assert bool(notes) == (form == "a list")


def test_a_folder_with_no_recognisable_data_is_a_warning(tmp_path):
    (tmp_path / "raw" / "notes").mkdir(parents=True)
    (tmp_path / "raw" / "notes" / "readme.txt").write_text("hello")
    report = ingest_directory(tmp_path / "raw", tmp_path / "out")
    assert report.records_written == 0
    (warning,) = report.issues
    assert warning.severity == "warning" and "no MOOVE data found" in warning.message

"""Another vehicle model for a recorded actor (``--vary``'s vehicles aspect): the free space
between the bumpers, which the record fixes, stays; the reference-point gaps params hold move."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from scenweave.ingest.variants import with_vehicle_type
from scenweave.inputs import InputSelection, load_input
from scenweave.scenario_lib.vehicles import VEHICLE_MODELS, bumper_gap_m, reference_gap_m

MODELS = [name for name in VEHICLE_MODELS if name != "ego"]


@given(st.floats(-80, 80, allow_nan=False), st.sampled_from(MODELS))
def test_bumper_gap_undoes_reference_gap(bumpers, model):
    assert bumper_gap_m(reference_gap_m(bumpers, model), model) == pytest.approx(bumpers,
                                                                                abs=1e-9)


def test_side_by_side_has_no_bumper_gap():
    assert bumper_gap_m(0.0, "truck") is None
    assert bumper_gap_m(reference_gap_m(0.0, "truck") - 0.1, "truck") is None


@pytest.fixture(scope="module")
def records(sample_raw) -> dict[str, list[dict]]:
    loaded = load_input(sample_raw / "highway", InputSelection(classes=("BRAKE", "FRF")))
    found: dict[str, list[dict]] = {}
    for params in loaded.params:
        found.setdefault(params["maneuver_class"], []).append(params)
    return found


def test_a_longer_lead_stands_farther_at_the_same_bumper_gap(records):
    brake = records["BRAKE"][0]
    other = "truck" if brake["npc_vehicle_type"] != "truck" else "van"
    changed = with_vehicle_type(brake, "npc", other)
    assert changed["npc_vehicle_type"] == other
    assert bumper_gap_m(changed["npc_distance_m"], other) == pytest.approx(
        bumper_gap_m(brake["npc_distance_m"], brake["npc_vehicle_type"]))
    growth = VEHICLE_MODELS[other].length_m - VEHICLE_MODELS[brake["npc_vehicle_type"]].length_m
    assert (changed["npc_distance_m"] - brake["npc_distance_m"]) * growth > 0
    assert changed["gap_ahead_m"] == max(changed["npc_distance_m"], 0.0)  # derived anew
    assert brake["npc_vehicle_type"] != other  # the record itself is left as it was


def test_only_the_changed_actors_gaps_move(records):
    """A free ride with two surrounding cars (the second copied from the first, 30 m on)."""
    free_ride = next(p for p in records["FRF"] if _slots(p))
    first = _slots(free_ride)[0]
    second = next(s for s in ("center", "right", "left") if s != first)
    two = {**free_ride, **{key.replace(first, second, 1): value for key, value
                           in free_ride.items() if key.startswith(f"{first}_")}}
    two[f"{second}_distance_m"] = free_ride[f"{first}_distance_m"] + 30.0
    model = "van" if two[f"{first}_vehicle_type"] != "van" else "truck"
    changed = with_vehicle_type(two, first, model)
    assert changed[f"{first}_distance_m"] != two[f"{first}_distance_m"]
    assert changed[f"{second}_distance_m"] == two[f"{second}_distance_m"]


def _slots(params: dict) -> list[str]:
    return [s for s in ("center", "right", "left") if params.get(f"{s}_present")]

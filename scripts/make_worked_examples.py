"""Remake ``corpus/worked_examples.json``: the example each reference script was written for.

The brake script's example is thesis Appendix B.3 (a BR_BK row); every other script's is the
seeded sample record (seed 15: not the demo's and benchmarks' 7, so an example is never the
record being adapted) of the first class that uses it. Each goes through the real extraction
and the Town04 spawn matcher, so the example carries its spawn keys like any record.
Run it when a script starts reading a new params key:

    .venv/bin/python scripts/make_worked_examples.py
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from scenweave import maneuvers
from scenweave.corpus.retrieval import script_path
from scenweave.corpus.worked_example import EXAMPLES_FILE
from scenweave.ingest.extract import extract_params
from scenweave.runner import default_matcher

#: thesis Appendix B.3, the worked example of the brake script (params as ingest types them)
THESIS_B3 = {
    "schema_version": "phase1.v1", "scenario_id": "BR_BK_B0_BRAKE_BINS_VALUES_row000042",
    "maneuver_class": "BR_BK", "maneuver_tag": "brake", "domain": "highway", "has_npc": True,
    "npc_position": "front", "binning_version": "B0",
    "source": {"file": "BRAKE_BINS_VALUES.npy", "row_index": 42}, "behavior_type": None,
    "params": {"ego_vel_kmh": 13.1, "lead_vel_kmh": 16.3, "duration_s": 0.6,
               "delta_vel_kmh": -0.08, "npc_distance_m": 11.7, "brake_intensity": 0.11,
               "other_dir_traffic": "Yes", "lead_vehicle_type": "Car"},
    "conventions": {"gaps_between": "bumpers"},
}
SEED = 15


def sample_records() -> dict[str, dict]:
    """class code -> its first seeded sample record, canonical."""
    from scenweave.ingest.batch import iter_raw_records
    from scenweave.ingest.issues import IngestReport
    from scenweave.ingest.samples import write_highway_samples, write_urban_samples

    with tempfile.TemporaryDirectory(prefix="scenweave-examples-") as tmp:
        raw = Path(tmp)
        write_highway_samples(raw / "highway", seed=SEED, per_class=1)
        write_urban_samples(raw / "urban", seed=SEED, per_class=1)
        records: dict[str, dict] = {}
        for found in iter_raw_records(raw, IngestReport()):
            records.setdefault(found.record["maneuver_class"], found.record)
        return records


def main() -> None:
    records = sample_records()
    matcher = default_matcher()
    examples: dict[str, dict] = {}
    for maneuver in maneuvers.maneuvers():
        name = script_path(maneuver).name
        if name in examples or maneuver.code not in records:
            continue
        record = THESIS_B3 if maneuver.tag == THESIS_B3["maneuver_tag"] else records[
            maneuver.code]
        examples[name] = matcher.assign(extract_params(record), 0)
    EXAMPLES_FILE.write_text(json.dumps(dict(sorted(examples.items())), indent=1) + "\n",
                             encoding="utf-8")
    print(f"{len(examples)} worked examples -> {EXAMPLES_FILE}")


if __name__ == "__main__":
    main()

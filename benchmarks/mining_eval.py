"""How well ``scenweave mine`` finds what is there: mined records against hand labels.

Mines the shared data (``../shared/data``: the NGSIM US-101 snippets and the urban ones),
matches every mined event to the labels in ``benchmarks/mining_labels/*.json`` one to one
(same file, same class, same ego and NPC, overlapping time windows; each label and each
event used once) and prints precision, recall and F1 per class, the events skipped as
unplayable (they count as found: detection is judged here, playability in
``benchmarks/fidelity.py``) and the duplicates: identical records (same class, vehicles and
fields), events dropped as repeats of an earlier file's, and events written twice across
overlapping files (two records of one class and vehicles whose ego series show the same
moments, judged from the records alone). A record seen in several files counts as found in
each (its provenance's ``also_in``).

A label is ``{"file": stem, "class": CODE, "ego": id, "npc": id|null, "start_s": s,
"end_s": s, "notes": why}``; every file in the folder is read, so each domain adds its own.

    .venv/bin/python benchmarks/mining_eval.py [DATA] [--labels DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # before benchmarks/, whose ingest.py would shadow the package

from scenweave import maneuvers  # noqa: E402
from scenweave.mining.mine import mine_recordings  # noqa: E402
from scenweave.mining.readers import read_recordings  # noqa: E402
from scenweave.mining.thresholds import load_thresholds  # noqa: E402
from scenweave.schemas.scenario_folder import MINING_REPORT_NAME  # noqa: E402

DEFAULT_DATA = ROOT.parent / "shared" / "data"
DEFAULT_LABELS = ROOT / "benchmarks" / "mining_labels"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", nargs="?", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--labels", type=Path, default=DEFAULT_LABELS)
    args = parser.parse_args()
    if not args.data.exists():
        print(f"mining_eval: skipped, no data at {args.data}")
        return
    labels = read_labels(args.labels)
    stems = {label["file"] for label in labels}
    with tempfile.TemporaryDirectory() as out:
        found, report = mined(args.data, Path(out), stems)
    for domain in ("highway", "urban"):
        judged = [label for label in labels if _domain(label["class"]) == domain]
        files = {label["file"] for label in judged}
        events = [e for e in found if _domain(e["class"]) == domain and e["file"] in files]
        if not judged:
            continue
        print(f"== {domain}: {len(judged)} labels in {len(files)} files; {len(events)} events "
              f"mined there ({sum(1 for e in events if e['skipped'])} of them skipped as "
              f"unplayable)")
        print_scores(judged, events)
        print_duplicates(events, report, files, domain)


def read_labels(folder: Path) -> list[dict]:
    labels = []
    for path in sorted(folder.glob("*.json")):
        labels += json.loads(path.read_text(encoding="utf-8"))
    return labels


def mined(data: Path, out: Path, stems: set[str]) -> tuple[list[dict], dict]:
    """Every event the mine found in the labelled files: written records and skipped ones,
    each as {file, class, ego, npc, start_s, end_s, params, skipped}."""
    recordings = (r for r in read_recordings(data) if Path(r.source).stem in stems)
    mine_recordings(recordings, out, load_thresholds())
    report = json.loads((out / MINING_REPORT_NAME).read_text(encoding="utf-8"))
    found = []
    for path in sorted(out.glob("*/*.json")):
        for record in json.loads(path.read_text(encoding="utf-8")):
            where = record["provenance"]
            for seen in [where, *where.get("also_in", [])]:  # one record, every file it is in
                found.append({"file": Path(seen["file"]).stem,
                              "class": record["maneuver_class"],
                              "ego": where["tracks"]["ego"], "npc": where["tracks"].get("npc"),
                              "start_s": seen["start_s"], "end_s": seen["end_s"],
                              "params": record.get("params"), "skipped": False,
                              "written": seen is where, "series": record.get("series", {})})
    for skip in report["skipped"]:
        found.append({**{k: skip.get(k) for k in ("class", "ego", "npc", "start_s", "end_s")},
                      "file": Path(skip["file"]).stem, "params": None, "skipped": True})
    return found, report


def matches(labels: list[dict], found: list[dict]) -> list[tuple[int, int]]:
    """One-to-one pairs (label, event): same file, class and vehicles, overlapping windows;
    the largest overlaps first."""
    candidates = []
    for i, label in enumerate(labels):
        for j, event in enumerate(found):
            if (label["file"], label["class"], str(label["ego"]), _id(label["npc"])) != \
                    (event["file"], event["class"], str(event["ego"]), _id(event["npc"])):
                continue
            overlap = min(label["end_s"], event["end_s"]) - max(label["start_s"],
                                                                event["start_s"])
            if overlap >= 0:
                candidates.append((-overlap, i, j))
    used_labels, used_events, pairs = set(), set(), []
    for _, i, j in sorted(candidates):
        if i not in used_labels and j not in used_events:
            used_labels.add(i)
            used_events.add(j)
            pairs.append((i, j))
    return pairs


def _domain(code: str) -> str:
    return maneuvers.get(code).domain


def _id(value) -> str | None:
    return None if value is None else str(value)


def print_scores(labels: list[dict], found: list[dict]) -> None:
    pairs = matches(labels, found)
    hit = Counter(labels[i]["class"] for i, _ in pairs)
    wanted = Counter(label["class"] for label in labels)
    got = Counter(event["class"] for event in found)
    print(f"{'class':<7}{'labels':>7}{'mined':>7}{'match':>7}{'prec':>7}{'recall':>8}{'F1':>7}")
    for code in sorted(set(wanted) | set(got)):
        p = hit[code] / got[code] if got[code] else float("nan")
        r = hit[code] / wanted[code] if wanted[code] else float("nan")
        f1 = 2 * p * r / (p + r) if p + r > 0 else float("nan")
        print(f"{code:<7}{wanted[code]:>7}{got[code]:>7}{hit[code]:>7}{p:>7.2f}{r:>8.2f}"
              f"{f1:>7.2f}" + ("" if wanted[code] >= 10 else "   (< 10 labels)"))
    matched_labels = {i for i, _ in pairs}
    matched_events = {j for _, j in pairs}
    for i, label in enumerate(labels):
        if i not in matched_labels:
            print(f"  missed: {_describe(label)}  ({label.get('notes', '')})")
    for j, event in enumerate(found):
        if j not in matched_events:
            print(f"  not labelled: {_describe(event)}")


def _describe(item: dict) -> str:
    return (f"{item['file']} {item['class']} ego {item['ego']} npc {item['npc']} "
            f"{item['start_s']:.1f}-{item['end_s']:.1f} s")


def print_duplicates(found: list[dict], report: dict, files: set[str], domain: str) -> None:
    written = [e for e in found if not e["skipped"] and e["written"]]
    keys = Counter((e["file"], e["class"], e["ego"], e["npc"],
                    json.dumps(e["params"], sort_keys=True)) for e in written)
    identical = sum(n - 1 for n in keys.values())
    print(f"identical duplicate records: {identical}")
    twice = written_twice(written)
    print(f"events written twice across overlapping files: {len(twice)}")
    for first, second in twice[:5]:
        print(f"  twice: {_describe(first)} and {_describe(second)}")
    repeats = [d for d in report.get("duplicates", []) if Path(d["file"]).stem in files
               and _domain(d["class"]) == domain]
    print(f"events dropped as repeats (same vehicles, same absolute time): {len(repeats)}")


#: two records show one moment when their ego's recorded speeds agree this well (m/s) ...
SAME_SPEED_MS = 0.02
#: ... over this many consecutive samples, varying by at least MIN_RANGE_MS
SAME_SAMPLES, MIN_RANGE_MS = 10, 0.3


def written_twice(written: list[dict]) -> list[tuple[dict, dict]]:
    """Pairs of written records of different files with the same class and vehicles whose
    ego series show the same moments (the same speeds sample by sample at some shift):
    one event written twice. Judged from the records alone, not from the mine's clock."""
    by_key: dict[tuple, list[dict]] = {}
    for event in written:
        by_key.setdefault((event["class"], str(event["ego"]), _id(event["npc"])), []).append(event)
    pairs = []
    for events in by_key.values():
        for i, first in enumerate(events):
            for second in events[i + 1:]:
                if first["file"] != second["file"] and _same_moments(first, second):
                    pairs.append((first, second))
    return pairs


def _same_moments(first: dict, second: dict) -> bool:
    a = [v for v in first["series"].get("ego_speed_raw_ms", []) if v is not None]
    b = [v for v in second["series"].get("ego_speed_raw_ms", []) if v is not None]
    for shift in range(-len(a) + SAME_SAMPLES, len(b) - SAME_SAMPLES + 1):
        run, values = 0, []
        for k, va in enumerate(a):
            j = k + shift
            if 0 <= j < len(b) and abs(va - b[j]) <= SAME_SPEED_MS:
                run, values = run + 1, values + [va]
                if run >= SAME_SAMPLES and max(values[-run:]) - min(values[-run:]) >= MIN_RANGE_MS:
                    return True
            else:
                run, values = 0, []
    return False


if __name__ == "__main__":
    main()

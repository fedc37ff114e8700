"""Readers of params with checked keys: ``schemas.params.Params`` is read-only, mypy knows its
keys, and the ``<actor>_<key>`` families go through ``actor_value`` whose suffix it knows too.
mypy is run on a copy of a real judge module with misspelt reads appended: each must be an
error, and the correctly spelt ones beside them must not."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import typing
from pathlib import Path

import pytest

from scenweave.schemas.params import (
    POSE_KEYS,
    SLOT_KEYS,
    ActorKey,
    actor_value,
    all_finite,
    finite,
)

ROOT = Path(__file__).resolve().parents[2]

#: appended to judge/fidelity.py: (line, error expected)
PROBES = (
    ("def _probe(check: _Check, doc: ScenarioDoc) -> object:", False),
    ("    params = check.params", False),
    ("    good = (params['ego_speed_ms'], finite(params.get('ego_speed_ms')),", False),
    ("            actor_value(params, 'npc', 'speed_ms'), placed_actors(params))", False),
    ("    misspelt = params['ego_sped_ms']", True),
    ("    got = finite(params.get('ego_sped_ms'))", True),
    ("    family = actor_value(params, 'npc', 'sped_ms')", True),
    ("    params['ego_speed_ms'] = 1.0", True),
    ("    made = fidelity(doc, {'ego_sped_ms': 1.0})", True),
    ("    return good, misspelt, got, family, made", False),
)


def _typecheck_module():
    spec = importlib.util.spec_from_file_location("typecheck", ROOT / "scripts" / "typecheck.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_mypy_flags_a_misspelt_params_key_in_the_judge(tmp_path):
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy is not installed (the dev extra has it)")
    tree = _typecheck_module().build_tree(tmp_path / "tree")
    source = (ROOT / "judge" / "fidelity.py").read_text(encoding="utf-8")
    first = len(source.splitlines()) + 1
    probe = tree / "judge_probe.py"
    probe.write_text(source + "\n" + "\n".join(line for line, _ in PROBES) + "\n",
                     encoding="utf-8")
    done = subprocess.run([sys.executable, "-m", "mypy", "--config-file",
                           str(ROOT / "pyproject.toml"), "--cache-dir",
                           str(tmp_path / "cache"), probe.name],
                          cwd=tree, capture_output=True, text=True, timeout=600)
    flagged = {int(line.split(":")[1]) for line in done.stdout.splitlines()
               if line.startswith(f"{probe.name}:") and ": error:" in line}
    expected = {first + 1 + i for i, (_, error) in enumerate(PROBES) if error}
    assert flagged == expected, done.stdout + done.stderr
    assert "has no key \"ego_sped_ms\"" in done.stdout
    assert "ReadOnly TypedDict key \"ego_speed_ms\"" in done.stdout


def test_the_family_suffixes_mypy_knows_are_the_contracts():
    suffixes: set[str] = set()
    for part in typing.get_args(ActorKey):
        suffixes |= set(typing.get_args(part)) or {part}
    assert suffixes == set(SLOT_KEYS) | set(POSE_KEYS)


def test_actor_value_reads_the_family_key_and_none_when_absent():
    params = {"npc_speed_ms": 12.5, "center_present": True, "ego_road_id": 7}
    assert actor_value(params, "npc", "speed_ms") == 12.5
    assert actor_value(params, "center", "present") is True
    assert actor_value(params, "ego", "road_id") == 7
    assert actor_value(params, "lead", "speed_ms") is None


@pytest.mark.parametrize(("values", "wanted"), [
    ((1, 2.5), (1.0, 2.5)), ((1.0, None), None), ((float("nan"), 1.0), None),
    ((True, 1.0), None), (("3", 1.0), None), ((), ())])
def test_all_finite_needs_every_value_a_finite_number(values, wanted):
    assert all_finite(*values) == wanted


def test_finite_is_none_for_what_is_no_finite_number():
    assert finite(3) == 3.0 and isinstance(finite(3), float)
    assert [finite(v) for v in (None, float("inf"), True, "1.0")] == [None] * 4

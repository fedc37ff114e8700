"""The reference scripts run unchanged in the sandbox, importing the read-only scenario library
(`scenweave.scenario_lib`), the only package of ours the sandbox has."""

from __future__ import annotations

import pytest
from lxml import etree

from scenweave.corpus import list_scripts
from tests.corpus.params_examples import example_params

#: one highway and one urban script: both paths through make_scenario
CASES = [("BRAKE", "gen_hw_brake.py"), ("U4_1", "gen_ur_stop_at_tfl_red.py")]


@pytest.mark.parametrize("code, script", CASES)
def test_reference_script_produces_its_scenario(make_box, tmp_path, code, script):
    source = next(path for path in list_scripts() if path.name == script).read_text()
    box = make_box(wall_time_s=30)  # the attack suite's 4 s is too tight for a busy CI machine
    result = box.run(source, example_params(code), tmp_path)
    assert result.ok, result.traceback or result.stderr
    root = etree.parse(str(tmp_path / "scenario.xosc")).getroot()
    assert root.tag == "OpenSCENARIO"
    assert result.files == [tmp_path / "scenario.xosc"]


#: which of our packages a script can import in the sandbox
PROBE = """
import importlib
def generate(params, out_path):
    found = []
    for name in params["names"]:
        try:
            importlib.import_module(name)
            found.append(name)
        except ImportError:
            pass
    open(out_path, "w").write(" ".join(found))
"""


def test_the_scenario_library_is_the_only_package_of_ours(box, tmp_path):
    names = ["scenweave.scenario_lib", "scenweave.scenario_lib.builder",
             "scenweave.scenario_lib.kinematics", "scenweave.scenario_lib.phases",
             "scenweave.corpus", "scenweave.corpus.retrieval", "scenweave.errors",
             "scenweave.maneuvers", "scenweave.sandbox"]
    result = box.run(PROBE, {"names": names}, tmp_path)
    assert result.ok, result.traceback or result.stderr
    assert (tmp_path / "scenario.xosc").read_text().split() == names[:4]

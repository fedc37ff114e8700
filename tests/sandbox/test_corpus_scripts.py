"""The reference scripts run unchanged in the sandbox, importing the read-only `corpus`."""

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

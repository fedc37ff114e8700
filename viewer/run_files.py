"""The names of the files a run folder holds, as the application shell writes them.

The shell (``scenweave.run_folder``, ``scenweave.presentation.report``) sits above the
viewer, which it starts, so the viewer cannot import them from there; tests/viewer checks
that these names match the shell's.
"""

from __future__ import annotations

from scenweave.agent.trace import CODE_NAME, PARAMS_NAME, TRACE_NAME, XOSC_NAME
from scenweave.player import REPLAY_NAME

RUN_NAME = "run.json"
SUMMARY_NAME = "summary.json"
STATUS_NAME = "status.json"
RECORDED_NAME = "recorded.json"
REPORT_NAME = "report.html"
#: a mined record folder's report, beside the records a run was made from
MINING_REPORT_NAME = "mining_report.html"
VARIANTS_DIR = "variants"
VARIANT_NAME = "variant.json"

#: the files of a scenario folder the page lists and serves, in this order
SCENARIO_FILES = (XOSC_NAME, CODE_NAME, PARAMS_NAME, STATUS_NAME, TRACE_NAME, REPLAY_NAME,
                  RECORDED_NAME, "reference.xosc", VARIANT_NAME)

__all__ = ["CODE_NAME", "MINING_REPORT_NAME", "PARAMS_NAME", "RECORDED_NAME", "REPLAY_NAME",
           "REPORT_NAME", "RUN_NAME", "SCENARIO_FILES", "STATUS_NAME", "SUMMARY_NAME",
           "TRACE_NAME", "VARIANTS_DIR", "VARIANT_NAME", "XOSC_NAME"]

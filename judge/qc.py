"""The ASAM OpenSCENARIO quality checker (``qc_openscenario``), run in-process on one file."""

from __future__ import annotations

import logging
from pathlib import Path

from scenweave.judge.findings import Finding


def run_asam_qc(path: Path | str) -> list[Finding]:
    """Every issue the ASAM checker bundle reports for ``path`` (ASAM_QC findings)."""
    # the ASAM checker packages ship neither type hints (py.typed) nor stubs
    from qc_baselib import Configuration, Result
    from qc_openscenario import constants
    from qc_openscenario.main import run_checks

    config = Configuration()
    config.set_config_param("InputFile", str(path))
    config.register_checker_bundle(constants.BUNDLE_NAME)
    result = Result()
    result.register_checker_bundle(name=constants.BUNDLE_NAME, description="ScenWeave QC",
                                   version=constants.BUNDLE_VERSION, summary="")
    quiet = logging.getLogger().level
    logging.getLogger().setLevel(logging.WARNING)  # the bundle logs every check at INFO
    try:
        run_checks(config, result)
    finally:
        logging.getLogger().setLevel(quiet)
    findings: list[Finding] = []
    for checker in result.get_checker_ids(constants.BUNDLE_NAME):
        for issue in result.get_issues(constants.BUNDLE_NAME, checker):
            findings.append(Finding("ASAM_QC", f"{checker}: {issue.description}",
                                    "error" if "ERROR" in str(issue.level) else "warning"))
    return findings

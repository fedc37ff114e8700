"""The judge: does a scenario say, and when played do, what its record says?

``validate_xosc(path, params)`` is the one entry: the auto-fix rules (thesis Table 5.7), the
OpenSCENARIO 1.0 XSD (``schemas.xsd``), structural and semantic checks (``checks``), parameter
fidelity (``fidelity``: every number read back from the file), the CARLA scenario_runner lint
(``carla_lint``) and, given replay settings, the replay in esmini judged sample by sample
(``replay``); ``variation`` decides whether an LLM's variant kept what the record fixes;
``in_situ`` judges an in-situ replay (every recorded vehicle on its recorded road) against
the raw record.
Every finding is a :class:`Finding` with a code (docs/scenario-conventions.md lists them).
The contracts it judges against (the params contract, the XSD, the JSON Schemas) live in
``schemas``.
"""

from __future__ import annotations

from scenweave.judge.findings import Finding, ValidationResult, failure_category
from scenweave.judge.qc import run_asam_qc
from scenweave.judge.validate_xosc import validate_tree, validate_xosc

__all__ = ["Finding", "ValidationResult", "failure_category", "run_asam_qc", "validate_tree",
           "validate_xosc"]

"""``validate_xosc``: auto-fix, XSD 1.0, Table 5.8 checks, semantics, fidelity, CARLA lint.

The file is read once, the five auto-fix rules rewrite it (atomically, only when something
changed), and every check runs on the one parsed tree, so a validation costs milliseconds.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

from lxml import etree

from scenweave.files import write_text_atomic
from scenweave.judge.autofix import apply_fixes
from scenweave.judge.carla_lint import carla_lint
from scenweave.judge.checks import detect_domain, semantics, structural
from scenweave.judge.fidelity import fidelity
from scenweave.judge.findings import Finding, ValidationResult
from scenweave.judge.replay import replay_verdict
from scenweave.judge.scenario_doc import ScenarioDoc
from scenweave.schemas.params import Params
from scenweave.schemas.scenario_folder import ReplaySummary
from scenweave.schemas.xsd import osc_1_0_schema

if TYPE_CHECKING:  # the player loads esmini's bindings: imported only when a file is played
    from scenweave.player import ReplaySettings

DESCRIPTION_CLASS = re.compile(r"^ScenWeave (?P<code>[A-Z][A-Z0-9_]*)\b")


def validate_xosc(path: Path | str, params: Params | None = None, *,
                  fix: bool = True, replay: ReplaySettings | None = None,
                  map_path: Path | None = None) -> ValidationResult:
    """Validate one ``.xosc`` (fixing it in place first unless ``fix=False``).

    With ``params`` the scenario's values are checked against them (parameter fidelity) and
    the manoeuvre class and domain come from them; without, they are read from the file.
    With ``replay`` (``player.ReplaySettings``) and params, a file that passes every static
    check is also played headless on ``map_path`` (default: the map params ``map`` names, else
    the file's ``LogicFile``, else Town04) and judged
    against the params (``REPLAY_*``, ``judge.replay``); ``result.playback`` holds what
    happened and ``result.verdict`` the judge's verdict on it (``result.write_replay``).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        return _invalid(Finding("UNREADABLE", f"{path}: {err}"))
    fixes: list[str] = []
    if fix:
        text, fixes = apply_fixes(text)
        if fixes:
            write_text_atomic(path, text)
    try:
        tree = etree.ElementTree(etree.fromstring(text.encode("utf-8"),
                                                 etree.XMLParser(remove_blank_text=False)))
    except etree.XMLSyntaxError as err:
        return _invalid(Finding("XML_SYNTAX", str(err), "error", err.lineno), fixes)
    result = validate_tree(tree, params, fixes)
    if replay is not None and params and result.valid:
        _replay_and_judge(result, path, tree, params, replay, map_path)
    return result


def _replay_and_judge(result: ValidationResult, path: Path, tree: etree._ElementTree,
                      params: Params, settings: ReplaySettings,
                      map_path: Path | None) -> None:
    from scenweave import player

    doc = ScenarioDoc(tree, params.get("map"))
    map_path = map_path or doc.map_path
    if map_path is None:
        result.errors.append(Finding("REPLAY_MAP", f"LogicFile {doc.logic_file!r} names no "
                                     "known map: nothing to play the scenario on"))
        result.valid = False
        return
    playback = player.replay_file(path, map_path, settings)
    findings, result.verdict = replay_verdict(playback, params, doc, map_path)
    result.errors += findings
    result.valid = not any(f.severity == "error" for f in result.errors)
    result.playback = playback
    summary: ReplaySummary = {"played": not playback.engine_error, "passed": not findings,
                              "codes": sorted({f.code for f in findings}),
                              "timings_s": playback.timings_s}
    if playback.series_errors:
        summary["series_errors"] = playback.series_errors
    result.replay = summary


def validate_tree(tree: etree._ElementTree, params: Params | None = None,
                  fixes: list[str] | None = None) -> ValidationResult:
    """Every check on a parsed scenario (``validate_xosc`` without the file and the fixes)."""
    doc = ScenarioDoc(tree, (params or {}).get("map"))
    domain = (params or {}).get("domain") or detect_domain(doc)
    code = (params or {}).get("maneuver_class") or _class_from_header(doc)
    findings = structural(doc, domain, code)
    if doc.root.tag == "OpenSCENARIO":
        findings = xsd_findings(tree) + findings
        findings += semantics(doc, code, params)
        findings += carla_lint(doc)
        if params:
            findings += fidelity(doc, params)
    valid = not any(f.severity == "error" for f in findings)
    return ValidationResult(valid, list(fixes or []), findings, domain)


def _class_from_header(doc: ScenarioDoc) -> str | None:
    header = doc.root.find("FileHeader")
    match = DESCRIPTION_CLASS.match(header.get("description") or "") if header is not None \
        else None
    return match.group("code") if match else None


def _invalid(finding: Finding, fixes: list[str] | None = None) -> ValidationResult:
    return ValidationResult(False, list(fixes or []), [finding], None)


def xsd_findings(tree: etree._ElementTree) -> list[Finding]:
    """One XSD_INVALID finding per violation of the OpenSCENARIO 1.0 schema, with its line."""
    schema = osc_1_0_schema()
    if schema.validate(tree):
        return []
    # lxml-stubs 0.5.1 declare the error log as an empty class; lxml's iterates over its entries
    return [Finding("XSD_INVALID", entry.message, "error", entry.line)
            for entry in schema.error_log]  # type: ignore[attr-defined]

"""The host side without a sandbox: report vetting, output capping, settings, selection."""

from __future__ import annotations

import base64
import json
import os

import pytest

from scenweave import sandbox
from scenweave.sandbox.capture import CappedBuffer
from scenweave.sandbox.result import ReportInvalid, read_report, safe_relative_name, write_files


def _report(tmp_path, payload) -> os.PathLike:
    path = tmp_path / "result.json"
    path.write_text(payload if isinstance(payload, str) else json.dumps(payload))
    return path


def _read(path, max_bytes=1000, max_files=4):
    return read_report(path, max_bytes, max_files, wall_time_s=60)


def test_a_well_formed_report_is_read(tmp_path):
    data = base64.b64encode(b"<xosc/>").decode()
    report = _read(_report(tmp_path, {"error_type": "KeyError", "error_message": "'a'",
                                      "traceback": "tb", "script_duration_s": 1.5,
                                      "files": [{"name": "sub/scenario.xosc", "data": data}]}))
    assert (report.error_type, report.error_message, report.script_duration_s) == \
        ("KeyError", "'a'", 1.5)
    assert report.files == {"sub/scenario.xosc": b"<xosc/>"}


@pytest.mark.parametrize("payload, reason", [
    ("", "no report"),
    ("{not json", "not JSON"),
    ("[1, 2]", "not an object"),
    ("[" * 100_000 + "]" * 100_000, "not JSON: RecursionError"),
    ("x" * 1_002_000, "exceeds the output limit"),
    ({"files": "x"}, "no list"),
    ({"files": [{"name": "a", "data": "@@@"}]}, "not base64"),
    ({"files": [{"name": "a", "data": base64.b64encode(b"x" * 2000).decode()}]},
     "exceed the output limit"),
    ({"files": [{"name": f"f{i}", "data": ""} for i in range(5)]}, "more than 4 files"),
])
def test_malformed_reports_are_refused(tmp_path, payload, reason):
    with pytest.raises(ReportInvalid, match=reason):
        _read(_report(tmp_path, payload))


def test_a_report_that_is_a_link_is_refused(tmp_path):
    (tmp_path / "result.json").symlink_to("/etc/passwd")
    with pytest.raises(ReportInvalid, match="no report"):
        _read(tmp_path / "result.json")


def test_untrusted_fields_are_typed_and_clamped(tmp_path):
    report = _read(_report(tmp_path, {"error_type": ["list"], "error_message": "m" * 10_000,
                                      "script_duration_s": 1e308, "traceback": None}))
    assert report.error_type == "['list']"
    assert len(report.error_message) == 4000
    assert report.script_duration_s == 60
    assert _read(_report(tmp_path, {"script_duration_s": True})).script_duration_s is None


@pytest.mark.parametrize("name", ["../x", "/etc/passwd", "a/../../b", "", "a\0b", "a\\b",
                                  "a/b/c/d/e", "x" * 201, 7, "."])
def test_unsafe_names_are_refused(name):
    with pytest.raises(ReportInvalid, match="unsafe file name"):
        safe_relative_name(name)


def test_files_are_written_beside_a_planted_link_not_through_it(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("untouched")
    out = tmp_path / "out"
    out.mkdir()
    (out / "scenario.xosc").symlink_to(victim)
    (out / "sub").symlink_to(tmp_path)
    assert write_files({"scenario.xosc": b"new"}, out) == [out / "scenario.xosc"]
    assert victim.read_text() == "untouched" and (out / "scenario.xosc").read_text() == "new"
    with pytest.raises(ReportInvalid, match="not a folder"):
        write_files({"sub/evil": b"x"}, out)
    assert not (tmp_path / "evil").exists()


def test_capped_buffer_keeps_head_and_tail():
    buffer = CappedBuffer(10)
    for chunk in (b"HEAD", b"-" * 1000, b"...", b"TAIL"):
        buffer.feed(chunk)
    text = buffer.text()
    assert text.startswith("HEAD-") and text.endswith(".TAIL")
    assert "1001 bytes cut" in text
    small = CappedBuffer(10)
    small.feed(b"short")
    assert small.text() == "short"


@pytest.mark.parametrize("field, value", [("backend", "qemu"), ("wall_time_s", 0),
                                          ("memory_mb", -1), ("pids", 0)])
def test_bad_settings_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        sandbox.SandboxSettings(**{field: value})


def test_backend_names_are_the_cli_choices():
    assert sandbox.backend_names() == ("docker", "bwrap", "auto")


def test_auto_falls_back_to_bwrap_when_no_engine_answers(tmp_path):
    settings = sandbox.SandboxSettings(docker_host=f"unix://{tmp_path}/no-engine.sock")
    reasons = sandbox.check_backends(settings)
    assert "no container engine answers" in reasons["docker"]
    assert "SandboxSettings.docker_host" in reasons["docker"]
    if reasons["bwrap"] is None:
        assert sandbox.get_sandbox(settings).name == "bwrap"
    else:
        with pytest.raises(sandbox.SandboxUnavailable, match="no sandbox backend works"):
            sandbox.get_sandbox(settings)


def test_missing_image_names_the_build_command(engine_url):
    settings = sandbox.SandboxSettings(backend="docker", docker_host=engine_url,
                                       image="localhost/scenweave-no-such-image:0")
    with pytest.raises(sandbox.ImageNotFound, match="scripts/setup.d/20-sandbox.sh"):
        sandbox.get_sandbox(settings)


def test_params_that_are_not_json_are_a_clear_error(tmp_path):
    box = sandbox.get_sandbox(sandbox.SandboxSettings(backend="bwrap"))
    with pytest.raises(ValueError, match="params: not JSON"):
        box.run("def generate(p, o): pass", {"when": object()}, tmp_path)


def test_an_unwritable_output_folder_is_an_infrastructure_error(tmp_path):
    (tmp_path / "scenario.xosc").mkdir()  # the host's folder is in the way, not the script
    box = sandbox.get_sandbox(sandbox.SandboxSettings(backend="bwrap"))
    code = "def generate(p, out_path):\n    open(out_path, 'w').write('x')\n"
    with pytest.raises(sandbox.SandboxError, match="cannot write the script's outputs"):
        box.run(code, {}, tmp_path)

"""The host side without a sandbox: report vetting, output capping, settings, selection."""

from __future__ import annotations

import base64
import json
import os

import pytest

from scenweave import sandbox
from scenweave.sandbox.capture import CappedBuffer
from scenweave.sandbox.result import (
    ReportInvalid,
    name_problem,
    read_report,
    write_files,
)
from scenweave.sandbox.settings import OUTPUT_NAMES


def _report(tmp_path, payload) -> os.PathLike:
    path = tmp_path / "result.json"
    path.write_text(payload if isinstance(payload, str) else json.dumps(payload))
    return path


def _read(path, max_bytes=1000, max_files=4):
    return read_report(path, max_bytes, max_files, wall_time_s=60, allowed=OUTPUT_NAMES)


def _entry(name, data=b"x"):
    return {"name": name, "data": base64.b64encode(data).decode()}


def test_a_well_formed_report_is_read(tmp_path):
    data = base64.b64encode(b"<xosc/>").decode()
    report = _read(_report(tmp_path, {"error_type": "KeyError", "error_message": "'a'",
                                      "traceback": "tb", "script_duration_s": 1.5,
                                      "files": [{"name": "scenario.xosc", "data": data}]}))
    assert (report.error_type, report.error_message, report.script_duration_s) == \
        ("KeyError", "'a'", 1.5)
    assert report.files == {"scenario.xosc": b"<xosc/>"}
    assert report.warnings == []


@pytest.mark.parametrize("payload, reason", [
    ("", "no report"),
    ("{not json", "not JSON"),
    ("[1, 2]", "not an object"),
    ("[" * 100_000 + "]" * 100_000, "not JSON: RecursionError"),
    ("x" * 1_002_000, "exceeds the output limit"),
    ({"files": "x"}, "not a list"),
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


@pytest.mark.parametrize("name, reason", [
    ("../x.xosc", "a path"), ("/etc/passwd.xosc", "a path"), ("sub/a.xosc", "a path"),
    ("a\\b.xosc", "a path"), ("..", "starts with '-' or '.'"), (".", "starts with"),
    (".hidden.xosc", "starts with"), ("-rf.xosc", "starts with"), ("", "not only ASCII"),
    ("a\0b.xosc", "not only ASCII"), ("a\nb.xosc", "not only ASCII"), ("é.xosc", "not only ASCII"),
    ("\udcff.xosc", "not only ASCII"), ("x" * 97 + ".xosc", "longer than 100"),
    ("evil.sh", "not one of SandboxSettings.output_names"), (7, "not text"),
])
def test_refused_output_names_say_why(name, reason):
    assert reason in name_problem(name, OUTPUT_NAMES)


@pytest.mark.parametrize("name", ["scenario.xosc", "other_2.xosc", "road.xodr", "notes.txt",
                                  "x" * 95 + ".xosc"])
def test_plain_allowed_names_are_taken(name):
    assert name_problem(name, OUTPUT_NAMES) is None


def test_each_refused_output_is_dropped_alone_with_a_warning(tmp_path):
    entries = [_entry("scenario.xosc", b"<xosc/>"), _entry("a\nb.xosc"), _entry("-rf.xosc"),
               {"name": "bad64.xosc", "data": "@@@"}, "not an entry", _entry("scenario.xosc"),
               _entry("big.xosc", b"x" * 2000), *(_entry(f"f{i}.txt") for i in range(5))]
    report = _read(_report(tmp_path, {"files": entries}))
    assert report.files == {"scenario.xosc": b"<xosc/>", "f0.txt": b"x", "f1.txt": b"x",
                            "f2.txt": b"x"}
    assert report.warnings == [
        "dropped output 'a\\nb.xosc': not only ASCII letters, digits, '_', '.' and '-'",
        "dropped output '-rf.xosc': starts with '-' or '.'",
        "dropped output 'bad64.xosc': its data is not base64",
        "dropped output <NoneType>: the name is not text",
        "dropped output 'scenario.xosc': listed twice",
        "dropped output 'big.xosc': outputs would exceed SandboxSettings.output_max_bytes (1000)",
        "dropped output 'f3.txt': more than SandboxSettings.output_max_files (4) outputs",
        "dropped output 'f4.txt': more than SandboxSettings.output_max_files (4) outputs"]


def test_warnings_about_a_flood_of_outputs_are_capped(tmp_path):
    report = _read(_report(tmp_path, {"files": [_entry(f"-{i}") for i in range(1000)]}))
    assert report.files == {} and len(report.warnings) == 21
    assert report.warnings[-1] == "... and 980 more outputs dropped"


def test_files_are_written_beside_a_planted_link_not_through_it(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("untouched")
    out = tmp_path / "out"
    out.mkdir()
    (out / "scenario.xosc").symlink_to(victim)
    assert write_files({"scenario.xosc": b"new"}, out) == [out / "scenario.xosc"]
    assert victim.read_text() == "untouched" and (out / "scenario.xosc").read_text() == "new"


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
                                          ("memory_mb", -1), ("pids", 0),
                                          ("output_names", ()), ("output_names", ("",))])
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

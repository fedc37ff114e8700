"""``scenweave sandbox check`` against the real backends."""

from __future__ import annotations

import json

from click.testing import CliRunner

from scenweave.cli import cli


def test_check_reports_both_backends_working(engine_url):
    result = CliRunner().invoke(cli, ["sandbox", "check", "--docker-host", engine_url, "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["backends"]["docker"] == {"works": True, "reason": None}
    assert report["backends"]["bwrap"] == {"works": True, "reason": None}
    assert report["auto"] == "docker"


def test_check_says_why_a_backend_does_not_work(tmp_path):
    result = CliRunner().invoke(cli, ["sandbox", "check", "--docker-host",
                                      f"unix://{tmp_path}/none.sock", "--python",
                                      str(tmp_path / "no-python")])
    assert result.exit_code == 1
    assert "docker: unavailable: no container engine answers" in result.output
    assert "bwrap: unavailable: sandbox Python" in result.output
    assert result.output.rstrip().endswith("--sandbox auto picks nothing")

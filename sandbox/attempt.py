"""One attempt's staging: the job folder a sandbox mounts, the report it writes, the mounts and
environment every backend uses, and how a raw run becomes an ``ExecResult``."""

from __future__ import annotations

import json
import logging
import os
import shutil
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenweave.sandbox.errors import SandboxError
from scenweave.sandbox.result import (
    ExecResult,
    Report,
    ReportInvalid,
    phase_timings,
    read_report,
    write_files,
)
from scenweave.sandbox.settings import SandboxSettings

log = logging.getLogger(__name__)

HARNESS = Path(__file__).with_name("harness.py")
#: the only environment a sandboxed script sees (nothing from the host)
SANDBOX_ENV = {
    "PATH": "/opt/venv/bin:/usr/bin:/bin",
    "LANG": "C.UTF-8",
    "HOME": "/tmp",
    "MPLCONFIGDIR": "/tmp",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "PYTHONDONTWRITEBYTECODE": "1",
    "PYTHONUNBUFFERED": "1",
}
#: paths inside the sandbox (the harness hard-codes the same ones)
JOB_MOUNT = "/sandbox/job"
RESULT_MOUNT = "/sandbox/result.json"
LIBRARY_MOUNT = "/sandbox/lib/scenweave/scenario_lib"
OUT_MOUNT = "/out"


@dataclass
class RawRun:
    """What a backend observed from outside: exit code, captured output, timing."""

    exit_code: int | None
    stdout: str
    stderr: str
    timed_out: bool
    duration_s: float
    ended_at: float  # wall clock once the sandbox was gone


class Attempt:
    """A private staging folder for one run: ``job/`` (harness, script, params) and the report.

    ``job/`` is mounted read-only; the report file is the only host file the sandbox can
    write, and the file-size limit bounds it. A warm sandbox starts before the job is
    loaded and waits for the ``go`` file.
    """

    def __init__(self, settings: SandboxSettings) -> None:
        self.settings = settings
        self.root = Path(tempfile.mkdtemp(prefix="scenweave-sbx-", dir=settings.work_dir))
        self.root.chmod(0o755)  # the unprivileged sandbox uid must reach job/
        self.job = self.root / "job"
        self.job.mkdir(mode=0o755)
        self._write(HARNESS.name, HARNESS.read_text(encoding="utf-8"))
        self.report = self.root / "result.json"
        self.report.touch(mode=0o600)
        if os.geteuid() == 0:
            os.chown(self.report, settings.sandbox_uid, settings.sandbox_uid)
        else:
            self.report.chmod(0o666)

    def load(self, code: str, params_json: str) -> None:
        """Put the script and its params where the harness reads them."""
        self._write("script.py", code)
        self._write("params.json", params_json)

    def go(self) -> None:
        """Tell a waiting (warm) harness that the job is complete."""
        self._write("go", "")

    def _write(self, name: str, text: str) -> None:
        path = self.job / name
        path.write_text(text, encoding="utf-8")
        path.chmod(0o644)

    def harness_command(self, python: str, warm: bool) -> list[str]:
        """The command line that starts the harness inside the sandbox."""
        command = [python, "-I", f"{JOB_MOUNT}/harness.py", str(self.settings.output_max_bytes)]
        return [*command, "--warm", str(self.settings.warm_idle_s)] if warm else command

    def outcome(self, raw: RawRun, out_dir: Path, backend: str, began_at: float) -> ExecResult:
        """Turn what the backend saw plus the (vetted) report into an :class:`ExecResult`;
        ``began_at`` is the wall clock when the host began the attempt."""
        result = ExecResult(exit_code=raw.exit_code, stdout=raw.stdout, stderr=raw.stderr,
                            timed_out=raw.timed_out, duration_s=raw.duration_s, backend=backend)
        s = self.settings
        collecting = time.time()
        try:
            report = read_report(self.report, s.output_max_bytes, s.output_max_files,
                                 raw.duration_s, s.output_names)
            result.files = write_files(report.files, out_dir)
        except ReportInvalid as err:
            report = Report(error_type="NoReport",
                            error_message=f"the script left no valid report ({err})")
        except OSError as err:
            raise SandboxError(f"cannot write the script's outputs into {out_dir}: {err}") from err
        result.script_duration_s = report.script_duration_s
        result.error_type = report.error_type
        result.error_message = report.error_message
        result.traceback = report.traceback
        result.warnings = report.warnings
        for warning in report.warnings:
            log.warning("%s sandbox: %s", backend, warning)
        result.timings = phase_timings(began_at, report.marks, raw.ended_at,
                                       time.time() - collecting)
        self._explain_kill(result)
        return result

    def _explain_kill(self, result: ExecResult) -> None:
        s = self.settings
        if result.timed_out:
            result.error_type = "Timeout"
            result.error_message = (f"killed after the wall-time limit of {s.wall_time_s:g} s "
                                    "(SandboxSettings.wall_time_s)")
        elif result.exit_code == 137 and result.error_type in (None, "NoReport"):
            result.error_type = "Killed"
            result.error_message = ("killed by SIGKILL, most likely at the memory limit of "
                                    f"{s.memory_mb} MiB (SandboxSettings.memory_mb)")
        elif result.exit_code != 0 and result.error_type is None:
            result.error_type = "NonZeroExit"
            result.error_message = f"the sandbox exited with code {result.exit_code}"

    def close(self) -> None:
        """Delete the staging folder (only our files and the report live there)."""
        shutil.rmtree(self.root, ignore_errors=True)


def params_to_json(params: Mapping[str, Any]) -> str:
    """``params`` as JSON text; ValueError naming ``params`` when it cannot be."""
    try:
        return json.dumps(params)
    except (TypeError, ValueError) as err:
        raise ValueError(f"params: not JSON-serialisable: {err}") from err

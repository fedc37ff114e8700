"""Runs inside the sandbox: import the LLM-written script, call ``generate``, report back.

Standard library only, and never imported by the host: the host mounts this file into the
sandbox. It writes one JSON document to the result file: the script's error (type, message,
traceback), its own duration and the files it left in the output folder (base64). The script
runs in this same process and can tamper with all of it, so the host trusts nothing it reads.
"""

import base64
import contextlib
import ctypes
import errno
import importlib.util
import json
import os
import stat
import struct
import sys
import time
import traceback
from typing import Any

JOB = "/sandbox/job"
LIB = "/sandbox/lib"  # holds the read-only `scenweave.scenario_lib` package
RESULT = "/sandbox/result.json"
OUT = "/out"
SCENARIO = OUT + "/scenario.xosc"
GO = JOB + "/go"
#: what every reference script imports: a warm sandbox imports them while it waits
WARM_IMPORTS = ("scenariogeneration", "scenweave.scenario_lib.builder")
#: machine -> (audit arch, unshare, clone, clone3): what the seccomp filter needs to know
SYSCALLS = {"x86_64": (0xC000003E, 272, 56, 435), "aarch64": (0xC00000B7, 97, 220, 435)}
CLONE_NEWUSER = 0x10000000
PR_SET_SECCOMP, SECCOMP_MODE_FILTER, PR_SET_NO_NEW_PRIVS = 22, 2, 38
LOAD, JEQ, JGE, JSET, RET = 0x20, 0x15, 0x35, 0x45, 0x06  # classic BPF opcodes (with K)
ALLOW, DENY, NOSYS = 0x7FFF0000, 0x00050000 | errno.EPERM, 0x00050000 | errno.ENOSYS


class SockFprog(ctypes.Structure):
    _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]


def forbid_user_namespaces() -> None:
    """Refuse new user namespaces to this process and all it starts (seccomp, irrevocable).

    In one the script could mount a tmpfs of its own, i.e. write where the sandbox allows
    nothing; podman's default seccomp profile permits it. bwrap's --disable-userns does the
    same for that backend; this covers both. clone3 answers ENOSYS (libc falls back to clone,
    whose flags a filter can see); other ABIs' calls are refused.
    """
    machine = os.uname().machine
    if machine not in SYSCALLS:
        raise OSError(f"harness: no seccomp syscall table for machine {machine}")
    arch, unshare, clone, clone3 = SYSCALLS[machine]
    program = [(LOAD, 0, 0, 4), (JEQ, 1, 0, arch), (RET, 0, 0, DENY),  # 0-2: native ABI only
               (LOAD, 0, 0, 0), (JGE, 6, 0, 0x40000000),  # 3-4: x32 numbers: deny
               (JEQ, 5, 0, unshare), (JEQ, 5, 0, clone3), (JEQ, 0, 2, clone),  # 5-7
               (LOAD, 0, 0, 16), (JSET, 1, 0, CLONE_NEWUSER),  # 8-9: clone's flags
               (RET, 0, 0, ALLOW), (RET, 0, 0, DENY), (RET, 0, 0, NOSYS)]  # 10-12
    code = ctypes.create_string_buffer(b"".join(struct.pack("HBBI", *op) for op in program))
    fprog = SockFprog(len(program), ctypes.addressof(code))
    libc = ctypes.CDLL(None, use_errno=True)
    if (libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0
            or libc.prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, ctypes.byref(fprog), 0, 0) != 0):
        raise OSError(ctypes.get_errno(), "harness: cannot install the seccomp filter")


def import_common() -> None:
    """Import what every reference script imports (a failure is the script's to meet)."""
    if LIB not in sys.path:
        sys.path.insert(0, LIB)
    for name in WARM_IMPORTS:
        with contextlib.suppress(Exception):  # the script will meet the same error itself
            importlib.import_module(name)


def wait_for_job(idle_s: float) -> None:
    """Warm mode: wait for the host's ``go`` file (exit when idle for ``idle_s``)."""
    deadline = time.monotonic() + idle_s
    while not os.path.exists(GO):
        if time.monotonic() > deadline:
            sys.exit(3)
        time.sleep(0.02)


def run_script(marks: dict[str, float]) -> dict[str, Any]:
    """Import ``script.py`` as a module (its own imports included: the ``imported`` mark)
    and call ``generate(params, SCENARIO)``."""
    with open(os.path.join(JOB, "params.json"), encoding="utf-8") as handle:
        params = json.load(handle)
    if LIB not in sys.path:
        sys.path.insert(0, LIB)
    started = time.perf_counter()
    report: dict[str, Any] = {"error_type": None, "error_message": None, "traceback": None}
    try:
        spec = importlib.util.spec_from_file_location("llm_script", os.path.join(JOB, "script.py"))
        if spec is None or spec.loader is None:
            raise ImportError(f"cannot load {JOB}/script.py as a module")
        module = importlib.util.module_from_spec(spec)
        sys.modules["llm_script"] = module
        spec.loader.exec_module(module)
        marks["imported"] = time.time()
        module.generate(params, SCENARIO)
    except BaseException as err:  # noqa: BLE001 - SystemExit from the script is an error too
        report["error_type"] = type(err).__name__
        report["error_message"] = str(err)
        report["traceback"] = traceback.format_exc()
    report["script_duration_s"] = time.perf_counter() - started
    return report


def output_paths() -> list[str]:
    """Every path under the output folder (never following links), the scenario first: the
    host takes outputs in this order up to its limits, and vets every name itself."""
    paths = [os.path.join(folder, name)
             for folder, _, names in os.walk(OUT, followlinks=False) for name in names]
    return sorted(paths, key=lambda path: (path != SCENARIO, path))


def produced_files(limit_bytes: int) -> list[dict[str, str]]:
    """The regular files of the output folder (no links, FIFOs...), up to ``limit_bytes``."""
    files: list[dict[str, str]] = []
    total = 0
    for path in output_paths():
        info = os.lstat(path)
        if not stat.S_ISREG(info.st_mode) or total + info.st_size > limit_bytes:
            continue
        with open(path, "rb") as handle:
            data = handle.read(info.st_size)
        total += len(data)
        files.append({"name": os.path.relpath(path, OUT),
                      "data": base64.b64encode(data).decode("ascii")})
    return files


def main() -> int:
    """Run the job and write the report; exit 0 when the script raised nothing."""
    forbid_user_namespaces()
    limit = int(sys.argv[1]) if len(sys.argv) > 1 else 16 * 1024 * 1024
    marks = {"begun": time.time()}  # wall clock: the host compares them with its own
    if len(sys.argv) > 3 and sys.argv[2] == "--warm":
        import_common()
        wait_for_job(float(sys.argv[3]))
        marks["begun"] = time.time()
    report = run_script(marks)
    marks["generated"] = time.time()
    marks.setdefault("imported", marks["generated"])  # the script did not import
    try:
        report["files"] = produced_files(limit)
    except Exception as err:  # noqa: BLE001 - e.g. a tree too deep to walk: report it
        report["files"] = []
        if report["error_type"] is None:
            report["error_type"] = "OutputUnreadable"
            report["error_message"] = f"{type(err).__name__}: {err}"
    marks["collected"] = time.time()
    report["marks"] = marks
    with open(RESULT, "w", encoding="utf-8") as handle:
        json.dump(report, handle)
    return 0 if report["error_type"] is None else 1


if __name__ == "__main__":
    status = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)  # the report is written: skip tearing down scipy & co. (~0.1-0.2 s)

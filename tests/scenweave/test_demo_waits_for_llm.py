"""``scenweave demo`` after ``scripts/setup.sh --llm-later`` (issue 35): the reference part runs
while llama.cpp compiles; the agent part waits for the background install to end."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from scenweave.commands import demo

HOLD_S = 1.5


@pytest.fixture
def no_llama(monkeypatch):
    found = demo.importlib.util.find_spec
    monkeypatch.setattr(demo.importlib.util, "find_spec",
                        lambda name, *a: None if name == "llama_cpp" else found(name, *a))


def test_the_demo_waits_while_the_install_holds_its_lock(tmp_path, no_llama, capsys):
    lock = tmp_path / "llama-install.lock"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, sys, time\n"
         f"f = open({str(lock)!r}, 'w'); fcntl.flock(f, fcntl.LOCK_EX)\n"
         f"print('held', flush=True); time.sleep({HOLD_S})"],
        stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    started = time.monotonic()
    demo.wait_for_embedded_runtime(lock)
    assert time.monotonic() - started > HOLD_S / 2
    holder.wait(timeout=10)
    out = capsys.readouterr().out
    assert "demo: waiting for llama-cpp-python" in out and "ready after" in out


def test_without_a_background_install_it_does_not_wait(tmp_path, no_llama, capsys):
    started = time.monotonic()
    demo.wait_for_embedded_runtime(tmp_path / "no-such.lock")
    assert time.monotonic() - started < 0.5
    assert capsys.readouterr().out == ""

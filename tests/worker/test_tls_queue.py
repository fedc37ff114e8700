"""The queue over TLS (``rediss://``) with a password: a real ``redis-server`` listening only
for TLS on loopback with a certificate of a throwaway CA made by ``openssl``, a real worker and
``submit --wait``."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from scenweave.cli import cli
from scenweave.queue.connection import QueueError, connect
from scenweave.testing.redis_server import free_port
from tests.worker.conftest import REPO

PASSWORD = "tls-queue-secret"


def _openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


def _certificates(folder: Path) -> None:
    """A CA and a server certificate for 127.0.0.1 signed by it (one day)."""
    _openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out",
             "ca.crt", "-days", "1", "-subj", "/CN=scenweave-test-ca", cwd=folder)
    _openssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "server.key", "-out",
             "server.csr", "-subj", "/CN=127.0.0.1", cwd=folder)
    (folder / "san.ext").write_text("subjectAltName=IP:127.0.0.1\n")
    _openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key",
             "-CAcreateserial", "-out", "server.crt", "-days", "1", "-extfile", "san.ext",
             cwd=folder)


@pytest.fixture(scope="module")
def tls_redis(tmp_path_factory):
    """(URL trusting the test CA, the same URL without the CA) of a TLS-only redis-server."""
    if shutil.which("openssl") is None or shutil.which("redis-server") is None:
        pytest.skip("TLS QUEUE NOT TESTED: openssl or redis-server is not installed")
    folder = tmp_path_factory.mktemp("redis-tls")
    _certificates(folder)
    port = free_port()
    server = subprocess.Popen(
        ["redis-server", "--port", "0", "--tls-port", str(port), "--bind", "127.0.0.1",
         "--tls-cert-file", "server.crt", "--tls-key-file", "server.key",
         "--tls-ca-cert-file", "ca.crt", "--tls-auth-clients", "no",
         "--requirepass", PASSWORD, "--save", "", "--appendonly", "no", "--dir", str(folder)],
        cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    base = f"rediss://:{PASSWORD}@127.0.0.1:{port}/0"
    trusted = f"{base}?ssl_ca_certs={folder / 'ca.crt'}"
    deadline = time.monotonic() + 15
    while True:
        try:
            connect(trusted)
            break
        except QueueError:
            if server.poll() is not None or time.monotonic() > deadline:
                server.kill()
                pytest.skip("TLS QUEUE NOT TESTED: this redis-server does not serve TLS")
            time.sleep(0.1)
    yield trusted, base
    server.terminate()
    server.wait(timeout=10)


def test_a_tls_queue_checks_the_server_s_certificate(tls_redis):
    trusted, untrusted = tls_redis
    assert connect(trusted).ping()
    with pytest.raises(QueueError, match="certificate verify failed") as error:
        connect(untrusted)
    assert PASSWORD not in str(error.value)


def test_a_worker_over_tls_hands_its_scenarios_back(tls_redis, records, tmp_path, esmini):
    trusted, _ = tls_redis
    connect(trusted).flushall()
    worker = subprocess.Popen(
        [sys.executable, "-m", "scenweave.cli", "worker", "--queue", trusted, "--scratch",
         str(tmp_path / "scratch"), "--heartbeat", "2"], cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL)
    try:
        result = CliRunner().invoke(cli, [
            "submit", str(records), "--no-llm", "--out", str(tmp_path / "runs"), "--run-id",
            "tls", "--classes", "LCF", "--queue", trusted, "--wait", "--timeout", "240"])
    finally:
        worker.send_signal(signal.SIGTERM)
        worker.wait(timeout=60)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "runs" / "tls" / "summary.json").read_text())
    assert summary["total"] == 3 and summary["counts"]["ok"] == 3
    assert PASSWORD not in (tmp_path / "runs" / "tls" / "run.json").read_text()

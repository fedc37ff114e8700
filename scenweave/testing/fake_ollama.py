"""A real HTTP server on loopback that answers like Ollama: ``/api/chat`` and ``/api/tags``.

It answers every chat with the same ``reply`` after ``delay_s`` (an LLM server with a fixed
latency) or, when ``answer`` is set, with ``answer(request_body)`` (a stand-in model that
reads the prompt: recorded replies of good and bad kinds), serves requests in parallel like a
server with several slots, and records every request it gets (a structured-output request
carries its JSON schema under ``format``). ``fail_status`` makes chats fail with that HTTP
status instead.

    with FakeOllama(reply="NO CHANGES", delay_s=1.0) as server:
        AgentSettings(llm="ollama", ollama_host=server.url, ...)
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

PULLED = "qwen2.5-coder:7b"
"""The one model the server has (the default Ollama model of ScenWeave)."""
TOKENS_IN, TOKENS_OUT = 321, 54
"""The prompt and reply token counts every chat reports."""


class FakeOllama(ThreadingHTTPServer):
    """Answers /api/chat and /api/tags like Ollama; records every request it gets."""

    daemon_threads = True

    def __init__(self, reply: str = "```python\nprint('hi')\n```", delay_s: float = 0.0,
                 port: int = 0) -> None:
        super().__init__(("127.0.0.1", port), OllamaHandler)
        self.requests: list[tuple[str, dict]] = []
        self.reply = reply
        self.answer: Callable[[dict], str] | None = None
        self.delay_s = delay_s
        self.fail_status = 0
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}"

    def start(self) -> FakeOllama:
        """Serve in a daemon thread."""
        self._thread = threading.Thread(target=self.serve_forever, args=(0.05,), daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self.shutdown()
        self.server_close()

    def __enter__(self) -> FakeOllama:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


class OllamaHandler(BaseHTTPRequestHandler):
    server: FakeOllama

    def log_message(self, *args: Any) -> None:
        pass

    def do_GET(self) -> None:
        self.server.requests.append((self.path, {}))
        if self.path == "/api/tags":
            self._send(200, {"models": [{"name": PULLED, "model": PULLED, "size": 1}]})
        else:
            self._send(404, {"error": "not found"})

    def do_POST(self) -> None:
        body = json.loads(self.rfile.read(int(self.headers["Content-Length"])) or b"{}")
        self.server.requests.append((self.path, body))
        time.sleep(self.server.delay_s)
        if self.path != "/api/chat":
            self._send(404, {"error": "not found"})
        elif self.server.fail_status:
            self._send(self.server.fail_status, {"error": "llama runner process has terminated"})
        elif body.get("model") != PULLED:
            self._send(404, {"error": f"model '{body.get('model')}' not found"})
        else:
            self._send(200, {"model": PULLED, "created_at": "2026-11-22T00:00:00Z",
                             "message": {"role": "assistant", "content": self._reply(body)},
                             "done": True, "done_reason": "stop",
                             "prompt_eval_count": TOKENS_IN, "eval_count": TOKENS_OUT,
                             "total_duration": 1_000_000, "eval_duration": 500_000})

    def _reply(self, body: dict) -> str:
        answer = self.server.answer
        return answer(body) if answer is not None else self.server.reply

    def _send(self, status: int, data: dict) -> None:
        payload = json.dumps(data).encode()
        try:
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(payload)))
            self.end_headers()
            self.wfile.write(payload)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up (a timeout)

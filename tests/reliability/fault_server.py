"""A fault-injecting HTTP server on 127.0.0.1, for reliability tests.

``FaultServer(mode)`` answers every ``POST`` (any path: chat completions, images, a segmenter or a
reconstructor) in a background thread according to ``mode``; ``requests`` counts what reached it.
Modes:

* ``hang`` — never answers (until the server stops);
* ``trickle`` — a 200 whose body arrives one byte every 0.2 s, never ending (each read is quick);
* ``braces`` — a 2 MB body of ``{`` with status 200;
* ``html`` — an HTML page with status 200;
* ``message_string`` — ``choices[0].message`` is a string;
* ``bad_usage`` — a valid-looking reply whose ``usage.prompt_tokens`` is not a number;
* ``error503`` — always HTTP 503;
* ``retry_after`` — HTTP 429 with ``Retry-After: 100000``;
* ``context`` — HTTP 400 "exceeds the available context size" (llama.cpp's wording);
* ``reset`` — closes the connection without answering.
"""

from __future__ import annotations

import contextlib
import json
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

MODES = ("hang", "trickle", "braces", "html", "message_string", "bad_usage", "error503", "retry_after", "context", "reset")


class FaultServer:
    """See the module docstring; use as a context manager."""

    def __init__(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}")
        self.mode = mode
        self.requests = 0
        self._stop = threading.Event()
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, format: str, *args: Any) -> None:  # keep test output clean
                return

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length", "0"))
                self.rfile.read(length)
                server.requests += 1
                server._answer(self)

        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, daemon=True)

    @property
    def root(self) -> str:
        """``http://127.0.0.1:PORT`` (any path answers the same)."""
        host, port = self._httpd.server_address[:2]
        return f"http://{host!s}:{port}"

    @property
    def base_url(self) -> str:
        host, port = self._httpd.server_address[:2]
        return f"http://{host!s}:{port}/v1"

    def __enter__(self) -> FaultServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._httpd.shutdown()
        self._httpd.server_close()

    def _send(self, h: BaseHTTPRequestHandler, status: int, body: bytes, ctype: str, **headers: str) -> None:
        h.send_response(status)
        h.send_header("Content-Type", ctype)
        h.send_header("Content-Length", str(len(body)))
        for k, v in headers.items():
            h.send_header(k.replace("_", "-"), v)
        h.end_headers()
        with contextlib.suppress(BrokenPipeError, ConnectionResetError):  # the client gave up: fine
            h.wfile.write(body)

    def _answer(self, h: BaseHTTPRequestHandler) -> None:
        mode = self.mode
        if mode == "hang":
            self._stop.wait(600)
            return
        if mode == "trickle":
            h.send_response(200)
            h.send_header("Content-Type", "application/json")
            h.send_header("Content-Length", "1000000")
            h.end_headers()
            with contextlib.suppress(BrokenPipeError, ConnectionResetError, OSError):
                while not self._stop.wait(0.2):
                    h.wfile.write(b" ")
                    h.wfile.flush()
            return
        if mode == "reset":
            h.connection.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
            h.connection.close()
            return
        if mode == "braces":
            self._send(h, 200, b"{" * 2_000_000, "application/json")
        elif mode == "html":
            self._send(h, 200, b"<html><body>Service temporarily moved</body></html>", "text/html")
        elif mode == "message_string":
            body = {"choices": [{"index": 0, "message": "hello", "finish_reason": "stop"}]}
            self._send(h, 200, json.dumps(body).encode(), "application/json")
        elif mode == "bad_usage":
            body = {
                "choices": [{"index": 0, "message": {"role": "assistant", "content": "not json"}, "finish_reason": "stop"}],
                "usage": {"prompt_tokens": "many", "completion_tokens": None},
            }
            self._send(h, 200, json.dumps(body).encode(), "application/json")
        elif mode == "error503":
            self._send(h, 503, b'{"error": {"message": "overloaded"}}', "application/json")
        elif mode == "retry_after":
            self._send(h, 429, b'{"error": {"message": "slow down"}}', "application/json", Retry_After="100000")
        elif mode == "context":
            err = {
                "error": {
                    "code": 400,
                    "message": "the request exceeds the available context size, try increasing it",
                    "type": "exceed_context_size_error",
                    "n_prompt_tokens": 4142,
                    "n_ctx": 4096,
                }
            }
            self._send(h, 400, json.dumps(err).encode(), "application/json")

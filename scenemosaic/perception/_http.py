"""One JSON-over-HTTP client for the perception servers (segmenter, reconstructor).

``POST`` a JSON body, read a JSON object back, through the one HTTP policy of every outbound call
(:func:`~scenemosaic.models._http.send_with_retries`, reached through the models package's
re-exports): each attempt under a total time-out, the run's deadline (its
:class:`~scenemosaic.models.CallClock`) over every attempt and wait, 429, 5xx, dropped
connections and time-outs tried again honouring ``Retry-After``. A refused connection or an
unknown host fails at once (nothing listens there); anything else raises
:class:`~scenemosaic.exceptions.BackendError` naming the server and what it said. Calls are
awaited on the event loop, so a signal interrupts a waiting call at once.
"""

from __future__ import annotations

import asyncio
import json
import random
from collections.abc import Awaitable, Callable
from typing import Any

import httpx
import structlog

from scenemosaic.exceptions import BackendError, ModelHTTPError, UsageError
from scenemosaic.models import (
    CallClock,
    GiveUp,
    HTTPRetryPolicy,
    is_unreachable,
    read_capped,
    send_with_retries,
    transient_status_error,
    unreachable_words,
)

__all__ = ["MAX_BACKEND_REPLY_BYTES", "JSONService"]

log = structlog.get_logger(__name__)

MAX_BACKEND_REPLY_BYTES = 256_000_000
"""Largest reply read from a perception server (a mesh travels inside it)."""


class JSONService:
    """An async JSON endpoint under the run's clock and the shared retry policy."""

    def __init__(
        self,
        url: str,
        *,
        what: str,
        timeout_s: float = 60.0,
        retry: HTTPRetryPolicy | None = None,
        clock: CallClock | None = None,
        transport: httpx.AsyncBaseTransport | None = None,
        sleep: Callable[[float], Awaitable[None]] = asyncio.sleep,
    ) -> None:
        """``timeout_s``: this backend's own time-out of one attempt, used when the run sets no
        ``--request-timeout`` (``clock.timeout_s``); ``clock``: the run's clock (no deadline when ``None``)."""
        if not url.startswith(("http://", "https://")):
            raise UsageError(f"{what} URL must start with http:// or https://, got {url!r}")
        self.url = url
        self.what = what
        self.timeout_s = timeout_s
        self.clock = clock or CallClock()
        self.retry = retry or HTTPRetryPolicy(max_total_s=max(300.0, 4 * timeout_s))
        self._transport = transport
        self._client: httpx.AsyncClient | None = None
        self._client_loop: asyncio.AbstractEventLoop | None = None
        self._sleep = sleep
        self._rng = random.Random(0)

    def _http(self) -> httpx.AsyncClient:
        loop = asyncio.get_running_loop()
        if self._client is None or self._client_loop is not loop:  # a client belongs to one event loop
            self._client = httpx.AsyncClient(transport=self._transport)
            self._client_loop = loop
        return self._client

    async def post(self, body: dict[str, Any]) -> dict[str, Any]:
        """The server's JSON object for ``body``."""
        timeout = self.clock.call_timeout(self.timeout_s)

        async def attempt(limit: float) -> dict[str, Any]:
            async with self._http().stream("POST", self.url, json=body, timeout=limit) as response:
                raw, whole = await read_capped(response, MAX_BACKEND_REPLY_BYTES)
            if response.status_code != 200:
                text = raw[:200].decode("utf-8", errors="replace")
                status = response.status_code
                transient = transient_status_error(status, text, response.headers.get("retry-after"))
                if transient is not None:
                    raise transient
                raise BackendError(f"{self.what} {self.url}: HTTP {status}: {text}")
            if not whole:
                raise BackendError(f"{self.what} {self.url}: reply larger than {MAX_BACKEND_REPLY_BYTES} bytes")
            try:
                data = json.loads(raw)
            except (ValueError, RecursionError) as exc:
                raise BackendError(f"{self.what} {self.url} answered something that is not JSON: {raw[:200]!r}") from exc
            if not isinstance(data, dict):
                raise BackendError(f"{self.what} {self.url} answered JSON that is not an object")
            if "error" in data and len(data) == 1:
                raise BackendError(f"{self.what} {self.url} answered an error: {str(data['error'])[:300]}")
            return data

        try:
            return await send_with_retries(
                attempt, timeout_s=timeout, policy=self.retry, clock=self.clock, sleep=self._sleep, rng=self._rng, what=self.what
            )
        except GiveUp as stopped:
            raise BackendError(self._gave_up(stopped, timeout)) from stopped.failure
        except httpx.HTTPError as exc:
            if is_unreachable(exc):
                where = unreachable_words(exc, self.url, f"{self.what} server")
                raise BackendError(f"{where}: start it, or choose another --{self.what}") from exc
            raise BackendError(f"{self.what} {self.url}: request failed: {type(exc).__name__}: {exc}") from exc

    def _gave_up(self, stopped: GiveUp, timeout: float) -> str:
        left = self.clock.remaining_s()
        if stopped.timed_out and left is not None and left <= 0.05:
            return f"{self.what} {self.url} did not answer within {self.clock.deadline_words()} ({stopped.attempts} attempts)"
        failure = stopped.failure
        if isinstance(failure, ModelHTTPError):  # a 429 or 5xx, after the retries
            said = f"HTTP {failure.status_code}: {failure.body[:200]}"
        elif stopped.timed_out:
            said = f"no complete reply in time ({timeout:g} s" + (f", then {2 * timeout:g} s)" if stopped.attempts > 1 else ")")
        else:
            said = f"{type(failure).__name__}: {failure}"
        return f"{self.what} {self.url} failed after {stopped.attempts} attempts: {said}"

    async def aclose(self) -> None:
        """Close the connection pool."""
        if self._client is not None:
            client, self._client = self._client, None
            await client.aclose()

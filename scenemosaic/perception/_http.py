"""One JSON-over-HTTP client for the perception servers (segmenter, reconstructor).

``POST`` a JSON body, read a JSON object back; 429, 5xx, dropped connections and time-outs are
tried again under :class:`~scenemosaic.models.HTTPRetryPolicy` (the model client's policy and
defaults), honouring ``Retry-After``; anything else raises
:class:`~scenemosaic.exceptions.BackendError` naming the server and what it said.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from typing import Any

import httpx
import structlog

from scenemosaic.exceptions import BackendError, UsageError
from scenemosaic.models import HTTPRetryPolicy

__all__ = ["MAX_BACKEND_REPLY_BYTES", "JSONService"]

log = structlog.get_logger(__name__)

MAX_BACKEND_REPLY_BYTES = 256_000_000
"""Largest reply read from a perception server (a mesh travels inside it)."""

_TRANSIENT = {408, 425, 429, 500, 502, 503, 504}


class JSONService:
    """A blocking JSON endpoint with retries (the perception stage calls it from worker threads)."""

    def __init__(
        self,
        url: str,
        *,
        what: str,
        timeout_s: float = 60.0,
        retry: HTTPRetryPolicy | None = None,
        transport: httpx.BaseTransport | None = None,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not url.startswith(("http://", "https://")):
            raise UsageError(f"{what} URL must start with http:// or https://, got {url!r}")
        self.url = url
        self.what = what
        self.timeout_s = timeout_s
        self.retry = retry or HTTPRetryPolicy(max_total_s=max(300.0, 4 * timeout_s))
        self._client = httpx.Client(transport=transport, timeout=timeout_s)
        self._sleep = sleep
        self._rng = random.Random(0)

    def post(self, body: dict[str, Any]) -> dict[str, Any]:
        """The server's JSON object for ``body``."""
        policy = self.retry
        started = time.monotonic()
        attempt = 0
        while True:
            attempt += 1
            wait: float | None = None
            try:
                response = self._client.post(self.url, json=body)
            except (httpx.TimeoutException, httpx.NetworkError, httpx.RemoteProtocolError) as exc:
                failure = f"{type(exc).__name__}: {exc}"
            except httpx.HTTPError as exc:
                raise BackendError(f"{self.what} {self.url}: request failed: {type(exc).__name__}: {exc}") from exc
            else:
                if response.status_code == 200:
                    if len(response.content) > MAX_BACKEND_REPLY_BYTES:
                        raise BackendError(f"{self.what} {self.url}: reply larger than {MAX_BACKEND_REPLY_BYTES} bytes")
                    try:
                        data = response.json()
                    except ValueError as exc:
                        raise BackendError(f"{self.what} {self.url} answered something that is not JSON: {response.text[:200]!r}") from exc
                    if not isinstance(data, dict):
                        raise BackendError(f"{self.what} {self.url} answered JSON that is not an object")
                    if "error" in data and len(data) == 1:
                        raise BackendError(f"{self.what} {self.url} answered an error: {str(data['error'])[:300]}")
                    return data
                failure = f"HTTP {response.status_code}: {response.text[:200]}"
                if response.status_code not in _TRANSIENT:
                    raise BackendError(f"{self.what} {self.url}: {failure}")
                wait = _retry_after(response.headers.get("retry-after"), policy.max_retry_after_s)
            if wait is None:
                wait = min(policy.initial_backoff_s * 2.0 ** (attempt - 1), policy.max_backoff_s) + self._rng.uniform(0, policy.jitter_s)
            if attempt >= policy.max_attempts or time.monotonic() - started + wait > policy.max_total_s:
                raise BackendError(f"{self.what} {self.url} failed after {attempt} attempts: {failure}")
            log.warning("backend_retry", backend=self.what, url=self.url, attempt=attempt, wait_s=round(wait, 2), error=failure)
            self._sleep(wait)

    def close(self) -> None:
        """Close the connection pool."""
        self._client.close()


def _retry_after(value: str | None, cap: float) -> float | None:
    if value is None:
        return None
    try:
        return min(max(0.0, float(value)), cap)
    except ValueError:
        return None

"""One policy for every outbound HTTP call of a run: one clock, one retry loop.

Every client a run opens — the chat model, its images endpoint, the perception segmenter and
reconstructor servers — sends through :func:`send_with_retries`:

* each attempt runs under a **total** time-out (``asyncio.timeout`` around connect, send and the
  whole body), so a server that trickles bytes is cut like one that hangs; httpx's own
  time-outs are only per read;
* the run's :class:`CallClock` caps every attempt at the time left before the run's deadline,
  and no attempt or wait starts past it;
* transient failures (429, 408/409/425, 5xx, time-outs, reset or dropped connections) are tried
  again under an :class:`HTTPRetryPolicy` written once on ``tenacity``: a capped ``Retry-After``,
  else exponential back-off with jitter, a cap on attempts and a total budget;
* a refused connection or an unknown host is a set-up error, never retried: the caller says
  which server is missing and how to fix it.

Everything is awaited on the event loop, so a signal that cancels the run's task interrupts a
waiting call at once (no worker thread to wait for).
"""

from __future__ import annotations

import asyncio
import math
import random
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from email.utils import parsedate_to_datetime
from typing import TypeVar

import httpx
import structlog
from tenacity import AsyncRetrying, RetryCallState, retry_if_exception_type

from scenemosaic.exceptions import ModelConfigError, ModelHTTPError

__all__ = [
    "TIMEOUT_RETRIES",
    "AttemptTimedOut",
    "CallClock",
    "GiveUp",
    "HTTPRetryPolicy",
    "TransientHTTPError",
    "is_unreachable",
    "parse_retry_after",
    "read_capped",
    "send_with_retries",
    "transient_status_error",
    "unreachable_words",
]

log = structlog.get_logger(__name__)

T = TypeVar("T")

TIMEOUT_RETRIES = 1
"""A timed-out request is sent once more, with twice the time-out; a second time-out ends it."""


@dataclass(frozen=True)
class HTTPRetryPolicy:
    """When and how long to wait before re-sending a request that failed transiently.

    One call takes at most ``max_attempts`` attempts, each under the call's time-out, so its wall
    time is at most ``max_attempts`` x time-out plus the waits between them, and never more than
    ``max_total_s`` (nor past the run's deadline, see :class:`CallClock`).
    """

    max_attempts: int = 4
    """Attempts in all, the first included."""
    initial_backoff_s: float = 1.0
    """Wait before the second attempt when the server gives no ``Retry-After`` (seconds); doubles per attempt."""
    max_backoff_s: float = 30.0
    """Cap on the exponential wait (seconds), before jitter."""
    jitter_s: float = 1.0
    """Uniform random extra wait in ``[0, jitter_s]`` seconds, so parallel clients spread out."""
    max_retry_after_s: float = 30.0
    """Cap on a server's ``Retry-After`` (seconds): a longer request is waited out only this long."""
    max_total_s: float = 300.0
    """Budget for one call, attempts and waits together (seconds): no attempt starts (and
    none runs) past it, and a wait that would end past it is not begun."""

    def __post_init__(self) -> None:
        if self.max_attempts < 1:
            raise ModelConfigError(f"max_attempts must be at least 1, got {self.max_attempts}")
        if self.max_total_s <= 0:
            raise ModelConfigError(f"max_total_s must be positive, got {self.max_total_s}")
        if min(self.initial_backoff_s, self.max_backoff_s, self.jitter_s, self.max_retry_after_s) < 0:
            raise ModelConfigError("retry waits must not be negative")


@dataclass(frozen=True)
class CallClock:
    """The run's one clock for outbound calls: the request time-out and the deadline.

    :func:`~scenemosaic.models.open_run_model` makes it from ``--request-timeout`` and
    ``--deadline`` (``RunModel.clock``); the model stack and the perception backends read it.
    """

    timeout_s: float | None = None
    """Total time-out of one call's attempt in seconds (``--request-timeout``); ``None`` keeps each client's own."""
    expires_at: float | None = None
    """The ``time.monotonic()`` reading at which the run's deadline passes; ``None``: no deadline."""
    deadline_s: float | None = None
    """The deadline as the user set it (seconds from the run's start), for messages."""

    @classmethod
    def starting(cls, timeout_s: float | None, deadline_s: float | None, started: float | None = None) -> CallClock:
        """The clock of a run that began at ``started`` (``time.monotonic()``; default now)."""
        began = time.monotonic() if started is None else started
        return cls(timeout_s, None if deadline_s is None else began + deadline_s, deadline_s)

    def remaining_s(self) -> float | None:
        """Seconds left before the deadline (0 once passed); ``None`` without a deadline."""
        return None if self.expires_at is None else max(0.0, self.expires_at - time.monotonic())

    def call_timeout(self, own_s: float) -> float:
        """The time-out of one attempt for a client whose own is ``own_s``: the request time-out
        when set, else ``own_s``; never past the deadline."""
        timeout = self.timeout_s if self.timeout_s is not None else own_s
        left = self.remaining_s()
        return timeout if left is None else min(timeout, left)

    def deadline_words(self) -> str:
        """"the run's 30 s deadline" (for messages: the deadline, not the time left)."""
        return f"the run's {self.deadline_s:g} s deadline" if self.deadline_s is not None else "the run's deadline"


class TransientHTTPError(ModelHTTPError):
    """A 429/5xx (or 408/409/425) reply worth retrying; ``retry_after_s`` is the server's hint, if any."""

    def __init__(self, message: str, *, status_code: int, body: str, retry_after_s: float | None) -> None:
        super().__init__(message, status_code=status_code, body=body)
        self.retry_after_s = retry_after_s


class AttemptTimedOut(Exception):
    """One attempt ran past its total time-out (httpx's own time-outs are per read)."""


class GiveUp(Exception):
    """Raised by :func:`send_with_retries` when it stops: the last ``failure`` and the ``attempts`` made."""

    def __init__(self, failure: BaseException, attempts: int) -> None:
        super().__init__(f"{type(failure).__name__}: {failure}")
        self.failure = failure
        self.attempts = attempts

    @property
    def timed_out(self) -> bool:
        """Whether the last attempt ran out of time."""
        return isinstance(self.failure, AttemptTimedOut | httpx.TimeoutException)


# Failures another attempt may cure. Not retried: a refused connection or an unknown host (no
# server there: a set-up error), httpx.UnsupportedProtocol and LocalProtocolError (our request is
# wrong) and every non-transient status.
RETRYABLE: tuple[type[BaseException], ...] = (
    TransientHTTPError,
    AttemptTimedOut,
    httpx.TimeoutException,
    httpx.ReadError,
    httpx.WriteError,
    httpx.CloseError,
    httpx.RemoteProtocolError,  # the server dropped the connection mid-exchange
    httpx.ProxyError,
)

TRANSIENT_STATUS = frozenset({408, 409, 425, 429})
"""Statuses retried besides every 5xx."""


def transient_status_error(
    status: int, body: str, retry_after: str | None, *, message: str | None = None
) -> TransientHTTPError | None:
    """The retryable error for a reply of ``status`` (429, 408/409/425, any 5xx) with ``body``
    (``message``: its error message, default the body), the server's ``Retry-After`` header
    read; ``None`` when another attempt cannot help."""
    if status in TRANSIENT_STATUS or status >= 500:
        hint = parse_retry_after(retry_after)
        return TransientHTTPError(message or body, status_code=status, body=body, retry_after_s=hint)
    return None


def is_unreachable(exc: BaseException) -> bool:
    """Whether ``exc`` says no server answers at the address: a refused connection, an unknown host."""
    return isinstance(exc, httpx.ConnectError)


_UNKNOWN_HOST = ("name or service not known", "nodename nor servname", "getaddrinfo", "no address associated", "temporary failure in name resolution")


def unreachable_words(exc: BaseException, url: str, what: str) -> str:
    """Why nothing answers at ``url`` (an unknown host, or no ``what`` listening), in a few words."""
    text = str(exc).lower()
    if any(k in text for k in _UNKNOWN_HOST):
        return f"unknown host {httpx.URL(url).host!r} in the {what} URL {url}"
    return f"no {what} at {url}"


def parse_retry_after(value: str | None, *, now: datetime | None = None) -> float | None:
    """Seconds to wait from a ``Retry-After`` header (delta seconds or an HTTP date); ``None`` if absent."""
    if not value:
        return None
    value = value.strip()
    try:
        seconds = float(value)
    except ValueError:
        pass
    else:
        return max(0.0, seconds) if math.isfinite(seconds) else None
    try:
        when = parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return max(0.0, (when - (now or datetime.now(UTC))).total_seconds())


async def read_capped(response: httpx.Response, cap: int, *, excerpt: int = 2000) -> tuple[bytes, bool]:
    """A streamed response's body, and whether it is whole: reading stops past ``cap`` bytes (an
    announced larger body is not read beyond its first ``excerpt`` bytes)."""
    declared = response.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > cap:
        async for chunk in response.aiter_bytes():
            return chunk[:excerpt], False
        return b"", False
    chunks: list[bytes] = []
    size = 0
    async for chunk in response.aiter_bytes():
        size += len(chunk)
        chunks.append(chunk)
        if size > cap:
            return b"".join(chunks)[:cap], False
    return b"".join(chunks), True


async def send_with_retries(
    attempt: Callable[[float], Awaitable[T]],
    *,
    timeout_s: float,
    policy: HTTPRetryPolicy,
    clock: CallClock | None = None,
    give_up_at: float | None = None,
    now: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep,
    rng: random.Random | None = None,
    what: str = "request",
) -> T:
    """``await attempt(t)`` until it succeeds, fails for good, or the policy says stop.

    ``t`` is the attempt's total time-out (seconds): ``timeout_s`` capped by ``clock`` (the run's
    request time-out and deadline) and by the policy's total budget; the attempt runs inside
    ``asyncio.timeout(t)``, and running out raises :class:`AttemptTimedOut`. A timed-out attempt
    is tried once more with twice the time-out (:data:`TIMEOUT_RETRIES`), then given up. Failures
    in :data:`RETRYABLE` are retried; any other exception propagates at once. When the policy
    stops, :class:`GiveUp` is raised with the last failure (its ``__cause__``). ``give_up_at``
    (a ``now()`` reading) replaces the policy's total budget when one call spans several sends;
    ``now`` and ``sleep`` are injectable for tests.
    """
    run_clock = clock or CallClock()
    timeout_s = run_clock.call_timeout(timeout_s)
    give_up_at = now() + policy.max_total_s if give_up_at is None else give_up_at
    if run_clock.expires_at is not None:
        left = run_clock.remaining_s() or 0.0
        if left <= 0:
            raise GiveUp(AttemptTimedOut(f"{run_clock.deadline_words()} had passed before the {what} was sent"), 0)
        give_up_at = min(give_up_at, now() + left)
    jitter = rng or random.Random()
    state = {"budget": timeout_s, "timeouts": 0, "after_drop": False}

    async def one() -> T:
        left = give_up_at - now()
        if left <= 0:
            raise AttemptTimedOut(f"no time left for the {what}")
        limit = max(0.001, min(state["budget"], left))
        try:
            async with asyncio.timeout(limit) as scope:
                return await attempt(limit)
        except TimeoutError as exc:
            if scope.expired():
                raise AttemptTimedOut(f"no complete reply within {limit:g} s") from exc
            raise

    def wait(rs: RetryCallState) -> float:
        failure = rs.outcome.exception() if rs.outcome is not None else None
        if isinstance(failure, httpx.RemoteProtocolError) and not state["after_drop"]:
            # a pooled keep-alive connection the server had closed: re-sending at once suffices
            state["after_drop"] = True
            return 0.0
        state["after_drop"] = isinstance(failure, httpx.RemoteProtocolError)
        if isinstance(failure, TransientHTTPError) and failure.retry_after_s is not None:
            return min(failure.retry_after_s, policy.max_retry_after_s)
        backoff: float = policy.initial_backoff_s * 2.0 ** max(0, rs.attempt_number - 1)
        return min(backoff, policy.max_backoff_s) + jitter.uniform(0.0, policy.jitter_s)

    def stop(rs: RetryCallState) -> bool:
        failure = rs.outcome.exception() if rs.outcome is not None else None
        if isinstance(failure, AttemptTimedOut | httpx.TimeoutException):
            # the same request under the same budget would most likely time out again
            state["timeouts"] += 1
            state["budget"] = timeout_s * 2
            if state["timeouts"] > TIMEOUT_RETRIES:
                return True
        return rs.attempt_number >= policy.max_attempts or now() + rs.upcoming_sleep >= give_up_at

    def before_sleep(rs: RetryCallState) -> None:
        failure = rs.outcome.exception() if rs.outcome is not None else None
        log.warning(
            "transient HTTP failure; retrying",
            what=what,
            attempt=rs.attempt_number,
            wait_s=round(rs.upcoming_sleep, 3),
            error=f"{type(failure).__name__}: {failure}",
        )

    async def pause(seconds: float) -> None:
        if seconds > 0:  # a dropped keep-alive is re-sent at once, without yielding to a sleep
            await sleep(seconds)

    retrying = AsyncRetrying(
        retry=retry_if_exception_type(RETRYABLE),
        wait=wait,
        stop=stop,
        sleep=pause,
        before_sleep=before_sleep,
        reraise=True,
    )
    attempts = 0
    try:
        async for trial in retrying:
            attempts = trial.retry_state.attempt_number
            with trial:
                return await one()
    except RETRYABLE as exc:
        raise GiveUp(exc, attempts) from exc
    raise AssertionError("unreachable")  # pragma: no cover - tenacity returns or raises

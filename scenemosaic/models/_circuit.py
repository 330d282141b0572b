"""``CircuitBreakerModel``: stop asking an endpoint that keeps failing.

Without it, every agent of a run whose server is down spends the full retry policy
(attempts, back-offs, time-outs) before falling back, one agent after another. With it,
after ``failure_threshold`` consecutive failed requests the circuit *opens*: requests are
refused at once with :class:`ModelUnavailableError`, which agents treat as a recoverable
failure, so they fall back to their rule solvers without touching the network. After
``reset_after_s`` one trial request is let through (*half-open*); if it gets an answer
the circuit closes again, otherwise it stays open for another ``reset_after_s``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Literal

import structlog

from scenemosaic.exceptions import (
    ModelConfigError,
    ModelContextLengthError,
    ModelDeadlineExceeded,
    ModelEndpointError,
    ModelError,
    ModelHTTPError,
    ModelUnavailableError,
    OutputValidationError,
    ReplayMissError,
)
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._wrapper import WrapperModel

__all__ = ["CircuitBreakerModel", "CircuitState"]

log = structlog.get_logger(__name__)

CircuitState = Literal["closed", "open", "half_open"]
"""``closed``: requests pass. ``open``: requests are refused. ``half_open``: one trial is out."""

_Outcome = Literal["failed", "answered", "unknown"]


def _outcome(exc: BaseException) -> _Outcome:
    """What a request's exception says about the endpoint's health.

    ``failed``: the endpoint is down or overloaded (5xx, 429, time-outs, transport errors,
    all after the model's own retries). ``answered``: the endpoint works, the request or the
    reply was wrong (a reply that failed validation, a prompt over the context window, other
    4xx). ``unknown``: says nothing about the endpoint (cancellation, a set-up error, the
    run's deadline, a refusal by this very breaker).
    """
    if isinstance(exc, ModelUnavailableError | ModelDeadlineExceeded | ReplayMissError):
        return "unknown"
    if isinstance(exc, ModelEndpointError):  # 401/403/404 came from a server; a refused connection did not
        return "failed" if exc.status_code is None else "answered"
    if isinstance(exc, OutputValidationError | ModelContextLengthError):
        return "answered"
    if isinstance(exc, ModelHTTPError):
        return "failed" if exc.status_code == 429 or exc.status_code >= 500 else "answered"
    if isinstance(exc, ModelError):
        return "failed"  # time-outs, refused or dropped connections: the transport's retries are spent
    return "unknown"


def _endpoint(model: Model) -> str:
    """The model's name, with the base URL of the innermost model that has one."""
    inner: object = model
    while inner is not None:
        base_url = getattr(inner, "base_url", None)
        if isinstance(base_url, str):
            return f"{model.name} at {base_url}"
        inner = getattr(inner, "wrapped", None)
    return model.name


class CircuitBreakerModel(WrapperModel):
    """Refuses requests at once while ``wrapped`` keeps failing; lets a trial through after a pause.

    * ``failure_threshold`` — consecutive failed requests (5xx, 429, time-outs, transport
      errors, each after the wrapped model's own retries) that open the circuit. A request
      that got an answer of any kind (valid, failing validation, a 4xx) resets the count.
    * ``reset_after_s`` — how long the circuit stays open before one trial request is let
      through; while that trial runs, other requests are still refused.
    * ``clock`` — injectable for tests (``time.monotonic`` by default).

    Opening is logged once, as a warning naming the endpoint and the last error; a refused
    request raises :class:`ModelUnavailableError` without sending anything.
    """

    def __init__(
        self,
        wrapped: Model,
        failure_threshold: int = 5,
        reset_after_s: float = 60.0,
        *,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if failure_threshold < 1:
            raise ModelConfigError(f"failure_threshold must be at least 1, got {failure_threshold}")
        if reset_after_s < 0:
            raise ModelConfigError(f"reset_after_s must not be negative, got {reset_after_s}")
        super().__init__(wrapped)
        self.failure_threshold = failure_threshold
        self.reset_after_s = reset_after_s
        self._clock = clock
        self.state: CircuitState = "closed"
        self.consecutive_failures = 0
        """Failed requests in a row (reset by any answer)."""
        self.last_error: str | None = None
        """``"Type: message"`` of the latest failure."""
        self._opened_at = 0.0

    def __repr__(self) -> str:
        return f"CircuitBreakerModel({self.wrapped!r}, state={self.state!r})"

    @property
    def retry_in_s(self) -> float:
        """Seconds until a trial request is let through (0 unless the circuit is open)."""
        if self.state == "closed":
            return 0.0
        return max(0.0, self._opened_at + self.reset_after_s - self._clock())

    def _admit(self) -> bool:
        """Whether the request may go; ``True`` also when it is the half-open trial."""
        if self.state == "closed":
            return True
        if self.state == "open" and self.retry_in_s <= 0:
            self.state = "half_open"
            log.info("model circuit half-open; sending one trial request", model=_endpoint(self.wrapped))
            return True
        return False  # open, or half-open with the trial still out

    def _refusal(self) -> ModelUnavailableError:
        endpoint = _endpoint(self.wrapped)
        wait = self.retry_in_s
        when = (
            f"a trial request goes in {wait:.0f} s"
            if self.state == "open"
            else "a trial request is under way"
        )
        return ModelUnavailableError(
            f"{endpoint} is unavailable: {self.consecutive_failures} requests in a row failed "
            f"(last: {self.last_error}); not sending this one ({when})",
            model=endpoint,
            last_error=self.last_error or "",
            retry_in_s=wait,
        )

    def _open(self) -> None:
        self.state = "open"
        self._opened_at = self._clock()

    def _record(self, outcome: _Outcome, trial: bool, exc: BaseException | None = None) -> None:
        if outcome == "answered":
            if self.state != "closed":
                log.info("model circuit closed; the endpoint answers again", model=_endpoint(self.wrapped))
            self.state = "closed"
            self.consecutive_failures = 0
            return
        if outcome == "unknown":
            if trial and self.state == "half_open":
                self.state = "open"  # the trial told nothing: the next request may try again
            return
        self.consecutive_failures += 1
        self.last_error = f"{type(exc).__name__}: {exc}"
        if trial and self.state == "half_open":
            self._open()
            log.warning(
                "model circuit re-opened; the trial request failed",
                model=_endpoint(self.wrapped),
                last_error=self.last_error[:300],
                retry_in_s=self.reset_after_s,
            )
        elif self.state == "closed" and self.consecutive_failures >= self.failure_threshold:
            self._open()
            log.warning(
                "model circuit opened: refusing requests to a failing endpoint",
                model=_endpoint(self.wrapped),
                failures=self.consecutive_failures,
                last_error=self.last_error[:300],
                retry_in_s=self.reset_after_s,
            )

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Forward while the circuit is closed (or as the half-open trial); else refuse at once."""
        if not self._admit():
            raise self._refusal()
        trial = self.state == "half_open"
        try:
            result = await self.wrapped.request(messages, output_type, settings, context=context)
        except BaseException as exc:  # a cancelled trial must hand the trial back
            self._record(_outcome(exc), trial, exc)
            raise
        self._record("answered", trial)
        return result

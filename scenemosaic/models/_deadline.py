"""``DeadlineModel``: one wall-clock budget for every model request of a run.

Once the budget is spent, a request raises :class:`ModelDeadlineExceeded` at once, without
sending anything; agents treat that like any other recoverable model failure and answer
with their rule solvers (when the run allows fallback). Before then, each request's
time-out is clamped to the time left, and a request still running when the deadline
passes is cancelled.
"""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import Callable

from scenemosaic.exceptions import ModelConfigError, ModelDeadlineExceeded
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._wrapper import WrapperModel

__all__ = ["DeadlineModel"]


class DeadlineModel(WrapperModel):
    """Requests to ``wrapped`` must all finish within ``deadline_s`` seconds of this wrapper's creation.

    * Before the deadline, each request's time-out (``ModelSettings.timeout_s``, else the
      wrapped model's own) is clamped to the time left and passed down in the settings, so
      an HTTP attempt never outlives the run; the wrapped call as a whole is cancelled if
      it is still running when the deadline passes (waits for a rate-limit slot included).
    * After the deadline, every request raises :class:`ModelDeadlineExceeded` at once.

    ``clock`` (``time.monotonic`` by default) is injectable for tests; the cancellation
    itself is timed by the event loop.
    """

    def __init__(
        self,
        wrapped: Model,
        deadline_s: float,
        *,
        clock: Callable[[], float] = time.monotonic,
        shown_s: float | None = None,
    ) -> None:
        if deadline_s < 0:
            raise ModelConfigError(f"deadline_s must not be negative, got {deadline_s}")
        super().__init__(wrapped)
        self.deadline_s = deadline_s
        self.shown_s = deadline_s if shown_s is None else shown_s
        """The deadline as the user set it, for messages (a run's stack opens after its start,
        so ``deadline_s`` is what was left of it then)."""
        self._clock = clock
        self.expires_at = clock() + deadline_s
        """The ``clock`` reading at which the deadline passes."""

    def __repr__(self) -> str:
        return f"DeadlineModel({self.wrapped!r}, deadline_s={self.deadline_s:g})"

    @property
    def remaining_s(self) -> float:
        """Seconds left before the deadline (0 once it has passed)."""
        return max(0.0, self.expires_at - self._clock())

    def _expired(self, context: RequestContext | None) -> ModelDeadlineExceeded:
        agent = context.agent if context else None
        return ModelDeadlineExceeded(
            f"{self.name}: the run's {self.shown_s:g} s deadline for model requests has passed "
            f"(request by agent {agent!r} not answered)"
        )

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Forward with the time-out clamped to the time left; refuse once the deadline has passed."""
        left = self.remaining_s
        if left <= 0:
            raise self._expired(context)
        settings = settings or ModelSettings()
        own = settings.timeout_s if settings.timeout_s is not None else self.wrapped.default_timeout_s
        clamped = left if own is None else min(own, left)
        settings = dataclasses.replace(settings, timeout_s=clamped)
        try:
            async with asyncio.timeout(left) as scope:
                return await self.wrapped.request(messages, output_type, settings, context=context)
        except TimeoutError as exc:
            if scope.expired():
                raise self._expired(context) from exc
            raise

    async def generate_image(self, prompt: str, *, size: str = "1024x1024", model: str | None = None) -> tuple[bytes, Usage]:
        """Forward under the same deadline: refused once it has passed, cancelled when it passes."""
        left = self.remaining_s
        if left <= 0:
            raise self._expired(RequestContext(agent="images"))
        try:
            async with asyncio.timeout(left) as scope:
                return await self.wrapped.generate_image(prompt, size=size, model=model)
        except TimeoutError as exc:
            if scope.expired():
                raise self._expired(RequestContext(agent="images")) from exc
            raise

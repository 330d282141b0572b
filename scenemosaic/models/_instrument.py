"""``InstrumentedModel``: one :class:`ModelCall` record per request, for events and usage totals."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import structlog

from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._wrapper import WrapperModel

__all__ = ["InstrumentedModel", "ModelCall"]

log = structlog.get_logger(__name__)


@dataclass(frozen=True)
class ModelCall:
    """What one model request did: who asked, which model, what it cost, how it ended."""

    agent: str | None
    """The asking agent (``RequestContext.agent``), if a context was given."""
    node: str | None
    """The task-graph node that ran the request, if any."""
    model: str
    """The model's name."""
    usage: Usage = field(default_factory=Usage)
    """Tokens and requests of the call. A failed call reports what it cost when the error
    carries it (an invalid reply, retried 429s and 5xx); else it is empty."""
    latency_s: float = 0.0
    """Wall-clock seconds from request to answer or error, repairs and retries included."""
    ok: bool = True
    """Whether a validated output came back."""
    error: str | None = None
    """``"ExceptionType: message"`` when the call failed."""
    error_type: str | None = None
    """The exception's class name when the call failed (e.g. ``"ModelHTTPError"``)."""


class InstrumentedModel(WrapperModel):
    """Calls ``on_call(ModelCall(...))`` after every request, successful or not.

    The callback runs synchronously in the event loop, so it should be quick (append to
    a list, put on a queue). An exception raised by the callback is logged and dropped:
    observing a run must not break it. ``clock`` (``time.perf_counter`` by default) is
    injectable for tests.
    """

    def __init__(
        self,
        wrapped: Model,
        on_call: Callable[[ModelCall], None],
        *,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        super().__init__(wrapped)
        self.on_call = on_call
        self._clock = clock

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Forward the request and report it."""
        agent = context.agent if context else None
        node = context.node if context else None
        started = self._clock()
        try:
            output, usage = await self.wrapped.request(messages, output_type, settings, context=context)
        except BaseException as exc:  # cancellations are reported too, then re-raised
            spent = getattr(exc, "usage", None)
            self._report(
                ModelCall(
                    agent=agent,
                    node=node,
                    model=self.name,
                    usage=spent if isinstance(spent, Usage) else Usage(),
                    latency_s=self._clock() - started,
                    ok=False,
                    error=f"{type(exc).__name__}: {exc}",
                    error_type=type(exc).__name__,
                )
            )
            raise
        self._report(
            ModelCall(agent=agent, node=node, model=self.name, usage=usage, latency_s=self._clock() - started)
        )
        return output, usage

    def _report(self, call: ModelCall) -> None:
        try:
            self.on_call(call)
        except Exception as exc:
            log.warning("on_call callback failed", model=call.model, agent=call.agent, error=repr(exc))

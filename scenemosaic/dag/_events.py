"""Typed run events and the stream that fans them out.

Every event is a frozen dataclass. A run's :class:`EventStream` keeps them in order, logs each
with structlog (node events at debug level, the rest at info) and hands them to listeners and
to any number of ``async for`` readers.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field, fields

import structlog

__all__ = [
    "EventListener",
    "EventStream",
    "ModelRequest",
    "NodeAdded",
    "NodeFailed",
    "NodeFinished",
    "NodeRetried",
    "NodeStarted",
    "RunEvent",
    "RunFinished",
]

_log = structlog.get_logger(__name__)


@dataclass(frozen=True, slots=True, kw_only=True)
class RunEvent:
    """Base of every run event."""

    at: float = field(default_factory=time.time)
    """Wall-clock time (seconds since the epoch) the event was made."""


@dataclass(frozen=True, slots=True, kw_only=True)
class NodeStarted(RunEvent):
    """A node's function is about to be awaited."""

    node: str
    """Node name."""
    attempt: int = 1
    """1 for the first try, 2 for the first retry, ..."""


@dataclass(frozen=True, slots=True, kw_only=True)
class NodeFinished(RunEvent):
    """A node produced its output, by running or from the run store."""

    node: str
    """Node name."""
    duration_s: float
    """Seconds from the first start to the output (store lookup time when cached)."""
    cached: bool = False
    """True when the output came from the run store and the function did not run."""


@dataclass(frozen=True, slots=True, kw_only=True)
class NodeRetried(RunEvent):
    """An attempt failed and the node will be tried again after ``delay_s``."""

    node: str
    """Node name."""
    attempt: int
    """The attempt that failed (1-based)."""
    error: str
    """``ExceptionType: message`` of the failure."""
    delay_s: float
    """Seconds waited before the next attempt."""


@dataclass(frozen=True, slots=True, kw_only=True)
class NodeFailed(RunEvent):
    """A node failed for good; the run stops."""

    node: str
    """Node name."""
    attempts: int
    """How many attempts were made."""
    error: str
    """``ExceptionType: message`` of the last failure."""


@dataclass(frozen=True, slots=True, kw_only=True)
class NodeAdded(RunEvent):
    """A running node added a node to the graph."""

    node: str
    """Name of the new node."""
    added_by: str
    """Name of the node that added it."""
    depends_on: tuple[str, ...] = ()
    """The new node's dependencies."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ModelRequest(RunEvent):
    """One model call, reported by the run's :class:`~scenemosaic.dag.UsageTracker`."""

    agent: str
    """Name of the asking agent."""
    node: str | None
    """Node that made the call, when known."""
    model: str
    """Model name."""
    input_tokens: int
    """Prompt text tokens."""
    output_tokens: int
    """Reply tokens."""
    image_tokens: int
    """Tokens spent on images."""
    latency_s: float
    """Seconds the call took."""
    ok: bool
    """False when the call raised."""
    cost: float | None = None
    """Cost of the call from the tracker's cost table, when it has the model."""


@dataclass(frozen=True, slots=True, kw_only=True)
class RunFinished(RunEvent):
    """The run ended (always the last event of a run)."""

    ok: bool
    """True when every node finished."""
    duration_s: float
    """Seconds from start to end."""
    executed: int
    """Nodes whose function ran to completion."""
    cached: int
    """Nodes whose output came from the run store."""
    error: str | None = None
    """``ExceptionType: message`` of what stopped the run, if anything."""


EventListener = Callable[[RunEvent], object]
"""A plain callback receiving every event of a run, in order."""

_EVENT_NAMES: dict[type[RunEvent], str] = {
    NodeStarted: "node_started",
    NodeFinished: "node_finished",
    NodeRetried: "node_retried",
    NodeFailed: "node_failed",
    NodeAdded: "node_added",
    ModelRequest: "model_request",
    RunFinished: "run_finished",
}
_DEBUG_EVENTS = (NodeStarted, NodeFinished, NodeAdded, ModelRequest)


class EventStream:
    """Ordered, replayable fan-out of one run's events.

    A reader that starts late still sees every event from the beginning; iteration ends
    after :class:`RunFinished`.
    """

    def __init__(self, listeners: tuple[EventListener, ...] = ()) -> None:
        self.history: list[RunEvent] = []
        """Every event emitted so far, in order."""
        self._listeners = listeners
        self._readers: list[asyncio.Queue[RunEvent]] = []
        self._closed = False

    def emit(self, event: RunEvent) -> None:
        """Record, log and deliver ``event``."""
        self.history.append(event)
        name = _EVENT_NAMES.get(type(event), type(event).__name__)
        if isinstance(event, _DEBUG_EVENTS):
            _log.debug(name, **_fields(event))
        elif isinstance(event, NodeRetried | NodeFailed):
            _log.warning(name, **_fields(event))
        else:
            _log.info(name, **_fields(event))
        for listener in self._listeners:
            listener(event)
        for queue in self._readers:
            queue.put_nowait(event)
        if isinstance(event, RunFinished):
            self._closed = True

    async def __aiter__(self) -> AsyncIterator[RunEvent]:
        queue: asyncio.Queue[RunEvent] = asyncio.Queue()
        for event in self.history:
            queue.put_nowait(event)
        if not self._closed:
            self._readers.append(queue)
        try:
            while True:
                if self._closed and queue.empty():
                    return
                event = await queue.get()
                yield event
                if isinstance(event, RunFinished):
                    return
        finally:
            if queue in self._readers:
                self._readers.remove(queue)


_FIELD_NAMES: dict[type[RunEvent], tuple[str, ...]] = {}


def _fields(event: RunEvent) -> dict[str, object]:
    names = _FIELD_NAMES.get(type(event))
    if names is None:
        names = _FIELD_NAMES[type(event)] = tuple(f.name for f in fields(event) if f.name != "at")
    return {name: getattr(event, name) for name in names}

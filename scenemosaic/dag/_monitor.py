"""The seam through which an outside observer (e.g. usage accounting) joins a running graph."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from scenemosaic.dag._events import RunEvent
from scenemosaic.exceptions import UsageLimitExceeded

__all__ = ["RunMonitor"]


class RunMonitor(Protocol):
    """Something a :class:`~scenemosaic.dag.Runner` binds to for the length of one run.

    While bound, the monitor may emit events into the run's stream and stop the run with a
    :class:`~scenemosaic.exceptions.UsageLimitExceeded`; the runner unbinds it (``bind(None)``)
    when the run ends. The models layer's ``UsageTracker`` is the implementation the library
    ships; the scheduler knows nothing about models.
    """

    def bind(
        self,
        emit: Callable[[RunEvent], None] | None,
        stop: Callable[[UsageLimitExceeded], None] | None = None,
    ) -> None:
        """Attach to a run (``emit``/``stop`` given) or detach (``None``)."""

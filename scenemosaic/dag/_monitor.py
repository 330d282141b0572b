"""The seam through which an outside observer (e.g. usage accounting) joins a running graph."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from scenemosaic.exceptions import UsageLimitExceeded

__all__ = ["ModelCallReport", "RunMonitor"]

ModelCallReport = Callable[[Any], None]
"""What a bound monitor calls once per model call, with an object carrying ``agent``, ``node``,
``model``, ``usage`` (``input_tokens``, ``output_tokens``, ``image_tokens``), ``latency_s``,
``ok`` and ``cost`` (the models layer's ``UsageRecord``); the runner turns it into a
:class:`~scenemosaic.dag.ModelRequest` event."""


class RunMonitor(Protocol):
    """Something a :class:`~scenemosaic.dag.Runner` binds to for the length of one run.

    While bound, the monitor reports model calls (the runner emits them as events) and may stop the run with a
    :class:`~scenemosaic.exceptions.UsageLimitExceeded`; the runner unbinds it (``bind(None)``)
    when the run ends. The models layer's ``UsageTracker`` is the implementation the library
    ships; the scheduler knows nothing about models.
    """

    def bind(
        self,
        report: ModelCallReport | None,
        stop: Callable[[UsageLimitExceeded], None] | None = None,
    ) -> None:
        """Attach to a run (``report``/``stop`` given) or detach (``None``)."""

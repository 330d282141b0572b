"""Usage accounting for a run: the callback an instrumented model reports each call to.

``UsageTracker.on_call`` (also the tracker itself, as a callable) takes any object with the
fields of the models layer's ``ModelCall``: ``agent``, ``node``, ``model``, ``usage``
(:class:`~scenemosaic.models._base.Usage`), ``latency_s``, ``ok``, ``error``. It keeps per-call
records and totals per agent, per model and per run, prices calls from an optional cost
table, reports each :class:`UsageRecord` to the task-graph run it is bound to (which emits it
as a ``ModelRequest`` event), and enforces :class:`UsageLimits`.

The instrumented model swallows exceptions raised by its callback (observing must not break
a call), so a crossed limit is not signalled by raising: the tracker tells the runner it is
bound to, which stops the whole run cleanly and raises
:class:`~scenemosaic.exceptions.UsageLimitExceeded` with the partial results. A tracker bound
to no runner raises instead.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from scenemosaic.exceptions import UsageLimitExceeded
from scenemosaic.models._base import Usage

__all__ = ["ModelCallLike", "ModelPrice", "UsageLimits", "UsageRecord", "UsageTracker", "charged_usage"]


class ModelCallLike(Protocol):
    """The fields of one model call as the models layer reports it (``ModelCall``)."""

    @property
    def agent(self) -> str | None: ...
    @property
    def node(self) -> str | None: ...
    @property
    def model(self) -> str: ...
    @property
    def usage(self) -> Usage: ...
    @property
    def latency_s(self) -> float: ...
    @property
    def ok(self) -> bool: ...
    @property
    def error(self) -> str | None: ...


def charged_usage(usage: Usage, *, cancelled: bool = False) -> Usage:
    """What one call costs the run, as every usage record counts it: a call cancelled because the
    run was stopping (or its deadline passed) charges nothing; a call that reports no request (a
    failed one, or a model that does not count its requests) charges one request."""
    if cancelled:
        return Usage()
    if usage.requests == 0 and usage.cached == 0:
        return usage + Usage(requests=1)
    return usage


@dataclass(frozen=True, slots=True)
class ModelPrice:
    """Price of a model's tokens, in any currency unit (used consistently across the table)."""

    input_per_1k: float
    """Price per 1,000 input tokens; image tokens are billed as input tokens."""
    output_per_1k: float
    """Price per 1,000 output tokens."""

    def cost(self, usage: Usage) -> float:
        """Cost of ``usage`` at this price."""
        return (usage.input_tokens + usage.image_tokens) / 1000 * self.input_per_1k + (
            usage.output_tokens / 1000 * self.output_per_1k
        )


@dataclass(frozen=True, slots=True)
class UsageLimits:
    """Caps on a run's model usage; ``None`` means no cap.

    A cap is checked after every call: the call that crosses it still counts, and the run
    stops with :class:`~scenemosaic.exceptions.UsageLimitExceeded`. :meth:`UsageTracker.before_call`
    additionally refuses a request once ``max_requests`` requests were made.
    """

    max_requests: int | None = None
    """Most HTTP requests the run may make, counted as ``Usage.requests`` counts them: every
    attempt the server answered (retries included); a call that got no answer at all counts one."""
    max_total_tokens: int | None = None
    """Most tokens (input + output + image) the run may spend."""
    max_cost: float | None = None
    """Most money the run may spend, priced with the tracker's cost table (models missing
    from the table cost nothing)."""


@dataclass(frozen=True, slots=True)
class UsageRecord:
    """One recorded call."""

    agent: str
    """Asking agent (``"?"`` when the call had no context)."""
    node: str | None
    """Node that made the call."""
    model: str
    """Model name."""
    usage: Usage
    """Tokens and requests of the call."""
    latency_s: float
    """Seconds the call took."""
    ok: bool
    """False when the call failed."""
    cost: float | None
    """Priced cost, when the model is in the cost table."""


@dataclass
class UsageTracker:
    """Per-call, per-agent, per-model and per-run usage of a run, with optional limits and prices.

    Pass it as the ``on_call`` callback of the models layer's instrumented model, and as
    ``usage=`` to the :class:`~scenemosaic.dag.Runner` so its calls appear as
    :class:`~scenemosaic.dag.ModelRequest` events.
    """

    limits: UsageLimits = field(default_factory=UsageLimits)
    """Caps that stop the run when crossed."""
    prices: Mapping[str, ModelPrice] = field(default_factory=dict)
    """Cost table: model name -> price."""
    calls: list[UsageRecord] = field(default_factory=list)
    """Every call, in the order reported."""
    total: Usage = field(default_factory=Usage)
    """Run totals."""
    by_agent: dict[str, Usage] = field(default_factory=dict)
    """Totals per agent name."""
    by_model: dict[str, Usage] = field(default_factory=dict)
    """Totals per model name."""
    cost: float = 0.0
    """Total priced cost."""
    exceeded: UsageLimitExceeded | None = None
    """The first limit crossing, if any."""
    _listener: Callable[[UsageRecord], None] | None = field(default=None, repr=False)
    _stop: Callable[[UsageLimitExceeded], None] | None = field(default=None, repr=False)

    def bind(
        self, listener: Callable[[UsageRecord], None] | None, stop: Callable[[UsageLimitExceeded], None] | None = None
    ) -> None:
        """Attach to a run (the runner does this): ``listener`` receives each call's
        :class:`UsageRecord`, ``stop`` is called when a limit is crossed."""
        self._listener = listener
        self._stop = stop

    def before_call(self, agent: str, node: str | None = None, model: str | None = None) -> None:
        """Raise :class:`~scenemosaic.exceptions.UsageLimitExceeded` if another request would break a limit."""
        limits = self.limits
        if limits.max_requests is not None and self.total.requests >= limits.max_requests:
            raise UsageLimitExceeded(
                f"request limit {limits.max_requests} reached; refusing a call by agent {agent!r}"
                + (f" in node {node!r}" if node else "")
            )
        self._check_totals()

    def on_call(self, call: ModelCallLike) -> None:
        """Record one finished call (a cancelled one is listed but charges nothing); raise :class:`~scenemosaic.exceptions.UsageLimitExceeded` if a cap is crossed."""
        usage = charged_usage(call.usage, cancelled=getattr(call, "error_type", None) == "CancelledError")
        agent = call.agent or "?"
        price = self.prices.get(call.model)
        cost = price.cost(usage) if price is not None else None
        record = UsageRecord(agent, call.node, call.model, usage, call.latency_s, call.ok, cost)
        self.calls.append(record)
        self.total = self.total + usage
        self.by_agent[agent] = self.by_agent.get(agent, Usage()) + usage
        self.by_model[call.model] = self.by_model.get(call.model, Usage()) + usage
        if cost is not None:
            self.cost += cost
        if self._listener is not None:
            self._listener(record)
        limits = self.limits
        try:
            if limits.max_requests is not None and self.total.requests > limits.max_requests:
                raise UsageLimitExceeded(
                    f"request limit {limits.max_requests} exceeded ({self.total.requests} requests)"
                )
            self._check_totals()
        except UsageLimitExceeded as exc:
            if self.exceeded is None:
                self.exceeded = exc
            if self._stop is None:
                raise
            self._stop(exc)

    __call__ = on_call

    def _check_totals(self) -> None:
        limits = self.limits
        if limits.max_total_tokens is not None and self.total.total_tokens > limits.max_total_tokens:
            raise UsageLimitExceeded(
                f"token limit {limits.max_total_tokens} exceeded ({self.total.total_tokens} tokens)"
            )
        if limits.max_cost is not None and self.cost > limits.max_cost:
            raise UsageLimitExceeded(f"cost limit {limits.max_cost:g} exceeded ({self.cost:.4g})")

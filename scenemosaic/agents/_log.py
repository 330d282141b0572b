"""``AgentLog``: the one collector of agent results a runner hands every :class:`AgentResult` to.

The runner of an agent (:func:`~scenemosaic.agents.run_agent`, and through it the task-graph
nodes of :func:`~scenemosaic.agents.run_agents`, the evolve loop, perception) records each result
here, and the model requests of an agent run that raised. A caller reads from one place how each
agent was answered, which fell back to their rule solvers, and what their requests cost (by agent
and in total, in the shape of the run report's ``usage``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from scenemosaic.agents._base import AgentOutcome, AgentResult, FallbackRecord, calls_of
from scenemosaic.models import Usage, UsageRecord, usage_summary

__all__ = ["AgentLog"]


@dataclass
class AgentLog:
    """Every agent result its runners handed over, in the order they were recorded.

    ``results`` holds the results; ``failed_calls`` the model requests of agent runs that raised
    (no result came back to carry them). Everything else is read from those two: ``outcomes``,
    ``fallbacks``, ``calls``, ``usage``, ``usage_by_agent`` and :meth:`usage_summary`.
    """

    results: list[AgentResult[Any]] = field(default_factory=list)
    failed_calls: list[UsageRecord] = field(default_factory=list)

    def record(self, result: AgentResult[Any]) -> None:
        """Keep one agent's result."""
        self.results.append(result)

    __call__ = record

    def record_failure(self, exc: BaseException, spent: Iterable[UsageRecord] = ()) -> None:
        """Keep the model requests of an agent run that raised ``exc`` (and ``spent``: requests of
        an earlier answer of the same run that was not applied)."""
        self.failed_calls.extend(spent)
        self.failed_calls.extend(calls_of(exc))

    def merge(self, other: AgentLog, order: Callable[[str], Any] | None = None) -> None:
        """Take in ``other``'s results (sorted by ``order`` of the agent's name when given; ties
        keep their order) and failed runs' requests."""
        results = other.results if order is None else sorted(other.results, key=lambda r: order(r.agent))
        self.results.extend(results)
        self.failed_calls.extend(other.failed_calls)

    @property
    def outcomes(self) -> dict[str, AgentOutcome]:
        """How each agent was answered, by agent name (the last result of an agent run twice)."""
        return {r.agent: r.outcome for r in self.results}

    @property
    def fallbacks(self) -> list[FallbackRecord]:
        """The agents answered by their rule solvers instead of the model, and why, in order."""
        return [r.fallback for r in self.results if r.fallback is not None]

    @property
    def calls(self) -> list[UsageRecord]:
        """Every model request of the recorded runs (those that raised included)."""
        return [c for r in self.results for c in r.calls] + self.failed_calls

    @property
    def usage(self) -> Usage:
        """What every request cost, in total."""
        return sum((c.usage for c in self.calls), Usage())

    @property
    def usage_by_agent(self) -> dict[str, Usage]:
        """What each agent's requests cost, by agent name."""
        out: dict[str, Usage] = {}
        for c in self.calls:
            out[c.agent] = out.get(c.agent, Usage()) + c.usage
        return out

    def usage_summary(self) -> dict[str, Any]:
        """Requests, tokens, failed calls and latencies, in total and per agent (the shape of a
        stage's ``usage`` in ``report.json``: :func:`scenemosaic.models.usage_summary`)."""
        return usage_summary(self.calls)

"""``SolverFallbackModel``: when a real model fails, answer with the agent's own rule solver.

Batch users would rather get a scene structured by the rules than no scene because a small
local model wrote broken JSON or a provider kept answering 503. The fallback covers model
failures that persist after retries and schema repairs; it never hides configuration errors
(bad key → HTTP 401, a missing replay entry, vision on a text-only server), which still raise.
Agents whose *checked* output stays unusable after their own repair loop also consult
``solver_fallback`` (see :meth:`scenemosaic.agents.TaskAgent.run`).
"""

from __future__ import annotations

from dataclasses import dataclass

import structlog

from scenemosaic.exceptions import ModelError, ModelHTTPError, ReplayMissError
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._wrapper import WrapperModel

__all__ = ["FallbackRecord", "SolverFallbackModel"]

log = structlog.get_logger(__name__)


@dataclass(frozen=True)
class FallbackRecord:
    """One request answered by the rule solver instead of the model."""

    agent: str
    reason: str


def _recoverable(exc: ModelError) -> bool:
    if isinstance(exc, ReplayMissError):
        return False  # a cassette mismatch is a setup error, not a flaky model
    if isinstance(exc, ModelHTTPError):
        return exc.status_code == 429 or exc.status_code >= 500
    return True  # unusable replies, time-outs, dropped connections after retries


class SolverFallbackModel(WrapperModel):
    """Forwards to ``wrapped``; on a persistent model failure answers with ``context.solve``.

    ``fallbacks`` lists every request answered by a solver, in order.
    """

    solver_fallback = True
    """Read by task agents: fall back to the solver when a checked output stays unusable."""

    def __init__(self, wrapped: Model) -> None:
        super().__init__(wrapped)
        self.fallbacks: list[FallbackRecord] = []

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Ask the wrapped model; on a recoverable failure use the asking agent's solver."""
        try:
            return await self.wrapped.request(messages, output_type, settings, context=context)
        except ModelError as exc:
            if context is None or context.solve is None or not _recoverable(exc):
                raise
            reason = f"{type(exc).__name__}: {exc}"
            self.record(context.agent, reason)
            answer = context.solve(context.evidence)
            return output_type.model_validate(answer.model_dump()), Usage()

    def record(self, agent: str, reason: str) -> None:
        """Note (and log) that ``agent`` was answered by its rule solver."""
        self.fallbacks.append(FallbackRecord(agent=agent, reason=reason[:500]))
        log.warning("model_fell_back_to_solver", agent=agent, reason=reason[:200])

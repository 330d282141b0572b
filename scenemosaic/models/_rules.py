"""The offline ``rules`` model: each agent's own deterministic solver answers its requests."""

from __future__ import annotations

import asyncio

from pydantic import BaseModel, ValidationError

from scenemosaic.exceptions import ModelConfigError, ModelError, OutputValidationError
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage

__all__ = ["RulesModel"]


class RulesModel(Model):
    """Answers a request with ``context.solve(context.evidence)``, validated as the output type.

    No prompt is read and no network is touched: the messages are ignored. Usage counts
    requests only (no tokens). Text-only by nature, so ``vision`` is false and agents skip
    rendering images for it.

    A solver is plain CPU work (on a large scene, pairwise geometry over every object), so
    it runs in a worker thread: the event loop stays free for other nodes while it works.
    Solvers are pure functions of their evidence, so this changes no result.
    """

    name = "rules"
    vision = False

    def __repr__(self) -> str:
        return "RulesModel()"

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Run the asking agent's solver on its evidence."""
        if context is None or context.solve is None:
            agent = context.agent if context else "(no context)"
            raise ModelConfigError(
                f"the rules model needs a solver, but agent {agent!r} sent none; "
                "use a VLM model (e.g. openai:<model>) for this agent"
            )
        agent = context.agent
        try:
            result = await asyncio.to_thread(context.solve, context.evidence)
        except Exception as exc:
            raise ModelError(f"rules solver of agent {agent!r} failed: {type(exc).__name__}: {exc}") from exc
        usage = Usage(requests=1)
        if isinstance(result, output_type):
            return result, usage
        if isinstance(result, BaseModel):
            raise OutputValidationError(
                f"rules solver of agent {agent!r} returned a {type(result).__name__}, "
                f"expected a {output_type.__name__}",
                raw_reply=result.model_dump_json(),
                errors=[f"wrong type {type(result).__name__}"],
            )
        try:
            return output_type.model_validate(result), usage
        except ValidationError as exc:
            raise OutputValidationError(
                f"rules solver of agent {agent!r} returned an invalid {output_type.__name__}: {exc}",
                raw_reply=repr(result),
                errors=[str(e["msg"]) for e in exc.errors(include_url=False)],
            ) from exc

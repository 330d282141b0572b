"""The offline ``rules`` model: agents answer with their own deterministic solvers."""

from __future__ import annotations

from scenemosaic.exceptions import ModelConfigError
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage

__all__ = ["RulesModel"]


class RulesModel(Model):
    """The offline default: no prompt is read and no network is touched.

    ``uses_rule_solvers`` tells every task agent to answer with its own rule solver (a real
    geometric/semantic solver over the agent's evidence), so the model itself is never asked;
    :meth:`request` exists only to fail clearly when something other than an agent calls it.
    Text-only by nature, so ``vision`` is false.
    """

    name = "rules"
    vision = False
    uses_rule_solvers = True

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
        """Always raises: the rules model has no answers of its own."""
        agent = context.agent if context else "(no context)"
        raise ModelConfigError(
            f"the rules model answers through each task agent's rule solver, not through request() "
            f"(asked by {agent!r}); use a VLM model (e.g. openai:<model>) for free-form requests"
        )

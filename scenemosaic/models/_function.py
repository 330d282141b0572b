"""``FunctionModel``: answers come from plain Python callables (tests, scripted runs)."""

from __future__ import annotations

import inspect
import json
from collections.abc import Awaitable, Callable, Mapping
from typing import Any, TypeAlias

from pydantic import BaseModel

from scenemosaic.exceptions import ModelConfigError
from scenemosaic.models._base import Message, ModelSettings, RequestContext, Usage
from scenemosaic.models._completion import Completion, CompletionModel

__all__ = ["AgentFunction", "FunctionModel"]

AgentFunction: TypeAlias = Callable[[list[Message], RequestContext | None], Any | Awaitable[Any]]
"""``fn(messages, context)`` returning (or awaiting to) an output object, a dict or a JSON string."""


class FunctionModel(CompletionModel):
    """A model whose replies come from Python functions, one per agent or one for all.

    A function gets the messages (with any repair turns appended) and the request
    context, and returns the output object, a dict, or a JSON string (code fences and
    surrounding prose are tolerated). It may be sync or async. An invalid reply
    raises :class:`~scenemosaic.exceptions.OutputValidationError` as a real model's does, so
    a function can be used to test the agents' repair behaviour.
    """

    def __init__(
        self,
        functions: AgentFunction | Mapping[str, AgentFunction],
        *,
        name: str = "function",
        vision: bool = True,
    ) -> None:
        """``functions``: one callable for every agent, or a mapping from agent name to callable."""
        self._functions = functions
        self.name = name
        self.vision = vision

    def __repr__(self) -> str:
        return f"FunctionModel(name={self.name!r})"

    def _function_for(self, context: RequestContext | None) -> AgentFunction:
        if not isinstance(self._functions, Mapping):
            return self._functions
        agent = context.agent if context else None
        if agent is None or agent not in self._functions:
            raise ModelConfigError(
                f"FunctionModel {self.name!r} has no function for agent {agent!r} "
                f"(it has: {', '.join(sorted(self._functions)) or 'none'})"
            )
        return self._functions[agent]

    async def complete(
        self,
        messages: list[Message],
        output_type: type[BaseModel],
        settings: ModelSettings,
        context: RequestContext | None,
    ) -> Completion:
        """Call the agent's function and wrap what it returns."""
        result = self._function_for(context)(list(messages), context)
        if inspect.isawaitable(result):
            result = await result
        usage = Usage(requests=1)
        if isinstance(result, str):
            return Completion(text=result, usage=usage)
        if isinstance(result, BaseModel):
            return Completion(text=result.model_dump_json(), usage=usage, value=result)
        try:
            text = json.dumps(result, sort_keys=True, default=str)
        except (TypeError, ValueError):
            text = repr(result)
        return Completion(text=text, usage=usage, value=result)

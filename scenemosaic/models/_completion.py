"""Models that produce text (or loose JSON) and the schema-repair loop that validates it.

:class:`CompletionModel` implements :meth:`Model.request` once for every model whose raw
answer may be wrong: it parses the reply and validates it as the output type; when that
fails it raises :class:`OutputValidationError` with the raw reply and the errors in words,
so the asking agent can send a repair request within its own attempt budget (models never
repair on their own: one budget per agent).
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Any

import structlog
from pydantic import BaseModel, ValidationError

from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._schema import extract_json

__all__ = ["Completion", "CompletionModel", "validate_reply"]

log = structlog.get_logger(__name__)

_NO_VALUE: Any = object()


@dataclass
class Completion:
    """One raw answer from a model, before validation."""

    text: str
    """The reply as text (what is shown back to the model in a repair request)."""
    usage: Usage = field(default_factory=Usage)
    truncated: bool = False
    """True when the reply hit the output-token cap; a truncated reply is never accepted."""
    value: Any = _NO_VALUE
    """An already-decoded reply (a dict or a pydantic object), when the model has one."""


def validate_reply(completion: Completion, output_type: type[OutputT]) -> tuple[OutputT | None, list[str]]:
    """Validate one completion as ``output_type``: the output, or ``None`` and the errors in words."""
    if completion.truncated:
        return None, ["the reply was cut off at the output-token limit; answer more briefly"]
    value = completion.value
    if value is _NO_VALUE:
        try:
            value = extract_json(completion.text)
        except ValueError as exc:
            return None, [str(exc)]
    if isinstance(value, output_type):
        return value, []
    if isinstance(value, BaseModel):
        return None, [f"expected a {output_type.__name__} object, got a {type(value).__name__}"]
    try:
        return output_type.model_validate(value), []
    except ValidationError as exc:
        errors = []
        for err in exc.errors(include_url=False):
            where = ".".join(str(p) for p in err["loc"]) or "(root)"
            errors.append(f"{where}: {err['msg']}")
        return None, errors


class CompletionModel(Model):
    """A model whose raw answers are parsed and validated here.

    Subclasses implement :meth:`complete`; :meth:`request` validates its result and raises
    :class:`OutputValidationError` (carrying the raw reply, the errors and the usage) when it
    is not a valid output.
    """

    @abc.abstractmethod
    async def complete(
        self,
        messages: list[Message],
        output_type: type[BaseModel],
        settings: ModelSettings,
        context: RequestContext | None,
    ) -> Completion:
        """One raw answer to ``messages``."""

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Ask once and validate as ``output_type``."""
        settings = settings or ModelSettings()
        agent = context.agent if context else None
        completion = await self.complete(list(messages), output_type, settings, context)
        output, errors = validate_reply(completion, output_type)
        if output is not None:
            return output, completion.usage
        log.info("model reply invalid", model=self.name, agent=agent, errors=errors[:5])
        raise OutputValidationError(
            f"{self.name}: reply for agent {agent!r} is not a valid {output_type.__name__}: {'; '.join(errors[:5])}",
            raw_reply=completion.text,
            errors=errors,
            usage=completion.usage,
        )

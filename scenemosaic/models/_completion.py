"""Models that produce text (or loose JSON) and the schema-repair loop that validates it.

:class:`CompletionModel` implements :meth:`Model.request` once for every model whose raw
answer may be wrong: it parses the reply, validates it as the output type, and when that
fails asks again with the bad reply and the validation errors appended, up to
``max_repairs`` times, before raising :class:`OutputValidationError`.
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
    """A model whose answers are validated here, with schema repair.

    Subclasses implement :meth:`complete`; :meth:`request` parses and validates its
    result and re-asks on failure.
    """

    max_repairs: int = 2
    """How many times an invalid reply is sent back with its errors before giving up."""

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
        """Ask, validate as ``output_type``, and repair up to ``max_repairs`` times."""
        settings = settings or ModelSettings()
        conversation = list(messages)
        total = Usage()
        agent = context.agent if context else None
        for attempt in range(self.max_repairs + 1):
            completion = await self.complete(conversation, output_type, settings, context)
            total = total + completion.usage
            output, errors = validate_reply(completion, output_type)
            if output is not None:
                return output, total
            log.info("model reply invalid", model=self.name, agent=agent, attempt=attempt, errors=errors[:5])
            if attempt == self.max_repairs:
                raise OutputValidationError(
                    f"{self.name}: reply for agent {agent!r} is not a valid {output_type.__name__} "
                    f"after {self.max_repairs} repairs: {'; '.join(errors[:5])}",
                    raw_reply=completion.text,
                    errors=errors,
                )
            conversation = [
                *conversation,
                Message.text("assistant", completion.text),
                Message.text(
                    "user",
                    f"That reply is not a valid {output_type.__name__} JSON object:\n- "
                    + "\n- ".join(errors)
                    + "\nReply again with only the corrected JSON object.",
                ),
            ]
        raise AssertionError("unreachable")  # pragma: no cover

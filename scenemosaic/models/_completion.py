"""Models that produce text (or loose JSON) and the schema-repair loop that validates it.

:class:`CompletionModel` implements :meth:`Model.request` once for every model whose raw
answer may be wrong: it parses the reply and validates it as the output type; when that
fails it raises :class:`OutputValidationError` with the raw reply and the errors in words,
so the asking agent can send a repair request within its own attempt budget (models never
repair on their own: one budget per agent).

Validation of a large reply (over :data:`OFFLOAD_REPLY_CHARS`) runs in a worker thread, so
parsing it never stalls the event loop where other requests are waiting. The raw reply an
error carries is an excerpt (:data:`RAW_REPLY_EXCERPT_CHARS`), so a runaway reply is never
sent back whole in a repair request.
"""

from __future__ import annotations

import abc
import asyncio
from dataclasses import dataclass, field
from typing import Any

import structlog
from pydantic import BaseModel, ValidationError

from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._schema import extract_json

__all__ = [
    "OFFLOAD_REPLY_CHARS",
    "RAW_REPLY_EXCERPT_CHARS",
    "Completion",
    "CompletionModel",
    "excerpt",
    "validate_reply",
]

log = structlog.get_logger(__name__)

_NO_VALUE: Any = object()

OFFLOAD_REPLY_CHARS = 64_000
"""Replies longer than this (characters) are parsed and validated in a worker thread."""
RAW_REPLY_EXCERPT_CHARS = 8_000
"""Most characters of a bad reply kept in ``OutputValidationError.raw_reply``."""
MAX_REPLY_ERRORS = 20
"""Most validation errors listed for one reply (the rest are summed up in one line)."""


def excerpt(text: str, limit: int = RAW_REPLY_EXCERPT_CHARS) -> str:
    """``text`` itself when it is short, else its first ``limit`` characters and how much was cut."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}\n[... {len(text) - limit} more characters cut]"


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
    problems: list[str] = field(default_factory=list)
    """Why the answer is unusable before any parsing (a malformed server reply, an
    oversized body); a completion with problems is never accepted."""


def validate_reply(completion: Completion, output_type: type[OutputT]) -> tuple[OutputT | None, list[str]]:
    """Validate one completion as ``output_type``: the output, or ``None`` and the errors in words."""
    if completion.problems:
        return None, list(completion.problems)
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
        found = exc.errors(include_url=False)
        errors = []
        for err in found[:MAX_REPLY_ERRORS]:
            where = ".".join(str(p) for p in err["loc"]) or "(root)"
            errors.append(f"{where}: {err['msg']}")
        if len(found) > MAX_REPLY_ERRORS:  # the repair request lists them; a few suffice
            errors.append(f"... and {len(found) - MAX_REPLY_ERRORS} more errors like these")
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
        if len(completion.text) > OFFLOAD_REPLY_CHARS:
            output, errors = await asyncio.to_thread(validate_reply, completion, output_type)
        else:
            output, errors = validate_reply(completion, output_type)
        if output is not None:
            return output, completion.usage
        log.info("model reply invalid", model=self.name, agent=agent, errors=errors[:5])
        raise OutputValidationError(
            f"{self.name}: reply for agent {agent!r} is not a valid {output_type.__name__}: {'; '.join(errors[:5])}",
            raw_reply=excerpt(completion.text),
            errors=errors,
            usage=completion.usage,
        )

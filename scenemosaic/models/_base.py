"""The one seam for language/vision models: :class:`Model` with a single abstract ``request``.

Retry, rate limits, replay/record and usage accounting are *wrappers* around a model,
not flags on it. The offline default (``rules``) sends no request at all: a model whose
``uses_rule_solvers`` is true tells the asking agent to answer with its own deterministic
solver. Models never call agent code.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Literal, TypeVar

from pydantic import BaseModel

__all__ = [
    "ImagePart",
    "Message",
    "Model",
    "ModelSettings",
    "RequestContext",
    "TextPart",
    "Usage",
]

OutputT = TypeVar("OutputT", bound=BaseModel)


@dataclass(frozen=True)
class TextPart:
    """A piece of text in a message."""

    text: str


@dataclass(frozen=True)
class ImagePart:
    """A PNG image in a message (sent as a base64 data URL on the wire)."""

    png: bytes
    label: str | None = None
    """Short caption; text-only models receive the agent's text rendering instead of the image."""


@dataclass(frozen=True)
class Message:
    """One chat message: a role and an ordered list of text and image parts."""

    role: Literal["system", "user", "assistant"]
    parts: tuple[TextPart | ImagePart, ...]

    @classmethod
    def text(cls, role: Literal["system", "user", "assistant"], text: str) -> Message:
        return cls(role=role, parts=(TextPart(text),))

    @property
    def has_images(self) -> bool:
        return any(isinstance(p, ImagePart) for p in self.parts)


@dataclass(frozen=True)
class ModelSettings:
    """Per-request settings. ``None`` means "the model's own default"."""

    temperature: float | None = 0.0
    """Sampling temperature; 0 for reproducible structured answers."""
    max_tokens: int | None = 2048
    """Cap on output tokens. A reply cut at this cap is treated as truncated, never as valid."""
    retry_truncated: bool = True
    """Ask once more with twice ``max_tokens`` when a reply is cut at the cap. Off for a cap sized
    to the answer (an agent's ``reply_tokens``): a reply that outgrows it is a model repeating
    itself, and the agent's repair asks for a shorter answer instead."""
    timeout_s: float | None = None
    """Time-out of each HTTP attempt in seconds; ``None`` (the default) means the model's own
    (``OpenAIChatModel(timeout_s=...)``, else 120 s). A value set here wins over the model's;
    a run deadline (:class:`~scenemosaic.models.DeadlineModel`) can only shorten it."""
    seed: int | None = None
    """Sampling seed where the server honours one."""


@dataclass
class Usage:
    """Token and request counts of one call or an aggregate of calls.

    ``requests`` counts HTTP requests the server answered: every attempt that got a response
    counts, whatever its status (a 429 that was retried, a reply cut at ``max_tokens`` and
    sent again, a reply that failed validation). Attempts that got no response at all
    (connection refused, time-out) are not counted. Token counts are what the server
    reported, summed over those attempts. ``cached`` counts calls answered from the on-disk
    reply cache (:class:`~scenemosaic.models.CachedModel`): nothing was sent for them.
    """

    requests: int = 0
    input_tokens: int = 0
    output_tokens: int = 0
    image_tokens: int = 0
    images: int = 0
    cached: int = 0

    def __add__(self, other: Usage) -> Usage:
        return Usage(
            requests=self.requests + other.requests,
            input_tokens=self.input_tokens + other.input_tokens,
            output_tokens=self.output_tokens + other.output_tokens,
            image_tokens=self.image_tokens + other.image_tokens,
            images=self.images + other.images,
            cached=self.cached + other.cached,
        )

    @property
    def total_tokens(self) -> int:
        return self.input_tokens + self.output_tokens + self.image_tokens


@dataclass(frozen=True)
class RequestContext:
    """What the asking agent tells a model besides the messages.

    Models use ``agent`` for usage accounting, rate-limit keys and cassette names; test
    models (:class:`~scenemosaic.models.FunctionModel`) may read the structured ``evidence``.
    """

    agent: str
    """Name of the asking agent (e.g. ``"support"``)."""
    node: str | None = None
    """Task-graph node running the request, when there is one."""
    evidence: BaseModel | None = None
    """The structured evidence the messages were rendered from."""


class Model(abc.ABC):
    """A model that turns messages into a validated pydantic output.

    Subclasses implement :meth:`request`. ``vision`` says whether image parts may be
    sent; agents send a text rendering of the same facts when it is false.
    """

    name: str = "model"
    vision: bool = True
    uses_rule_solvers: bool = False
    """True for the offline ``rules`` model: agents answer with their own solvers and send
    no request. Wrappers report their wrapped model's value."""

    @abc.abstractmethod
    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Send ``messages`` and return the reply validated as ``output_type`` plus its usage."""

    @property
    def default_timeout_s(self) -> float | None:
        """The per-attempt time-out this model uses when ``ModelSettings.timeout_s`` is ``None``.

        ``None`` when the model has no time-out of its own (it does no I/O, or lets the
        caller bound it). Wrappers report their wrapped model's value.
        """
        return None

    async def generate_image(self, prompt: str, *, size: str = "1024x1024", model: str | None = None) -> tuple[bytes, Usage]:
        """Draw ``prompt`` as a PNG through an images endpoint (``/images/generations``); ``model``
        names the image model when it is not this model. Models without one raise
        :class:`~scenemosaic.exceptions.ModelConfigError`; wrappers forward the call."""
        from scenemosaic.exceptions import ModelConfigError

        raise ModelConfigError(
            f"{self.name} cannot draw an image: a text prompt needs an OpenAI-compatible images endpoint "
            "(--model openai:<model>@<base_url>, and --image-model when the image model has another name)"
        )

    async def aclose(self) -> None:  # noqa: B027 - optional hook, most models hold nothing
        """Release connections; a no-op unless the model holds any."""

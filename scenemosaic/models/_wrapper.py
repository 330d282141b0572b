"""``WrapperModel``: the base of models that add behaviour around another model."""

from __future__ import annotations

from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage

__all__ = ["WrapperModel"]


class WrapperModel(Model):
    """Delegates to ``wrapped``; subclasses override :meth:`request` to add behaviour.

    ``name`` and ``vision`` are the wrapped model's, so agents and cassettes see through
    wrappers; :meth:`aclose` closes the wrapped model.
    """

    def __init__(self, wrapped: Model) -> None:
        self.wrapped = wrapped
        self._name_override: str | None = None
        self._vision_override: bool | None = None

    @property
    def name(self) -> str:
        """The wrapped model's name (unless set on the wrapper)."""
        return self._name_override if self._name_override is not None else self.wrapped.name

    @name.setter
    def name(self, value: str) -> None:
        self._name_override = value

    @property
    def vision(self) -> bool:
        """Whether the wrapped model takes images (unless set on the wrapper)."""
        return self._vision_override if self._vision_override is not None else self.wrapped.vision

    @vision.setter
    def vision(self, value: bool) -> None:
        self._vision_override = value

    @property
    def uses_rule_solvers(self) -> bool:  # type: ignore[override]
        """Whether the wrapped model is the offline rules model."""
        return self.wrapped.uses_rule_solvers

    @property
    def default_timeout_s(self) -> float | None:
        """The wrapped model's own time-out."""
        return self.wrapped.default_timeout_s

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.wrapped!r})"

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Forward to the wrapped model."""
        return await self.wrapped.request(messages, output_type, settings, context=context)

    async def generate_image(self, prompt: str, *, size: str = "1024x1024", model: str | None = None) -> tuple[bytes, Usage]:
        """Forward to the wrapped model."""
        return await self.wrapped.generate_image(prompt, size=size, model=model)

    async def aclose(self) -> None:
        """Close the wrapped model."""
        await self.wrapped.aclose()

"""A cheap estimate of how many tokens a prompt costs, without a tokenizer.

One estimate serves two purposes: the rate limiter books it before a request leaves,
and :class:`~scenemosaic.models.OpenAIChatModel` refuses a prompt that clearly cannot fit
its ``context_tokens``. It is an estimate, not a count: real tokenizers give about 4
characters per token for English prose and 2 to 3 for JSON full of numbers, and an image
costs what the server's vision encoder makes of it.
"""

from __future__ import annotations

import math

from scenemosaic.models._base import ImagePart, Message, ModelSettings, TextPart

__all__ = ["CHARS_PER_TOKEN", "IMAGE_TOKENS", "estimate_tokens"]

CHARS_PER_TOKEN = 3.5
"""Characters per token assumed for text: between prose (about 4) and numeric JSON (2 to 3)."""
IMAGE_TOKENS = 765
"""Tokens assumed per image: a 1024 px image at high detail on OpenAI's tiling."""


def estimate_tokens(messages: list[Message], settings: ModelSettings | None = None) -> int:
    """Estimated tokens of ``messages``: text characters / 3.5 plus 765 per image.

    With ``settings`` the output cap (``max_tokens``) is added too: providers count the
    requested cap against a tokens-per-minute budget when the request arrives. Only the
    parts in ``messages`` count; drop image parts first for a model that does not send them.
    """
    chars = 0
    images = 0
    for message in messages:
        for part in message.parts:
            if isinstance(part, TextPart):
                chars += len(part.text)
            elif isinstance(part, ImagePart):
                images += 1
    out_cap = settings.max_tokens if settings is not None and settings.max_tokens else 0
    return math.ceil(chars / CHARS_PER_TOKEN) + images * IMAGE_TOKENS + out_cap

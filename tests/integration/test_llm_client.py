"""The OpenAI-compatible client against a real server (opt-in).

Runs only when ``SCENEMOSAIC_LLM_URL`` points at a Chat Completions server, e.g. a local
llama.cpp server (``llama-server --port 8089``) on 127.0.0.1::

    SCENEMOSAIC_LLM_URL=http://127.0.0.1:8089/v1 pytest -m integration tests/integration/test_llm_client.py

``SCENEMOSAIC_LLM_MODEL`` names the model (the llama.cpp server ignores it) and
``SCENEMOSAIC_LLM_VISION=1`` says the server takes images (then the rejection test
checks the opposite: that an image request is answered).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from pydantic import BaseModel, Field

from scenemosaic.exceptions import ModelConfigError
from scenemosaic.models import (
    ImagePart,
    InstrumentedModel,
    Message,
    ModelCall,
    ModelSettings,
    OpenAIChatModel,
    ReplayModel,
    RequestContext,
    TextPart,
)

pytestmark = pytest.mark.integration

URL = os.environ.get("SCENEMOSAIC_LLM_URL", "")
MODEL = os.environ.get("SCENEMOSAIC_LLM_MODEL", "qwen2.5-coder-0.5b-instruct")
SERVER_HAS_VISION = os.environ.get("SCENEMOSAIC_LLM_VISION", "0") == "1"

if not URL:
    pytest.skip(
        "integration suite not run: set SCENEMOSAIC_LLM_URL to an OpenAI-compatible server",
        allow_module_level=True,
    )

# A 1x1 PNG.
PNG = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360000002000100e221bc330000000049454e44ae426082"
)


class CriticVerdict(BaseModel):
    """A critic-like output, small enough for a 0.5 B model to fill in a few seconds."""

    should_modify: bool
    notes: list[str] = Field(max_length=3)
    quality_score: int = Field(ge=0, le=100)


SYSTEM = (
    "You review furniture layouts. Reply with one JSON object with the keys should_modify (boolean), "
    "notes (at most 3 short strings naming object ids in parentheses) and quality_score (0-100)."
)
USER = (
    "Layout: a desk (desk_0) against the north wall; a chair (chair_1) 3 m away from the desk, "
    "facing the wall. Should anything be changed?"
)
SETTINGS = ModelSettings(temperature=0.0, max_tokens=160, seed=1, timeout_s=120.0)


def _messages(*, image: bool = False) -> list[Message]:
    parts: list[TextPart | ImagePart] = [TextPart(USER)]
    if image:
        parts.append(ImagePart(PNG, label="top-down view"))
    return [Message.text("system", SYSTEM), Message(role="user", parts=tuple(parts))]


async def test_structured_round_trip(record_property: pytest.RecordProperty) -> None:
    calls: list[ModelCall] = []
    inner = OpenAIChatModel(MODEL, base_url=URL, vision=False, structured="json_schema")
    model = InstrumentedModel(inner, calls.append)
    try:
        for _ in range(2):
            output, usage = await model.request(
                _messages(), CriticVerdict, SETTINGS, context=RequestContext(agent="critic")
            )
            assert isinstance(output, CriticVerdict)
            assert 0 <= output.quality_score <= 100
            assert len(output.notes) <= 3
            assert usage.requests >= 1 and usage.input_tokens > 0 and usage.output_tokens > 0
    finally:
        await model.aclose()
    assert [c.ok for c in calls] == [True, True]
    record_property("latency_s", [round(c.latency_s, 3) for c in calls])
    record_property("output_tokens", [c.usage.output_tokens for c in calls])


async def test_record_then_replay_offline(tmp_path: Path) -> None:
    cassette = tmp_path / "llm.json"
    inner = OpenAIChatModel(MODEL, base_url=URL, vision=False)
    recorder = ReplayModel(inner, cassette, "record")
    try:
        recorded, _ = await recorder.request(
            _messages(), CriticVerdict, SETTINGS, context=RequestContext(agent="critic")
        )
    finally:
        await recorder.aclose()
    replayed, _ = await ReplayModel(None, cassette, "replay").request(
        _messages(), CriticVerdict, SETTINGS, context=RequestContext(agent="critic")
    )
    assert replayed == recorded


async def test_image_path_matches_the_server() -> None:
    """A text-only server's image rejection becomes a ModelConfigError naming ``vision``;
    a vision server (``SCENEMOSAIC_LLM_VISION=1``) answers the same request."""
    model = OpenAIChatModel(MODEL, base_url=URL, vision=True)
    ctx = RequestContext(agent="critic")
    try:
        if SERVER_HAS_VISION:
            output, usage = await model.request(_messages(image=True), CriticVerdict, SETTINGS, context=ctx)
            assert isinstance(output, CriticVerdict) and usage.images == 1
            return
        with pytest.raises(ModelConfigError, match="vision"):
            await model.request(_messages(image=True), CriticVerdict, SETTINGS, context=ctx)
        # The same request with vision off (the image dropped) is answered.
        model.vision = False
        output, usage = await model.request(_messages(image=True), CriticVerdict, SETTINGS, context=ctx)
        assert isinstance(output, CriticVerdict) and usage.images == 0
    finally:
        await model.aclose()

"""Text to image through the images endpoint: the OpenAI wire format, retries, bad replies, replay."""

from __future__ import annotations

import base64
import io
from pathlib import Path

import httpx
import pytest
from llm_fakes import FakeServer
from PIL import Image

from scenemosaic.exceptions import ModelConfigError, ModelError, ReplayMissError
from scenemosaic.models import HTTPRetryPolicy, ReplayModel, RulesModel


def _png(colour: tuple[int, int, int] = (200, 120, 40)) -> bytes:
    buf = io.BytesIO()
    Image.new("RGB", (64, 48), colour).save(buf, format="PNG")
    return buf.getvalue()


def _image_reply(png: bytes, **extra: object) -> httpx.Response:
    return httpx.Response(200, json={"created": 1, "data": [{"b64_json": base64.b64encode(png).decode(), **extra}], "usage": {"input_tokens": 12, "output_tokens": 4160}})


async def test_generate_image_posts_the_openai_body_and_retries_a_429() -> None:
    png = _png()
    server = FakeServer(httpx.Response(429, headers={"Retry-After": "2"}, json={"error": {"message": "slow down"}}), _image_reply(png))
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3, jitter_s=0.0))
    got, usage = await model.generate_image("a cozy bedroom with a desk", model="gpt-image-1")
    assert got == png
    assert [r.url.path for r in server.requests] == ["/v1/images/generations"] * 2
    assert server.bodies[-1] == {
        "model": "gpt-image-1",
        "prompt": "a cozy bedroom with a desk",
        "n": 1,
        "size": "1024x1024",
        "response_format": "b64_json",
    }
    assert sleeps == [2.0]
    assert (usage.requests, usage.input_tokens, usage.output_tokens) == (2, 12, 4160)


@pytest.mark.parametrize(
    ("reply", "message"),
    [
        (httpx.Response(200, json={"data": [{"url": "https://example.invalid/x.png"}]}), "a URL instead of b64_json"),
        (httpx.Response(200, json={"data": [{"b64_json": base64.b64encode(b"not a png").decode()}]}), "is not an image"),
        (httpx.Response(200, json={"nothing": True}), "expected data\\[0\\].b64_json"),
    ],
)
async def test_generate_image_bad_replies(reply: httpx.Response, message: str) -> None:
    model, _ = FakeServer(reply).model()
    with pytest.raises(ModelError, match=message):
        await model.generate_image("a kitchen")


async def test_rules_model_cannot_draw() -> None:
    with pytest.raises(ModelConfigError, match="images endpoint"):
        await RulesModel().generate_image("a kitchen")


async def test_images_record_and_replay(tmp_path: Path) -> None:
    png = _png((10, 200, 30))
    server = FakeServer(_image_reply(png))
    real, _ = server.model()
    cassette = tmp_path / "images.json"
    recorder = ReplayModel(real, cassette, "record")
    assert (await recorder.generate_image("a study"))[0] == png
    recorder.cassette.save()
    player = ReplayModel(None, cassette)
    got, usage = await player.generate_image("a study")
    assert got == png and usage.requests == 1
    assert len(server.requests) == 1
    with pytest.raises(ReplayMissError, match="agent 'images'"):
        await player.generate_image("a different room")

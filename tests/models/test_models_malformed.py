"""Malformed 200 replies are ordinary invalid replies; oversized bodies are refused; usage counts every answered attempt."""

from __future__ import annotations

import json
from typing import Any

import httpx
import pytest
from llm_fakes import VALID, FakeServer, Verdict, chat_reply, user_messages
from pydantic import BaseModel

from scenemosaic.agents import AgentPolicy, SceneState, TaskAgent
from scenemosaic.exceptions import ModelError, ModelHTTPError, OutputValidationError
from scenemosaic.models import (
    InstrumentedModel,
    ModelCall,
    ModelSettings,
    RequestContext,
    Usage,
    UsageTracker,
)
from scenemosaic.scene import Scene

CTX = RequestContext(agent="critic")


def completion(choice: Any, usage: Any = None) -> httpx.Response:
    """A 200 reply with the given ``choices[0]`` (and ``usage``), however odd."""
    body: dict[str, Any] = {"id": "x", "object": "chat.completion", "choices": [choice]}
    if usage is not None:
        body["usage"] = usage
    return httpx.Response(200, json=body)


HTML = "<!DOCTYPE html><html><head><title>502 Bad Gateway</title></head><body>nginx</body></html>"


@pytest.mark.parametrize(
    ("reply", "complaint"),
    [
        (httpx.Response(200, text=HTML, headers={"content-type": "text/html"}), "not JSON"),
        (httpx.Response(200, text="upstream connect error or disconnect/reset"), "not JSON"),
        (httpx.Response(200, json=[1, 2, 3]), "not an object"),
        (completion({"index": 0, "message": "just a string", "finish_reason": "stop"}), "message"),
        (httpx.Response(200, json={"id": "x", "object": "chat.completion"}), "no choices"),
        (httpx.Response(200, json={"id": "x", "choices": []}), "no choices"),
        (httpx.Response(200, json={"id": "x", "choices": ["text"]}), "choices[0]"),
        (httpx.Response(200, json={"error": {"message": "model is loading"}}), "model is loading"),
        (completion({"index": 0, "message": {"role": "assistant", "content": None}, "finish_reason": "stop"}), "no content"),
        (completion({"index": 0, "message": {"role": "assistant"}, "finish_reason": "stop"}), "no content"),
        (
            completion({"message": {"role": "assistant", "content": None, "refusal": "I cannot"}, "finish_reason": "stop"}),
            "refused",
        ),
    ],
    ids=["html", "plain-text", "json-list", "message-string", "no-choices", "empty-choices", "choice-string", "error-in-200",
         "content-null", "content-missing", "refusal"],
)  # fmt: skip
async def test_malformed_200_replies_are_invalid_replies(reply: httpx.Response, complaint: str) -> None:
    server = FakeServer(reply)
    model, sleeps = server.model()
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    error = info.value
    assert complaint in " ".join(error.errors)
    assert len(error.raw_reply) <= 2100  # an excerpt, enough to show the model what came back
    assert isinstance(error.usage, Usage) and error.usage.requests == 1
    assert (len(server.requests), sleeps) == (1, [])  # not retried: the server did answer


async def test_content_as_a_list_of_text_parts_is_joined() -> None:
    parts = [
        {"type": "text", "text": json.dumps(VALID)[:20]},
        {"type": "text", "text": json.dumps(VALID)[20:]},
    ]
    server = FakeServer(
        completion({"message": {"role": "assistant", "content": parts}, "finish_reason": "stop"})
    )
    model, _ = server.model()
    out, _ = await model.request(user_messages(), Verdict, context=CTX)
    assert out == Verdict.model_validate(VALID)


async def test_content_as_a_list_without_text_is_an_invalid_reply() -> None:
    parts = [{"type": "image_url", "image_url": {"url": "data:,"}}]
    server = FakeServer(
        completion({"message": {"role": "assistant", "content": parts}, "finish_reason": "stop"})
    )
    model, _ = server.model()
    with pytest.raises(OutputValidationError, match="no content"):
        await model.request(user_messages(), Verdict, context=CTX)


@pytest.mark.parametrize(
    "usage",
    [
        {"prompt_tokens": "many", "completion_tokens": 7},
        {"prompt_tokens": None, "completion_tokens": 7},
        {"completion_tokens": 7},
        {"prompt_tokens": [1], "completion_tokens": 7},
        {"prompt_tokens": -5, "completion_tokens": 7},
        {"prompt_tokens": float("nan"), "completion_tokens": 7},
        "not an object",
    ],
)
async def test_odd_usage_counts_as_zero_and_never_crashes(usage: Any) -> None:
    message = {"role": "assistant", "content": json.dumps(VALID)}
    # NaN is not JSON; send the body as text so the reply holds it the way a sloppy server writes it.
    body = json.dumps({"choices": [{"message": message, "finish_reason": "stop"}], "usage": usage})
    server = FakeServer(httpx.Response(200, text=body))
    model, _ = server.model()
    out, got = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert got.requests == 1 and got.input_tokens == 0
    assert got.output_tokens == (7 if isinstance(usage, dict) else 0)


async def test_a_reply_over_the_size_cap_is_refused_with_a_short_excerpt() -> None:
    huge = json.dumps({**VALID, "notes": ["x" * 1000] * 5000})  # about 5 MB
    server = FakeServer(chat_reply(huge, prompt_tokens=50, completion_tokens=60_000))
    model, sleeps = server.model(max_reply_bytes=100_000)
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    error = info.value
    assert any("100000-byte limit" in e for e in error.errors)
    assert len(error.raw_reply) < 2_200 and "cut" in error.raw_reply
    assert isinstance(error.usage, Usage) and error.usage.requests == 1  # tokens unknown: never parsed
    assert sleeps == []


async def test_a_streamed_reply_over_the_cap_stops_being_read() -> None:
    produced: list[int] = []

    class Endless(httpx.AsyncByteStream):
        async def __aiter__(self):  # type: ignore[no-untyped-def]
            for _ in range(10_000):  # 640 MB if it were all read
                produced.append(1)
                yield b"{" * 65_536

    server = FakeServer(lambda request: httpx.Response(200, stream=Endless()))
    model, _ = server.model(max_reply_bytes=200_000)
    with pytest.raises(OutputValidationError, match="byte limit"):
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(produced) <= 5  # read up to the cap, then dropped


async def test_a_large_reply_is_validated_and_its_raw_reply_shortened() -> None:
    # Under the byte cap but far over the excerpt: the repair request must not carry it whole.
    big = "Here is my analysis: " + "blah " * 40_000
    server = FakeServer(chat_reply(big))
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(info.value.raw_reply) < 8_100 and info.value.raw_reply.endswith("characters cut]")


# -- usage: every attempt that got a response ------------------------------------------------


async def test_retried_and_truncated_attempts_all_count() -> None:
    server = FakeServer(
        httpx.Response(429, headers={"Retry-After": "1"}, json={"error": {"message": "slow down"}}),
        httpx.ReadError("reset"),  # no response: not counted
        chat_reply('{"should_modify": true', finish="length", prompt_tokens=100, completion_tokens=50),
        chat_reply(VALID, prompt_tokens=100, completion_tokens=80),
    )
    model, _ = server.model()
    _, usage = await model.request(user_messages(), Verdict, ModelSettings(max_tokens=50), context=CTX)
    assert (usage.requests, usage.input_tokens, usage.output_tokens) == (3, 200, 130)


async def test_an_invalid_reply_reports_the_tokens_the_server_counted() -> None:
    server = FakeServer(chat_reply('{"should_modify": "maybe"}', prompt_tokens=120, completion_tokens=9))
    calls: list[ModelCall] = []
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as info:
        await InstrumentedModel(model, calls.append).request(user_messages(), Verdict, context=CTX)
    assert info.value.usage == Usage(requests=1, input_tokens=120, output_tokens=9)
    (call,) = calls
    assert not call.ok and call.usage == Usage(requests=1, input_tokens=120, output_tokens=9)


async def test_a_failed_call_reports_every_answered_attempt() -> None:
    server = FakeServer(default=httpx.Response(503, json={"error": {"message": "busy"}}))
    model, _ = server.model()
    tracker = UsageTracker()
    with pytest.raises(ModelHTTPError):
        await InstrumentedModel(model, tracker).request(user_messages(), Verdict, context=CTX)
    assert tracker.total.requests == 4 == len(server.requests)
    assert tracker.calls[0].ok is False


class Answer(BaseModel):
    value: int


class Number(BaseModel):
    value: int


class EvenAgent(TaskAgent[SceneState, Number, Answer]):
    name = "even"
    prompt = "Answer with an even number.\n"

    def gather(self, state: SceneState) -> Number:
        return Number(value=2)

    def solve(self, evidence: Number) -> Answer:
        return Answer(value=evidence.value)

    def apply(self, output: Answer, state: SceneState) -> None:
        state.scene.metadata["even"] = output.value


async def test_an_agent_repairs_after_an_html_page_and_falls_back_after_repeated_ones() -> None:
    page = httpx.Response(200, text=HTML)
    server = FakeServer(page, chat_reply({"value": 4}))
    model, _ = server.model()
    state = SceneState(scene=Scene(), policy=AgentPolicy(max_attempts=2))
    result = await EvenAgent().run(state, model)
    assert result.output == Answer(value=4) and result.usage.requests == 2
    repair = json.loads(server.requests[1].content)["messages"][-1]["content"]
    assert "not JSON" in repair

    always_html = FakeServer(default=page)
    model, _ = always_html.model()
    state = SceneState(scene=Scene(), policy=AgentPolicy(max_attempts=2, solver_fallback=True))
    result = await EvenAgent().run(state, model)
    assert result.output == Answer(value=2) and result.fallback is not None and result.fallback.agent == "even"
    assert len(always_html.requests) == 2


async def test_a_transport_failure_is_a_model_error_with_usage() -> None:
    server = FakeServer(default=httpx.ReadError("connection reset by peer"))
    model, _ = server.model()
    with pytest.raises(ModelError, match="ReadError") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert getattr(info.value, "usage", None) == Usage()  # nothing answered, nothing counted

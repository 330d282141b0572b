"""Prompts over the context window: the servers' refusals, the client's own estimate, and agents falling back."""

from __future__ import annotations

import json

import httpx
import pytest
from llm_fakes import PNG_1PX, VALID, FakeServer, Verdict, chat_reply, user_messages
from pydantic import BaseModel

from scenemosaic.agents import AgentPolicy, SceneState, TaskAgent
from scenemosaic.exceptions import ModelContextLengthError, ModelHTTPError
from scenemosaic.models import ImagePart, Message, RequestContext, TextPart, estimate_tokens
from scenemosaic.scene import Scene

CTX = RequestContext(agent="critic")

LLAMA_CPP = {
    "error": {
        "code": 400,
        "message": "the request exceeds the available context size, try increasing it",
        "type": "exceed_context_size_error",
        "n_prompt_tokens": 4142,
        "n_ctx": 4096,
    }
}
OPENAI = {
    "error": {
        "message": "This model's maximum context length is 128000 tokens. However, your messages resulted in "
        "131072 tokens. Please reduce the length of the messages.",
        "type": "invalid_request_error",
        "param": "messages",
        "code": "context_length_exceeded",
    }
}
VLLM = {
    "object": "error",
    "message": "This model's maximum context length is 4096 tokens. However, you requested 6000 tokens "
    "(5000 in the messages, 1000 in the completion). Please reduce the length of the messages or completion.",
    "type": "BadRequestError",
    "code": 400,
}


@pytest.mark.parametrize(
    ("body", "prompt", "context"),
    [(LLAMA_CPP, 4142, 4096), (OPENAI, 131072, 128000), (VLLM, 5000, 4096)],
    ids=["llama.cpp", "openai", "vllm"],
)
async def test_a_context_refusal_names_the_sizes_and_is_not_retried(
    body: dict, prompt: int, context: int
) -> None:  # type: ignore[type-arg]
    server = FakeServer(httpx.Response(400, json=body))
    model, sleeps = server.model()
    with pytest.raises(ModelContextLengthError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    error = info.value
    assert isinstance(error, ModelHTTPError) and error.status_code == 400 and error.sent
    assert (error.prompt_tokens, error.context_tokens) == (prompt, context)
    assert (len(server.requests), sleeps) == (1, [])


async def test_a_context_refusal_with_a_5xx_status_is_not_retried_either() -> None:
    body = {"error": {"message": "the request exceeds the available context size, try increasing it"}}
    server = FakeServer(httpx.Response(500, json=body))
    model, sleeps = server.model()
    with pytest.raises(ModelContextLengthError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.prompt_tokens is None and info.value.context_tokens is None
    assert (len(server.requests), sleeps) == (1, [])


async def test_a_token_rate_limit_is_not_a_context_refusal() -> None:
    body = {
        "error": {
            "message": "Rate limit reached: too many tokens per min; the context is fine",
            "code": "rate_limit_exceeded",
        }
    }
    server = FakeServer(httpx.Response(429, json=body), chat_reply(VALID))
    model, _ = server.model()
    out, _ = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70 and len(server.requests) == 2


def test_estimate_tokens_is_text_over_3_5_plus_a_fixed_cost_per_image() -> None:
    messages = [
        Message.text("system", "x" * 700),
        Message(role="user", parts=(TextPart("y" * 350), ImagePart(PNG_1PX), ImagePart(PNG_1PX))),
    ]
    assert estimate_tokens(messages) == 200 + 100 + 2 * 765
    assert estimate_tokens([Message.text("user", "abc")]) == 1  # rounded up


async def test_a_prompt_that_clearly_cannot_fit_is_refused_before_sending() -> None:
    server = FakeServer()
    model, _ = server.model(context_tokens=1000)
    prompt = user_messages("z" * 35_000)  # about 10,000 tokens
    with pytest.raises(ModelContextLengthError) as info:
        await model.request(prompt, Verdict, context=CTX)
    error = info.value
    assert not error.sent and server.requests == []
    assert error.context_tokens == 1000 and error.prompt_tokens is not None and error.prompt_tokens > 10_000
    assert "nothing was sent" in str(error) and not str(error).startswith("HTTP")


async def test_a_prompt_near_the_window_is_still_sent() -> None:
    # The estimate is rough: 3,000 characters (about 860 tokens) may well fit 800 tokens.
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model(context_tokens=800)
    await model.request([Message.text("user", "w" * 3000)], Verdict, context=CTX)
    assert len(server.requests) == 1


async def test_images_a_text_only_model_drops_do_not_count() -> None:
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model(context_tokens=100, vision=False)
    await model.request(user_messages(image=True), Verdict, context=CTX)  # 765 image tokens, not sent
    assert len(server.requests) == 1
    vision, _ = FakeServer().model(context_tokens=100, vision=True)
    with pytest.raises(ModelContextLengthError):
        await vision.request(user_messages(image=True), Verdict, context=CTX)


class Answer(BaseModel):
    value: int


class Number(BaseModel):
    value: int


class EchoAgent(TaskAgent[SceneState, Number, Answer]):
    name = "echo"
    prompt = "Repeat the number.\n"

    def gather(self, state: SceneState) -> Number:
        return Number(value=5)

    def solve(self, evidence: Number) -> Answer:
        return Answer(value=evidence.value)

    def apply(self, output: Answer, state: SceneState) -> None:
        state.scene.metadata["echo"] = output.value


async def test_agents_fall_back_on_a_context_refusal() -> None:
    server = FakeServer(httpx.Response(400, json=LLAMA_CPP), httpx.Response(400, json=LLAMA_CPP))
    model, _ = server.model()
    state = SceneState(scene=Scene(), policy=AgentPolicy(solver_fallback=True))
    result = await EchoAgent().run(state, model)
    assert result.output == Answer(value=5)
    record = result.fallback
    assert record is not None and record.agent == "echo" and "ModelContextLengthError" in record.reason
    # once more with a compact prompt (never the same prompt twice), then the rule solver
    assert len(server.requests) == 2
    first, second = (json.dumps(b["messages"]) for b in server.bodies)
    assert len(second) < len(first)

"""OpenAIChatModel against scripted servers: wire format, retries, errors, truncation, usage."""

from __future__ import annotations

import base64
import json
import re
from datetime import UTC, datetime, timedelta
from email.utils import format_datetime

import httpx
import pytest
from llm_fakes import PNG_1PX, VALID, FakeServer, Verdict, chat_reply, user_messages

from scenemosaic.exceptions import (
    ModelConfigError,
    ModelContextLengthError,
    ModelEndpointError,
    ModelError,
    ModelHTTPError,
    OutputValidationError,
)
from scenemosaic.models import HTTPRetryPolicy, ModelSettings, OpenAIChatModel, RequestContext

CTX = RequestContext(agent="critic", node="critic/unit_0")


async def test_wire_format_schema_image_and_auth() -> None:
    server = FakeServer(chat_reply(VALID, prompt_tokens=120, completion_tokens=30))
    model, sleeps = server.model()
    settings = ModelSettings(temperature=0.2, max_tokens=300, seed=7, timeout_s=12.5)
    output, usage = await model.request(user_messages(image=True), Verdict, settings, context=CTX)

    assert output == Verdict.model_validate(VALID)
    assert sleeps == []
    (request,) = server.requests
    assert request.method == "POST"
    assert str(request.url) == "http://llm.test/v1/chat/completions"
    assert request.headers["authorization"] == "Bearer sk-test"
    assert request.extensions["timeout"]["read"] == 12.5
    body = server.bodies[0]
    assert body["model"] == "test-model"
    assert (body["temperature"], body["max_tokens"], body["seed"]) == (0.2, 300, 7)
    fmt = body["response_format"]
    assert fmt["type"] == "json_schema"
    assert fmt["json_schema"]["name"] == "Verdict"
    assert fmt["json_schema"]["strict"] is True
    schema = fmt["json_schema"]["schema"]
    assert schema["additionalProperties"] is False
    assert sorted(schema["required"]) == ["notes", "score", "should_modify"]
    assert schema["properties"]["notes"]["maxItems"] > 0
    assert "maxLength" not in schema["properties"]["notes"]["items"]  # not in OpenAI's strict subset

    system, user = body["messages"]
    assert system == {"role": "system", "content": "You are a layout critic. Reply in JSON."}
    kinds = [p["type"] for p in user["content"]]
    assert kinds == ["text", "text", "image_url"]
    assert user["content"][1]["text"] == "[image: top-down view]"
    url = user["content"][2]["image_url"]["url"]
    assert url.startswith("data:image/png;base64,")
    assert base64.b64decode(url.split(",", 1)[1]) == PNG_1PX

    assert (usage.requests, usage.input_tokens, usage.output_tokens, usage.images) == (1, 120, 30, 1)


async def test_api_key_from_named_env_var(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MY_LLM_KEY", "sk-from-env")
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model(api_key=None, api_key_env="MY_LLM_KEY")
    await model.request(user_messages(), Verdict, context=CTX)
    assert server.requests[0].headers["authorization"] == "Bearer sk-from-env"


async def test_no_key_sends_no_auth_header_and_openai_needs_one(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model(api_key=None)
    await model.request(user_messages(), Verdict, context=CTX)
    assert "authorization" not in server.requests[0].headers
    with pytest.raises(ModelConfigError, match="OPENAI_API_KEY"):
        OpenAIChatModel("gpt-4o-mini")


async def test_vision_off_drops_images_and_sends_plain_text() -> None:
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model(vision=False)
    _, usage = await model.request(user_messages(image=True), Verdict, context=CTX)
    user = server.bodies[0]["messages"][1]
    assert user == {"role": "user", "content": "Evidence: three chairs."}
    assert "image_url" not in server.requests[0].content.decode()
    assert usage.images == 0


async def test_json_object_and_none_modes_parse_fenced_replies() -> None:
    fenced = "Here you go:\n```json\n" + json.dumps(VALID) + "\n```\nAnything else?"
    server = FakeServer(chat_reply(fenced), chat_reply(fenced))
    obj_model, _ = server.model(structured="json_object")
    out, _ = await obj_model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert server.bodies[0]["response_format"] == {"type": "json_object"}
    none_model, _ = server.model(structured="none")
    out, _ = await none_model.request(user_messages(), Verdict, context=CTX)
    assert out.notes == ["move (chair_1) left"]
    assert "response_format" not in server.bodies[1]
    # without a strict response_format the server never sees the schema: the system message states it
    for body in server.bodies:
        system = body["messages"][0]["content"]
        assert body["messages"][0]["role"] == "system" and "must match this JSON schema" in system
        assert '"should_modify"' in system


async def test_a_strict_schema_request_does_not_repeat_the_schema_in_the_prompt() -> None:
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model()
    await model.request(user_messages(), Verdict, context=CTX)
    body = server.bodies[0]
    assert body["response_format"]["type"] == "json_schema"
    assert "must match this JSON schema" not in json.dumps(body["messages"])


async def test_429_honours_retry_after_seconds() -> None:
    server = FakeServer(
        httpx.Response(429, headers={"Retry-After": "7"}, json={"error": {"message": "rate limited"}}),
        chat_reply(VALID),
    )
    model, sleeps = server.model()
    out, usage = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert sleeps == [7.0]
    assert len(server.requests) == 2
    assert usage.requests == 2  # every attempt the server answered counts, the 429 included


async def test_429_honours_retry_after_http_date() -> None:
    when = datetime.now(UTC) + timedelta(seconds=30)
    server = FakeServer(
        httpx.Response(429, headers={"Retry-After": format_datetime(when, usegmt=True)}, text="slow down"),
        chat_reply(VALID),
    )
    model, sleeps = server.model()
    await model.request(user_messages(), Verdict, context=CTX)
    assert len(sleeps) == 1
    assert 27.0 <= sleeps[0] <= 30.0


async def test_500_then_success_backs_off_with_jitter() -> None:
    server = FakeServer(httpx.Response(500, json={"error": {"message": "overloaded"}}), chat_reply(VALID))
    model, sleeps = server.model()
    out, _ = await model.request(user_messages(), Verdict, context=CTX)
    assert out.should_modify is True
    assert len(sleeps) == 1
    assert 1.0 <= sleeps[0] <= 1.5  # initial backoff + jitter in [0, 0.5]


async def test_5xx_exhausts_bounded_attempts_with_growing_backoff() -> None:
    server = FakeServer(*[httpx.Response(503, json={"error": {"message": "busy"}}) for _ in range(3)])
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3, initial_backoff_s=2.0, jitter_s=0.0))
    with pytest.raises(ModelHTTPError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == 503
    assert "busy" in info.value.body
    assert len(server.requests) == 3
    assert sleeps == [2.0, 4.0]


async def test_a_read_timeout_is_retried_once_with_twice_the_time() -> None:
    server = FakeServer(httpx.ReadTimeout("too slow"), chat_reply(VALID))
    model, sleeps = server.model(timeout_s=3.0)
    out, _ = await model.request(user_messages(), Verdict, ModelSettings(timeout_s=None), context=CTX)
    assert out.score == 70
    assert len(sleeps) == 1
    assert [r.extensions["timeout"]["read"] for r in server.requests] == [3.0, 6.0]


async def test_timeouts_every_time_raise_model_error() -> None:
    server = FakeServer(*[httpx.ReadTimeout("too slow") for _ in range(2)])
    model, _ = server.model(retry=HTTPRetryPolicy(max_attempts=2, jitter_s=0.0))
    with pytest.raises(ModelError, match="timed out") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert not isinstance(info.value, ModelHTTPError)
    assert isinstance(info.value.__cause__, httpx.ReadTimeout)


async def test_a_refused_connection_is_a_setup_error_at_once() -> None:
    server = FakeServer(httpx.ConnectError("[Errno 111] Connection refused"), chat_reply(VALID))
    model, sleeps = server.model()
    with pytest.raises(ModelEndpointError, match=r"^no model server at http://llm.test/v1: start it or fix --model, or use --model rules$") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code is None and info.value.url == "http://llm.test/v1"
    assert (len(server.requests), sleeps) == (1, [])  # not retried: nothing listens there


@pytest.mark.parametrize(
    ("status", "message", "fix"),
    [
        (401, "invalid api key", "refused the key (HTTP 401"),
        (403, "forbidden", "refused the key (HTTP 403"),
        (404, "model 'test-model' not found", "model 'test-model' not found on the model server"),
        (404, "no route", "nothing at http://llm.test/v1/chat/completions not found"),
    ],
)
async def test_a_refused_key_or_missing_model_is_a_setup_error(status: int, message: str, fix: str) -> None:
    server = FakeServer(httpx.Response(status, json={"error": {"message": message}}), chat_reply(VALID))
    model, sleeps = server.model()
    with pytest.raises(ModelEndpointError, match=re.escape(fix)) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == status and "--model rules" in str(info.value) and "\n" not in str(info.value)
    assert (len(server.requests), sleeps) == (1, [])


async def test_dropped_keep_alive_is_resent_once_without_waiting() -> None:
    server = FakeServer(
        httpx.RemoteProtocolError("Server disconnected without sending a response."), chat_reply(VALID)
    )
    model, sleeps = server.model()
    out, _ = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert sleeps == []
    assert len(server.requests) == 2


async def test_a_connection_dropped_on_every_attempt_is_an_error_after_the_policy() -> None:
    server = FakeServer(*[httpx.RemoteProtocolError("Server disconnected") for _ in range(3)])
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3, initial_backoff_s=1.0, jitter_s=0.0))
    with pytest.raises(ModelError, match="RemoteProtocolError") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 3
    # The first drop is re-sent at once (a stale pooled connection); a repeated drop backs off.
    assert sleeps == [2.0]
    assert not isinstance(info.value, ModelHTTPError)


async def test_non_200_with_error_body_is_not_retried() -> None:
    body = {"error": {"message": "messages must not be empty", "type": "invalid_request_error", "code": 400}}
    server = FakeServer(httpx.Response(400, json=body))
    model, sleeps = server.model()
    with pytest.raises(ModelHTTPError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == 400
    assert json.loads(info.value.body) == body
    assert "messages must not be empty" in str(info.value)
    assert (len(server.requests), sleeps) == (1, [])


async def test_200_with_error_object_is_an_invalid_reply_or_a_context_refusal() -> None:
    server = FakeServer(
        httpx.Response(200, json={"error": {"message": "model is loading"}}),
        httpx.Response(200, json={"error": {"message": "context length exceeded"}}),
    )
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as invalid:
        await model.request(user_messages(), Verdict, context=CTX)
    assert invalid.value.errors == ["the server answered with an error: model is loading"]
    with pytest.raises(ModelContextLengthError, match="context length exceeded") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == 200


async def test_image_rejection_names_the_vision_setting() -> None:
    # The exact reply of llama.cpp's server without a multimodal projector.
    body = {
        "error": {
            "code": 500,
            "message": "image input is not supported - hint: if this is unexpected, you may need to provide the mmproj",
            "type": "server_error",
        }
    }
    server = FakeServer(httpx.Response(500, json=body))
    model, sleeps = server.model()
    with pytest.raises(ModelConfigError, match="vision") as info:
        await model.request(user_messages(image=True), Verdict, context=CTX)
    assert "image input is not supported" in str(info.value)
    assert (len(server.requests), sleeps) == (1, [])


async def test_rejected_response_format_names_the_structured_setting() -> None:
    msg = "Input should be 'text' or 'json_object' at ('body', 'response_format', 'type')"
    server = FakeServer(httpx.Response(500, json={"error": {"message": msg}}))
    model, _ = server.model()
    with pytest.raises(ModelConfigError, match="structured"):
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 1


async def test_truncated_reply_is_retried_once_with_doubled_max_tokens() -> None:
    server = FakeServer(
        chat_reply('{"should_modify": true, "notes": ["a', finish="length", completion_tokens=50),
        chat_reply(VALID, completion_tokens=40),
    )
    model, _ = server.model()
    out, usage = await model.request(user_messages(), Verdict, ModelSettings(max_tokens=50), context=CTX)
    assert out.score == 70
    assert [b["max_tokens"] for b in server.bodies] == [50, 100]
    assert (usage.requests, usage.output_tokens) == (2, 90)


async def test_truncated_even_when_doubled_is_never_accepted() -> None:
    cut = '{"should_modify": true, "notes": ["a'
    # A length-capped reply that happens to be valid JSON is still never accepted.
    cut_but_valid = json.dumps(VALID)
    server = FakeServer(chat_reply(cut, finish="length"), chat_reply(cut_but_valid, finish="length"))
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, ModelSettings(max_tokens=8), context=CTX)
    assert info.value.raw_reply == cut_but_valid
    assert any("cut off" in e for e in info.value.errors)
    assert [b["max_tokens"] for b in server.bodies] == [8, 16]


async def test_a_cap_sized_to_the_answer_is_not_doubled() -> None:
    """``retry_truncated=False`` (an agent's own reply cap): a cut reply goes straight back as an
    invalid reply the agent repairs ("answer more briefly"), without a second, longer request."""
    server = FakeServer(chat_reply('{"should_modify": true, "notes": ["a', finish="length"))
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, ModelSettings(max_tokens=50, retry_truncated=False), context=CTX)
    assert any("cut off" in e for e in info.value.errors)
    assert [b["max_tokens"] for b in server.bodies] == [50]


async def test_owned_client_is_closed_and_injected_client_is_not() -> None:
    server = FakeServer(chat_reply(VALID), chat_reply(VALID))
    model, _ = server.model()
    await model.request(user_messages(), Verdict)
    await model.aclose()
    await model.request(user_messages(), Verdict)  # a fresh client after close
    await model.aclose()
    assert len(server.requests) == 2

    other = FakeServer(chat_reply(VALID))
    async with httpx.AsyncClient(transport=httpx.MockTransport(other.handler)) as client:
        injected = OpenAIChatModel("m", base_url="http://llm.test/v1", client=client)
        await injected.request(user_messages(), Verdict)
        await injected.aclose()
        assert not client.is_closed


async def test_503_honours_retry_after_and_caps_it() -> None:
    server = FakeServer(
        httpx.Response(503, headers={"Retry-After": "3"}, json={"error": {"message": "loading model"}}),
        httpx.Response(503, headers={"Retry-After": "86400"}, json={"error": {"message": "loading model"}}),
        chat_reply(VALID),
    )
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3, max_retry_after_s=20.0, jitter_s=0.5))
    out, _ = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert sleeps == [3.0, 20.0]  # the server's hint, exactly (no jitter), capped at max_retry_after_s


async def test_429_every_time_ends_with_the_status_and_body() -> None:
    body = {"error": {"message": "rate limit reached for requests", "type": "requests"}}
    server = FakeServer(*[httpx.Response(429, headers={"Retry-After": "1"}, json=body) for _ in range(3)])
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3))
    with pytest.raises(ModelHTTPError, match="rate limit reached") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == 429 and json.loads(info.value.body) == body
    assert (len(server.requests), sleeps) == (3, [1.0, 1.0])


@pytest.mark.parametrize("status", [201, 202, 301, 413, 422])
async def test_any_non_200_with_error_message_is_an_error(status: int) -> None:
    """Whatever the status code (even a 2xx other than 200), an error body is raised, not parsed."""
    body = {"error": {"message": f"nope {status}"}}
    server = FakeServer(httpx.Response(status, json=body), chat_reply(VALID))
    model, sleeps = server.model()
    with pytest.raises(ModelHTTPError, match=f"nope {status}") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == status
    assert (len(server.requests), sleeps) == (1, [])  # client errors are not retried


async def test_truncated_reply_without_a_token_cap_is_refused_not_accepted() -> None:
    """With no max_tokens there is nothing to double: the cut reply is an invalid reply at once
    (the asking agent sends it back for repair; see tests/agents/test_agent_repair.py)."""
    server = FakeServer(chat_reply(VALID, finish="length"), chat_reply(VALID))
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, ModelSettings(max_tokens=None), context=CTX)
    assert len(server.requests) == 1 and "max_tokens" not in server.bodies[0]
    assert any("cut off" in e for e in info.value.errors)

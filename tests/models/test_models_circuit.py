"""CircuitBreakerModel: open after consecutive failures, refuse without the network, one trial after the pause."""

from __future__ import annotations

import asyncio

import httpx
import pytest
from llm_fakes import VALID, FakeClock, FakeServer, Verdict, chat_reply, user_messages
from structlog.testing import capture_logs

from scenemosaic.exceptions import (
    ModelConfigError,
    ModelEndpointError,
    ModelError,
    ModelHTTPError,
    ModelUnavailableError,
    OutputValidationError,
)
from scenemosaic.models import CircuitBreakerModel, FunctionModel, HTTPRetryPolicy, RequestContext

CTX = RequestContext(agent="critic")
BUSY = httpx.Response(503, json={"error": {"message": "server overloaded"}})


async def test_an_endpoint_answering_503_is_no_longer_asked_after_the_threshold() -> None:
    clock = FakeClock()
    server = FakeServer(default=BUSY)
    inner, _ = server.model(retry=HTTPRetryPolicy(max_attempts=2, jitter_s=0.0))
    model = CircuitBreakerModel(inner, failure_threshold=3, reset_after_s=60.0, clock=clock)
    with capture_logs() as logs:
        for _ in range(3):
            with pytest.raises(ModelHTTPError):
                await model.request(user_messages(), Verdict, context=CTX)
        assert model.state == "open" and len(server.requests) == 6  # 3 requests x 2 attempts
        for _ in range(5):
            with pytest.raises(ModelUnavailableError) as info:
                await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 6  # nothing more reached the server
    error = info.value
    assert isinstance(error, ModelError) and not isinstance(error, ModelHTTPError)
    assert "openai:test-model at http://llm.test/v1" in str(error) and "server overloaded" in str(error)
    assert error.model == "openai:test-model at http://llm.test/v1" and "503" in error.last_error
    assert error.retry_in_s == 60.0
    opened = [e for e in logs if e["log_level"] == "warning" and "circuit opened" in e["event"]]
    assert len(opened) == 1 and opened[0]["model"] == "openai:test-model at http://llm.test/v1"


async def test_after_the_pause_one_trial_goes_through_and_success_closes_the_circuit() -> None:
    clock = FakeClock()
    server = FakeServer(BUSY, BUSY, chat_reply(VALID), chat_reply(VALID))
    inner, _ = server.model(retry=HTTPRetryPolicy(max_attempts=1))
    model = CircuitBreakerModel(inner, failure_threshold=2, reset_after_s=30.0, clock=clock)
    for _ in range(2):
        with pytest.raises(ModelHTTPError):
            await model.request(user_messages(), Verdict, context=CTX)
    clock.advance(29.0)
    with pytest.raises(ModelUnavailableError, match="in 1 s"):
        await model.request(user_messages(), Verdict, context=CTX)
    clock.advance(1.0)
    out, _ = await model.request(user_messages(), Verdict, context=CTX)  # the trial
    assert out.score == 70 and model.state == "closed" and model.consecutive_failures == 0
    await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 4


async def test_a_failed_trial_reopens_for_another_pause() -> None:
    clock = FakeClock()
    server = FakeServer(default=BUSY)
    inner, _ = server.model(retry=HTTPRetryPolicy(max_attempts=1))
    model = CircuitBreakerModel(inner, failure_threshold=1, reset_after_s=10.0, clock=clock)
    with pytest.raises(ModelHTTPError):
        await model.request(user_messages(), Verdict, context=CTX)
    clock.advance(10.0)
    with pytest.raises(ModelHTTPError):  # the trial reaches the server and fails
        await model.request(user_messages(), Verdict, context=CTX)
    assert model.state == "open" and model.retry_in_s == 10.0
    with pytest.raises(ModelUnavailableError):
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 2


async def test_while_the_trial_is_out_other_requests_are_refused() -> None:
    clock = FakeClock()
    release = asyncio.Event()
    calls = 0

    async def answer(messages: object, context: object) -> dict[str, object]:
        nonlocal calls
        calls += 1
        if calls == 1:
            raise ModelError("connection refused")
        await release.wait()
        return VALID

    model = CircuitBreakerModel(FunctionModel(answer), failure_threshold=1, reset_after_s=5.0, clock=clock)
    with pytest.raises(ModelError):
        await model.request(user_messages(), Verdict, context=CTX)
    clock.advance(5.0)
    trial = asyncio.create_task(model.request(user_messages(), Verdict, context=CTX))
    await asyncio.sleep(0)
    assert model.state == "half_open"
    with pytest.raises(ModelUnavailableError, match="trial request is under way"):
        await model.request(user_messages(), Verdict, context=CTX)
    release.set()
    await trial
    assert model.state == "closed" and calls == 2


async def test_invalid_replies_and_client_errors_do_not_count_as_failures() -> None:
    server = FakeServer(
        BUSY,
        chat_reply("not json at all"),  # the model answered badly: the endpoint works
        BUSY,
        httpx.Response(404, json={"error": {"message": "no such model"}}),
        BUSY,
    )
    inner, _ = server.model(retry=HTTPRetryPolicy(max_attempts=1))
    model = CircuitBreakerModel(inner, failure_threshold=2)
    # a 404 is a set-up error (ModelEndpointError): the run stops, the breaker does not count it
    for expected in (ModelHTTPError, OutputValidationError, ModelHTTPError, ModelEndpointError, ModelHTTPError):
        with pytest.raises(expected):
            await model.request(user_messages(), Verdict, context=CTX)
    assert model.state == "closed" and model.consecutive_failures == 1


async def test_timeouts_and_transport_errors_count() -> None:
    server = FakeServer(default=httpx.ReadTimeout("slow"))
    inner, _ = server.model(retry=HTTPRetryPolicy(max_attempts=1))
    model = CircuitBreakerModel(inner, failure_threshold=2)
    for _ in range(2):
        with pytest.raises(ModelError, match="timed out"):
            await model.request(user_messages(), Verdict, context=CTX)
    with pytest.raises(ModelUnavailableError, match="ReadTimeout"):
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 2


async def test_set_up_errors_and_cancellations_do_not_count() -> None:
    def misconfigured(messages: object, context: object) -> str:
        raise ModelConfigError("bad setting")

    model = CircuitBreakerModel(FunctionModel(misconfigured), failure_threshold=1)
    with pytest.raises(ModelConfigError):
        await model.request(user_messages(), Verdict, context=CTX)
    assert model.state == "closed" and model.consecutive_failures == 0


def test_a_nonsense_threshold_is_a_config_error() -> None:
    with pytest.raises(ModelConfigError):
        CircuitBreakerModel(FunctionModel(lambda m, c: "{}"), failure_threshold=0)

"""DeadlineModel: time-outs clamped to the time left, immediate refusal after it, cancellation at it, agents falling back."""

from __future__ import annotations

import asyncio
import time

import httpx
import pytest
from llm_fakes import VALID, FakeClock, FakeServer, Verdict, chat_reply, user_messages
from pydantic import BaseModel

from scenemosaic.agents import AgentPolicy, SceneState, TaskAgent, run_agent
from scenemosaic.exceptions import ModelConfigError, ModelDeadlineExceeded, ModelError
from scenemosaic.models import (
    DeadlineModel,
    FunctionModel,
    HTTPRetryPolicy,
    InstrumentedModel,
    ModelCall,
    ModelSettings,
    RequestContext,
)
from scenemosaic.scene import Scene

CTX = RequestContext(agent="critic")


async def test_time_outs_are_clamped_to_the_time_left() -> None:
    clock = FakeClock()
    server = FakeServer(chat_reply(VALID), chat_reply(VALID), chat_reply(VALID))
    inner, _ = server.model(timeout_s=30.0)
    model = DeadlineModel(inner, 100.0, clock=clock)
    await model.request(user_messages(), Verdict, context=CTX)  # 100 s left: the model's own 30 s
    clock.advance(80.0)
    await model.request(user_messages(), Verdict, context=CTX)  # 20 s left
    await model.request(user_messages(), Verdict, ModelSettings(timeout_s=5.0), context=CTX)  # the call's 5 s
    assert [r.extensions["timeout"]["read"] for r in server.requests] == [30.0, 20.0, 5.0]
    assert model.remaining_s == 20.0 and model.default_timeout_s == 30.0


async def test_after_the_deadline_requests_fail_at_once_without_the_network() -> None:
    clock = FakeClock()
    server = FakeServer()
    inner, _ = server.model()
    model = DeadlineModel(inner, 60.0, clock=clock)
    clock.advance(60.0)
    for _ in range(3):
        with pytest.raises(ModelDeadlineExceeded, match="60 s deadline") as info:
            await model.request(user_messages(), Verdict, context=CTX)
    assert isinstance(info.value, ModelError)
    assert server.requests == []


async def test_a_request_running_at_the_deadline_is_cancelled() -> None:
    cancelled = asyncio.Event()

    async def hang(request: httpx.Request) -> httpx.Response:
        try:
            await asyncio.sleep(3600)
        except asyncio.CancelledError:
            cancelled.set()
            raise
        raise AssertionError("unreachable")

    server = FakeServer(default=hang)
    # A per-attempt time-out far beyond the deadline: only the deadline can stop the request.
    inner, _ = server.model(timeout_s=3600.0, retry=HTTPRetryPolicy(max_attempts=1))
    calls: list[ModelCall] = []
    model = DeadlineModel(InstrumentedModel(inner, calls.append), 0.1)
    started = time.perf_counter()
    with pytest.raises(ModelDeadlineExceeded):
        await model.request(user_messages(), Verdict, context=CTX)
    assert time.perf_counter() - started < 2.0
    assert cancelled.is_set() and len(server.requests) == 1
    assert [c.error_type for c in calls] == ["CancelledError"]


async def test_a_failure_of_its_own_inside_the_deadline_passes_through() -> None:
    def broken(messages: object, context: object) -> str:
        raise ModelConfigError("no function for this agent")

    model = DeadlineModel(FunctionModel(broken), 60.0)
    with pytest.raises(ModelConfigError):
        await model.request(user_messages(), Verdict, context=CTX)


def test_a_negative_deadline_is_a_config_error() -> None:
    with pytest.raises(ModelConfigError):
        DeadlineModel(FunctionModel(lambda m, c: "{}"), -1.0)


class Answer(BaseModel):
    value: int


class Number(BaseModel):
    value: int


class TripleAgent(TaskAgent[SceneState, Number, Answer]):
    """Evidence 3; the rule solver answers 9."""

    name = "triple"
    prompt = "Triple the number.\n"

    def gather(self, state: SceneState) -> Number:
        return Number(value=3)

    def solve(self, evidence: Number) -> Answer:
        return Answer(value=evidence.value * 3)

    def apply(self, output: Answer, state: SceneState) -> None:
        state.scene.metadata["triple"] = output.value


async def test_an_agent_past_the_deadline_falls_back_to_its_rule_solver() -> None:
    clock = FakeClock()
    asked: list[str] = []

    def answer(messages: object, context: RequestContext) -> dict[str, int]:
        asked.append(context.agent)
        return {"value": 9}

    model = DeadlineModel(FunctionModel(answer, vision=False), 30.0, clock=clock)
    state = SceneState(scene=Scene(), policy=AgentPolicy(solver_fallback=True))
    result = await TripleAgent().run(state, model)  # in time: the model answers
    assert result.output == Answer(value=9) and asked == ["triple"] and result.fallback is None

    clock.advance(31.0)
    state = SceneState(scene=Scene(), policy=AgentPolicy(solver_fallback=True))
    result = await run_agent(TripleAgent(), state, model)  # the runner applies the solver's answer
    assert result.output == Answer(value=9) and state.scene.metadata["triple"] == 9
    assert asked == ["triple"] and result.usage.requests == 0  # not asked again
    record = result.fallback
    assert record is not None
    assert record.agent == "triple" and record.reason.startswith("ModelDeadlineExceeded")


async def test_without_fallback_the_deadline_fails_the_agent() -> None:
    clock = FakeClock()
    model = DeadlineModel(FunctionModel(lambda m, c: {"value": 9}), 1.0, clock=clock)
    clock.advance(2.0)
    with pytest.raises(ModelDeadlineExceeded):
        await TripleAgent().run(SceneState(scene=Scene()), model)

"""RulesModel, FunctionModel and InstrumentedModel: the offline models and the call hook."""

from __future__ import annotations

import asyncio
from typing import Any

import httpx
import pytest
from llm_fakes import VALID, FakeServer, Verdict, chat_reply, user_messages

from scenemosaic.exceptions import ModelConfigError, ModelHTTPError, OutputValidationError
from scenemosaic.models import (
    FunctionModel,
    InstrumentedModel,
    Message,
    ModelCall,
    RequestContext,
    RulesModel,
)


async def test_rules_model_is_a_marker_that_never_answers() -> None:
    """Agents answer with their own solvers when the model uses rule solvers; asked directly, it refuses."""
    model = RulesModel()
    assert model.uses_rule_solvers and InstrumentedModel(model, lambda call: None).uses_rule_solvers
    assert (model.name, model.vision) == ("rules", False)
    with pytest.raises(ModelConfigError, match="'support'"):
        await model.request([], Verdict, context=RequestContext(agent="support"))
    with pytest.raises(ModelConfigError):
        await model.request([], Verdict)


async def test_function_model_per_agent_sync_and_async() -> None:
    async def critic(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        await asyncio.sleep(0)
        return {**VALID, "score": len(messages)}

    def actor(messages: list[Message], context: RequestContext | None) -> Verdict:
        return Verdict(should_modify=False, notes=[], score=1)

    model = FunctionModel({"critic": critic, "actor": actor})
    out, _ = await model.request(user_messages(), Verdict, context=RequestContext(agent="critic"))
    assert out.score == 2
    out, _ = await model.request(user_messages(), Verdict, context=RequestContext(agent="actor"))
    assert out.notes == []
    with pytest.raises(ModelConfigError, match=r"'judge'.*actor, critic"):
        await model.request(user_messages(), Verdict, context=RequestContext(agent="judge"))


async def test_function_model_single_function_gets_context() -> None:
    agents: list[str | None] = []

    def any_agent(messages: list[Message], context: RequestContext | None) -> str:
        agents.append(context.agent if context else None)
        return '{"should_modify": false, "notes": [], "score": 0}'

    model = FunctionModel(any_agent)
    for agent in ("a", "b"):
        await model.request(user_messages(), Verdict, context=RequestContext(agent=agent))
    assert agents == ["a", "b"]


async def test_instrumented_model_reports_each_call() -> None:
    calls: list[ModelCall] = []
    ticks = iter([10.0, 10.25, 20.0, 20.5])
    server = FakeServer(chat_reply(VALID, prompt_tokens=9, completion_tokens=4), chat_reply("nope"))
    inner, _ = server.model()
    model = InstrumentedModel(inner, calls.append, clock=lambda: next(ticks))
    assert (model.name, model.vision) == ("openai:test-model", True)

    await model.request(user_messages(), Verdict, context=RequestContext(agent="critic", node="critic/u1"))
    with pytest.raises(OutputValidationError):
        await model.request(user_messages(), Verdict, context=RequestContext(agent="actor", node="actor/u1"))

    ok, failed = calls
    assert (ok.agent, ok.node, ok.model, ok.ok, ok.error) == (
        "critic",
        "critic/u1",
        "openai:test-model",
        True,
        None,
    )
    assert ok.latency_s == pytest.approx(0.25)
    assert (ok.usage.input_tokens, ok.usage.output_tokens) == (9, 4)
    assert (failed.agent, failed.ok, failed.error_type) == ("actor", False, "OutputValidationError")
    assert failed.latency_s == pytest.approx(0.5)
    assert failed.error is not None and "actor" in failed.error


async def test_instrumented_callback_failure_does_not_break_the_call() -> None:
    def broken(call: ModelCall) -> None:
        raise RuntimeError("observer bug")

    server = FakeServer(chat_reply(VALID))
    inner, _ = server.model()
    out, _ = await InstrumentedModel(inner, broken).request(user_messages(), Verdict)
    assert out.score == 70


async def test_instrumented_reports_http_errors() -> None:
    calls: list[ModelCall] = []
    server = FakeServer(httpx.Response(400, json={"error": {"message": "bad request"}}))
    inner, _ = server.model()
    with pytest.raises(ModelHTTPError):
        await InstrumentedModel(inner, calls.append).request(user_messages(), Verdict)
    assert calls[0].error_type == "ModelHTTPError" and calls[0].agent is None

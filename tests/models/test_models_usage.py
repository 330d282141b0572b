"""Usage accounting through the models layer's InstrumentedModel, and usage limits stopping a run."""

from __future__ import annotations

import asyncio

import pytest
from pydantic import BaseModel

from scenemosaic.dag import ModelRequest, Node, NodeContext, Runner
from scenemosaic.dag._graph import NodeFn
from scenemosaic.exceptions import UsageLimitExceeded
from scenemosaic.models import InstrumentedModel, ModelCall, ModelPrice, UsageLimits, UsageTracker
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage


class Reply(BaseModel):
    text: str


class TokenModel(Model):
    """Answers every request at once; token counts depend on the agent, to tell totals apart."""

    name = "fake-vlm"

    def __init__(self) -> None:
        self.requests = 0

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        self.requests += 1
        await asyncio.sleep(0)
        agent = context.agent if context else "?"
        size = 100 if agent == "support" else 10
        usage = Usage(requests=1, input_tokens=size, output_tokens=size // 10, image_tokens=5, images=1)
        return output_type.model_validate({"text": agent}), usage


def asking(model: Model, agent: str, times: int = 1) -> NodeFn:
    async def fn(ctx: NodeContext) -> str:
        reply = ""
        for _ in range(times):
            out, _usage = await model.request(
                [Message.text("user", "hi")], Reply, context=RequestContext(agent=agent, node=ctx.name)
            )
            reply = out.text
        return reply

    return fn


async def test_usage_totals_per_call_agent_model_and_run() -> None:
    tracker = UsageTracker(prices={"fake-vlm": ModelPrice(input_per_1k=1.0, output_per_1k=2.0)})
    model = InstrumentedModel(TokenModel(), tracker)
    nodes = [
        Node("support", asking(model, "support", times=2)),
        Node("walls", asking(model, "walls")),
        Node("walls_again", asking(model, "walls"), ("walls",)),
    ]
    runner = Runner(nodes, usage=tracker)
    assert await runner.run() == {"support": "support", "walls": "walls", "walls_again": "walls"}

    assert len(tracker.calls) == 4
    assert tracker.by_agent["support"] == Usage(
        requests=2, input_tokens=200, output_tokens=20, image_tokens=10, images=2
    )
    assert tracker.by_agent["walls"] == Usage(
        requests=2, input_tokens=20, output_tokens=2, image_tokens=10, images=2
    )
    assert tracker.total == tracker.by_agent["support"] + tracker.by_agent["walls"]
    assert tracker.by_model == {"fake-vlm": tracker.total}
    # (input + image) tokens at 1.0 / 1k, output tokens at 2.0 / 1k
    assert tracker.cost == pytest.approx((220 + 20) / 1000 * 1.0 + 22 / 1000 * 2.0)

    events = [e for e in runner.history if isinstance(e, ModelRequest)]
    assert sorted((e.agent, e.node) for e in events) == [
        ("support", "support"),
        ("support", "support"),
        ("walls", "walls"),
        ("walls", "walls_again"),
    ]
    assert all(e.ok and e.latency_s >= 0 and e.cost is not None for e in events)


async def test_request_limit_stops_the_run_cleanly() -> None:
    tracker = UsageTracker(limits=UsageLimits(max_requests=3))
    inner = TokenModel()
    model = InstrumentedModel(inner, tracker)
    chain = [Node(f"step{i}", asking(model, "walls"), (f"step{i - 1}",) if i else ()) for i in range(8)]
    runner = Runner(chain, usage=tracker)
    with pytest.raises(UsageLimitExceeded, match="request limit 3 exceeded") as info:
        await runner.run()
    assert inner.requests == 4  # the call that crossed the limit counts; no call after it
    assert {"step0", "step1", "step2"} <= set(info.value.partial) <= {"step0", "step1", "step2", "step3"}
    assert tracker.exceeded is not None
    assert asyncio.all_tasks() == {asyncio.current_task()}


async def test_token_limit_stops_concurrent_nodes() -> None:
    tracker = UsageTracker(limits=UsageLimits(max_total_tokens=300))
    model = InstrumentedModel(TokenModel(), tracker)
    never_done = asyncio.Event()

    async def waits(ctx: NodeContext) -> None:
        await never_done.wait()

    nodes = [Node("support", asking(model, "support", times=5)), Node("idle", waits)]
    with pytest.raises(UsageLimitExceeded, match="token limit 300 exceeded"):
        await Runner(nodes, usage=tracker).run()
    assert tracker.total.total_tokens > 300
    assert tracker.total.requests == 3  # 115 tokens per call: the third crosses 300


def test_cost_limit_and_unbound_tracker_raises() -> None:
    tracker = UsageTracker(limits=UsageLimits(max_cost=0.5), prices={"m": ModelPrice(1.0, 1.0)})
    tracker.on_call(ModelCall(agent="a", node=None, model="m", usage=Usage(requests=1, input_tokens=400)))
    with pytest.raises(UsageLimitExceeded, match="cost limit"):
        tracker(ModelCall(agent="a", node=None, model="m", usage=Usage(requests=1, input_tokens=200)))
    # a failed call still counts as a request
    failed = UsageTracker()
    failed.on_call(ModelCall(agent=None, node="n", model="m", ok=False, error="ModelHTTPError: 500"))
    assert failed.total.requests == 1 and failed.by_agent == {"?": Usage(requests=1)}


def test_before_call_refuses_once_the_request_budget_is_spent() -> None:
    tracker = UsageTracker(limits=UsageLimits(max_requests=1))
    tracker.before_call("walls")
    tracker.on_call(ModelCall(agent="walls", node="walls", model="m", usage=Usage(requests=1)))
    with pytest.raises(UsageLimitExceeded, match="refusing a call by agent 'support' in node 'n1'"):
        tracker.before_call("support", "n1")

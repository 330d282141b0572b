"""Scheduler behaviour: concurrency, data flow, retries, timeouts, cancellation, dynamic nodes."""

from __future__ import annotations

import asyncio
import math
import threading
from collections.abc import Awaitable, Callable
from typing import Any

import pytest

from scenemosaic.dag import (
    Node,
    NodeAdded,
    NodeContext,
    NodeFailed,
    NodeFinished,
    NodePolicy,
    NodeRetried,
    NodeStarted,
    RetryPolicy,
    RunEvent,
    RunFinished,
    Runner,
    TaskGraph,
    TimeoutPolicy,
    current_context,
    derive_seed,
    run_graph,
)
from scenemosaic.exceptions import GraphDefinitionError, NodeFailedError, NodeTimeoutError, RunCancelledError

HANDSHAKE_S = 5.0
"""Generous bound on waiting for another node; only reached when the scheduler is wrong."""

NodeFnT = Callable[[NodeContext], Awaitable[Any]]


def const(value: Any) -> NodeFnT:
    async def fn(ctx: NodeContext) -> Any:
        return value

    return fn


async def forever(ctx: NodeContext) -> None:
    await asyncio.Event().wait()


def only_this_task_left() -> bool:
    return asyncio.all_tasks() == {asyncio.current_task()}


async def test_independent_nodes_run_at_the_same_time() -> None:
    names = ["room", "walls", "attributes"]
    started = {n: asyncio.Event() for n in names}

    def make(name: str) -> NodeFnT:
        async def fn(ctx: NodeContext) -> str:
            started[name].set()
            # Every node waits until all three have started: only possible with real overlap.
            for event in started.values():
                await asyncio.wait_for(event.wait(), HANDSHAKE_S)
            return name

        return fn

    out = await run_graph([Node(n, make(n)) for n in names])
    assert out == {n: n for n in names}


async def test_a_node_starts_as_soon_as_its_own_dependencies_finish() -> None:
    dependent_started = asyncio.Event()

    async def slow(ctx: NodeContext) -> str:
        # Finishes only after "dependent" started: a level-by-level scheduler would deadlock here.
        await asyncio.wait_for(dependent_started.wait(), HANDSHAKE_S)
        return "slow"

    async def dependent(ctx: NodeContext) -> str:
        dependent_started.set()
        return "dependent"

    out = await run_graph(
        [Node("fast", const(1)), Node("slow", slow), Node("dependent", dependent, ("fast",))]
    )
    assert out == {"fast": 1, "slow": "slow", "dependent": "dependent"}


async def test_dependency_outputs_flow_by_name() -> None:
    seen: dict[str, list[str]] = {}

    def add(*deps: str) -> NodeFnT:
        async def fn(ctx: NodeContext) -> int:
            seen[ctx.name] = sorted(ctx.inputs)
            return 1 + sum(int(ctx[d]) for d in deps)

        return fn

    graph = TaskGraph(
        [
            Node("a", add()),
            Node("b", add("a"), ("a",)),
            Node("c", add("a"), ("a",)),
            Node("d", add("b", "c"), ("b", "c")),
        ]
    )
    out = await run_graph(graph)
    assert out == {"a": 1, "b": 2, "c": 2, "d": 5}
    assert seen == {"a": [], "b": ["a"], "c": ["a"], "d": ["b", "c"]}
    assert len(graph) == 4  # the caller's graph is not touched by the run


async def test_retry_with_backoff_then_success() -> None:
    calls: list[int] = []

    async def flaky(ctx: NodeContext) -> str:
        calls.append(ctx.attempt)
        if ctx.attempt < 3:
            raise ValueError(f"boom {ctx.attempt}")
        return "ok"

    policy = NodePolicy(retry=RetryPolicy(attempts=3, initial_backoff_s=0.01, multiplier=2.0, jitter=0.0))
    runner = Runner([Node("flaky", flaky, policy=policy)])
    assert await runner.run() == {"flaky": "ok"}
    assert calls == [1, 2, 3]
    retried = [e for e in runner.history if isinstance(e, NodeRetried)]
    assert [(e.attempt, e.delay_s) for e in retried] == [(1, 0.01), (2, 0.02)]
    assert "ValueError: boom 1" in retried[0].error
    assert [e.attempt for e in runner.history if isinstance(e, NodeStarted)] == [1, 2, 3]


async def test_retry_honours_retry_on_and_max_backoff() -> None:
    calls = 0

    async def wrong_kind(ctx: NodeContext) -> None:
        nonlocal calls
        calls += 1
        raise KeyError("not retryable")

    policy = NodePolicy(retry=RetryPolicy(attempts=5, initial_backoff_s=0.001, retry_on=(ValueError,)))
    with pytest.raises(NodeFailedError) as info:
        await run_graph([Node("n", wrong_kind, policy=policy)])
    assert calls == 1
    assert isinstance(info.value.cause, KeyError)

    capped = RetryPolicy(attempts=10, initial_backoff_s=1.0, max_backoff_s=3.0, multiplier=10.0, jitter=0.0)
    import random

    assert [capped.delay_s(k, random.Random(0)) for k in (1, 2, 3)] == [1.0, 3.0, 3.0]


async def test_jitter_is_seeded_and_bounded() -> None:
    async def always_fails(ctx: NodeContext) -> None:
        raise ValueError("x")

    policy = NodePolicy(retry=RetryPolicy(attempts=4, initial_backoff_s=0.002, multiplier=1.0, jitter=0.5))

    async def delays(seed: int) -> list[float]:
        runner = Runner([Node("n", always_fails, policy=policy)], seed=seed)
        with pytest.raises(NodeFailedError):
            await runner.run()
        return [e.delay_s for e in runner.history if isinstance(e, NodeRetried)]

    first, again, other = await delays(1), await delays(1), await delays(2)
    assert first == again and first != other
    assert all(0.001 <= d <= 0.003 for d in first) and len(set(first)) == 3


async def test_graph_defaults_apply_unless_a_node_overrides_them() -> None:
    calls = {"plain": 0, "strict": 0}

    def failing(name: str) -> NodeFnT:
        async def fn(ctx: NodeContext) -> None:
            calls[name] += 1
            raise ValueError(name)

        return fn

    defaults = NodePolicy(retry=RetryPolicy(attempts=3, initial_backoff_s=0.0, jitter=0.0))
    strict = NodePolicy(retry=RetryPolicy(attempts=1))
    for name, policy in (("plain", NodePolicy()), ("strict", strict)):
        with pytest.raises(NodeFailedError):
            await run_graph([Node(name, failing(name), policy=policy)], defaults=defaults)
    assert calls == {"plain": 3, "strict": 1}


async def test_failure_keeps_finished_outputs_and_stops_the_rest() -> None:
    blocker_cancelled = asyncio.Event()

    async def blocker(ctx: NodeContext) -> None:
        try:
            await asyncio.Event().wait()
        finally:
            blocker_cancelled.set()

    async def broken(ctx: NodeContext) -> None:
        raise RuntimeError("kaput")

    runner = Runner(
        [
            Node("done", const("d")),
            Node("blocker", blocker),
            Node("broken", broken, ("done",)),
            Node("never", const(0), ("broken",)),
        ]
    )
    with pytest.raises(NodeFailedError, match="node 'broken' failed: RuntimeError: kaput") as info:
        await runner.run()
    assert info.value.node == "broken"
    assert info.value.partial == {"done": "d"}
    assert blocker_cancelled.is_set()
    assert only_this_task_left()
    failed = [e for e in runner.history if isinstance(e, NodeFailed)]
    assert [(e.node, e.attempts) for e in failed] == [("broken", 1)]
    assert isinstance(runner.history[-1], RunFinished) and not runner.history[-1].ok


async def test_timeout_raises_node_timeout_error() -> None:
    policy = NodePolicy(timeout=TimeoutPolicy(0.05))
    with pytest.raises(NodeTimeoutError) as info:
        await run_graph([Node("ok", const(1)), Node("stuck", forever, ("ok",), policy=policy)])
    assert info.value.node == "stuck" and info.value.timeout_s == 0.05
    assert info.value.partial == {"ok": 1}
    assert only_this_task_left()


async def test_timeout_is_subject_to_the_retry_policy() -> None:
    async def slow_first(ctx: NodeContext) -> int:
        if ctx.attempt == 1:
            await asyncio.Event().wait()
        return ctx.attempt

    policy = NodePolicy(
        timeout=TimeoutPolicy(0.05), retry=RetryPolicy(attempts=2, initial_backoff_s=0.0, jitter=0.0)
    )
    runner = Runner([Node("n", slow_first, policy=policy)])
    assert await runner.run() == {"n": 2}
    retried = [e for e in runner.history if isinstance(e, NodeRetried)]
    assert len(retried) == 1 and retried[0].error.startswith("NodeTimeoutError")

    no_timeouts = NodePolicy(
        timeout=TimeoutPolicy(0.05), retry=RetryPolicy(attempts=3, retry_on=(ValueError,))
    )
    with pytest.raises(NodeTimeoutError):
        await run_graph([Node("n", forever, policy=no_timeouts)])


async def test_a_timeout_error_raised_by_the_node_itself_is_not_a_node_timeout() -> None:
    async def raises_timeout(ctx: NodeContext) -> None:
        raise TimeoutError("socket")

    with pytest.raises(NodeFailedError) as info:
        await run_graph([Node("n", raises_timeout, policy=NodePolicy(timeout=TimeoutPolicy(10.0)))])
    assert type(info.value.cause) is TimeoutError


def cancellable_graph(started: asyncio.Event, cancelled: list[str]) -> list[Node]:
    def blocked(name: str) -> NodeFnT:
        async def fn(ctx: NodeContext) -> None:
            started.set()
            try:
                await asyncio.Event().wait()
            except asyncio.CancelledError:
                cancelled.append(name)
                raise

        return fn

    nodes = [Node("quick", const("q")), Node("after_quick", const("aq"), ("quick",))]
    nodes += [Node(f"blocked{i}", blocked(f"blocked{i}"), ("after_quick",)) for i in range(5)]
    nodes.append(Node("tail", const("t"), tuple(f"blocked{i}" for i in range(5))))
    return nodes


@pytest.mark.parametrize("how", ["task", "runner", "event"])
async def test_cancellation_mid_run_keeps_partial_results_and_leaves_no_task(how: str) -> None:
    started, cancelled = asyncio.Event(), list[str]()
    cancel_event = asyncio.Event()
    runner = Runner(cancellable_graph(started, cancelled), cancel_event=cancel_event, max_concurrency=10)
    task = asyncio.create_task(runner.run())
    await asyncio.wait_for(started.wait(), HANDSHAKE_S)
    if how == "task":
        task.cancel()
    elif how == "runner":
        runner.cancel()
    else:
        cancel_event.set()
    with pytest.raises(RunCancelledError) as info:
        await asyncio.wait_for(task, HANDSHAKE_S)
    assert info.value.partial == {"quick": "q", "after_quick": "aq"}
    assert sorted(cancelled) == [f"blocked{i}" for i in range(5)]
    assert only_this_task_left()
    assert isinstance(runner.history[-1], RunFinished)
    assert runner.history[-1].error is not None and "RunCancelledError" in runner.history[-1].error


async def test_cancel_before_start() -> None:
    runner = Runner([Node("a", const(1))])
    runner.cancel()
    with pytest.raises(RunCancelledError) as info:
        await runner.run()
    assert info.value.partial == {}


async def test_a_node_leaking_cancelled_error_fails_the_run_instead_of_hanging() -> None:
    async def leaks(ctx: NodeContext) -> None:
        raise asyncio.CancelledError

    with pytest.raises(NodeFailedError, match="leaks"):
        await asyncio.wait_for(run_graph([Node("leaks", leaks), Node("other", forever)]), HANDSHAKE_S)


async def test_nodes_added_at_run_time_are_scheduled() -> None:
    async def unit(ctx: NodeContext) -> str:
        return f"{ctx.name}<-{sorted(ctx.inputs)}"

    async def manager(ctx: NodeContext) -> list[str]:
        ctx.add_nodes(
            [
                Node("unit_a", unit, depends_on=("manager",)),
                Node("unit_b", unit, depends_on=("unit_a", "room")),
            ]
        )
        current_context().add_node(Node("compose", unit, depends_on=("unit_b",)))
        return ["unit_a", "unit_b", "compose"]

    runner = Runner([Node("room", const("r")), Node("manager", manager, ("room",))])
    out = await runner.run()
    assert out["unit_a"] == "unit_a<-['manager']"
    assert out["unit_b"] == "unit_b<-['room', 'unit_a']"
    assert out["compose"] == "compose<-['unit_b']"
    added = [(e.node, e.added_by) for e in runner.history if isinstance(e, NodeAdded)]
    assert added == [("unit_a", "manager"), ("unit_b", "manager"), ("compose", "manager")]
    assert "compose" in runner.graph


@pytest.mark.parametrize(
    ("batch", "message"),
    [
        ([("x", ("nowhere",))], r"'nowhere' \(needed by 'x'\)"),
        ([("x", ("y",)), ("y", ("x",))], "cycle"),
        ([("first", ())], "duplicate node name 'first'"),
    ],
)
async def test_invalid_run_time_nodes_fail_the_run(
    batch: list[tuple[str, tuple[str, ...]]], message: str
) -> None:
    async def adder(ctx: NodeContext) -> None:
        ctx.add_nodes(Node(name, const(0), depends_on=deps) for name, deps in batch)

    with pytest.raises(NodeFailedError) as info:
        await run_graph([Node("first", const(1)), Node("adder", adder, ("first",))])
    assert isinstance(info.value.cause, GraphDefinitionError)
    assert info.value.partial == {"first": 1}
    with pytest.raises(GraphDefinitionError, match=message):
        raise info.value.cause


async def test_max_concurrency_is_a_bound_and_is_used() -> None:
    active = peak = 0

    async def work(ctx: NodeContext) -> None:
        nonlocal active, peak
        active += 1
        peak = max(peak, active)
        for _ in range(5):
            await asyncio.sleep(0)
        active -= 1

    await run_graph([Node(f"n{i}", work) for i in range(12)], max_concurrency=3)
    assert peak == 3
    peak = 0
    await run_graph([Node(f"n{i}", work) for i in range(12)])
    assert peak == 12


async def test_events_stream_while_running() -> None:
    runner = Runner([Node("a", const(1)), Node("b", const(2), ("a",))])
    task = asyncio.create_task(runner.run())
    seen: list[RunEvent] = [event async for event in runner.events()]
    assert await task == {"a": 1, "b": 2}
    kinds = [(type(e).__name__, getattr(e, "node", None)) for e in seen]
    assert kinds == [
        ("NodeStarted", "a"),
        ("NodeFinished", "a"),
        ("NodeStarted", "b"),
        ("NodeFinished", "b"),
        ("RunFinished", None),
    ]
    finished = [e for e in seen if isinstance(e, NodeFinished)]
    assert all(e.duration_s >= 0 and not e.cached for e in finished)
    late = [event async for event in runner.events()]  # a late reader replays the whole run
    assert late == seen
    run_finished = seen[-1]
    assert isinstance(run_finished, RunFinished) and run_finished.ok and run_finished.executed == 2


async def test_seeds_are_derived_per_node() -> None:
    async def seed(ctx: NodeContext) -> tuple[int, int]:
        return ctx.run_seed, ctx.node_seed

    out = await run_graph([Node("a", seed), Node("b", seed)], seed=7)
    assert out["a"] == (7, derive_seed(7, "a")) and out["b"] == (7, derive_seed(7, "b"))
    assert out["a"][1] != out["b"][1]
    assert (await run_graph([Node("a", seed)], seed=8))["a"][1] != out["a"][1]


async def test_run_in_thread_and_process() -> None:
    async def in_thread(ctx: NodeContext) -> bool:
        return await ctx.run_in_thread(lambda: threading.current_thread() is not threading.main_thread())

    async def in_process(ctx: NodeContext) -> int:
        return await ctx.run_in_process(math.factorial, 20)

    out = await run_graph([Node("t", in_thread), Node("p", in_process)])
    assert out == {"t": True, "p": math.factorial(20)}


async def test_a_runner_runs_once() -> None:
    runner = Runner([Node("a", const(1))])
    await runner.run()
    with pytest.raises(Exception, match="runs once"):
        await runner.run()

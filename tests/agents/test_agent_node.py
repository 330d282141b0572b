"""The TaskAgent adapter: agents as nodes, run_agents, resume restoring state, run-time scheduling."""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import ClassVar

import pytest
from pydantic import BaseModel

from scenemosaic.agents import (
    AgentLog,
    AgentPolicy,
    SceneState,
    TaskAgent,
    add_agent_nodes,
    agent_dependencies,
    agent_node,
    run_agent,
    run_agents,
)
from scenemosaic.dag import FileRunStore, Node, NodeContext, NodePolicy, RetryPolicy, RunEvent, Runner
from scenemosaic.exceptions import AgentOutputError, NodeFailedError, RunCancelledError
from scenemosaic.models import Message, Model, ModelSettings, RequestContext, Usage
from scenemosaic.models._base import OutputT
from scenemosaic.scene import Scene


class CountEvidence(BaseModel):
    count: int


class CountOutput(BaseModel):
    value: int


class SolverModel(Model):
    """A fake model answering with the asking agent's own solver, counting requests per agent."""

    name = "fake-solver"
    vision = False

    def __init__(self, *, bad_for: str | None = None) -> None:
        self.requests: dict[str, int] = {}
        self.bad_for = bad_for

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        assert context is not None and isinstance(context.evidence, CountEvidence)
        self.requests[context.agent] = self.requests.get(context.agent, 0) + 1
        answer = SOLVERS[context.agent](context.evidence)
        if context.agent == self.bad_for:
            answer = output_type.model_validate({"value": -1})
        return output_type.model_validate(answer.model_dump()), Usage(requests=1, input_tokens=3)


class _CountingAgent(TaskAgent[SceneState, CountEvidence, CountOutput]):
    prompt: ClassVar[str] = "unused"

    def messages(self, evidence: CountEvidence, state: SceneState, *, vision: bool) -> list[Message]:
        return [Message.text("user", evidence.model_dump_json())]

    def check(self, output: CountOutput, state: SceneState) -> list[str]:
        return [] if output.value >= 0 else [f"value {output.value} is negative"]

    def apply(self, output: CountOutput, state: SceneState) -> None:
        state.scene.metadata[self.name] = output.value


class RoomAgent(_CountingAgent):
    name: ClassVar[str] = "room"

    def gather(self, state: SceneState) -> CountEvidence:
        return CountEvidence(count=int(state.scene.metadata["objects"]))

    def solve(self, evidence: CountEvidence) -> CountOutput:
        return CountOutput(value=evidence.count)


class DoubleAgent(_CountingAgent):
    name: ClassVar[str] = "double"
    depends_on: ClassVar[tuple[str, ...]] = ("room",)

    def gather(self, state: SceneState) -> CountEvidence:
        return CountEvidence(count=state.scene.metadata["room"])

    def solve(self, evidence: CountEvidence) -> CountOutput:
        return CountOutput(value=2 * evidence.count)


SOLVERS = {"room": RoomAgent().solve, "double": DoubleAgent().solve}
"""What the fake model answers with (test code may call agent code; models in the package never do)."""


def make_state(objects: int = 3) -> SceneState:
    return SceneState(
        scene=Scene(id="t", metadata={"objects": objects}), seed=5, policy=AgentPolicy(max_attempts=1, solver_fallback=False)
    )


def written(state: SceneState) -> dict[str, object]:
    """What the agents wrote into the scene's metadata."""
    return {k: v for k, v in state.scene.metadata.items() if k != "objects"}


def test_agent_node_carries_name_dependencies_and_policy() -> None:
    policy = NodePolicy(retry=RetryPolicy(attempts=2))
    node = agent_node(DoubleAgent(), make_state(), SolverModel(), policy=policy)
    assert (node.name, node.depends_on, node.policy) == ("double", ("room",), policy)
    assert node.definition_key.endswith(":DoubleAgent") and node.restore is not None


async def test_run_agents_runs_in_dependency_order_and_applies_outputs() -> None:
    state, model = make_state(3), SolverModel()
    events: list[RunEvent] = []
    log = AgentLog()
    out = await run_agents([DoubleAgent(), RoomAgent()], state, model, events=events.append, log=log)
    results = log.results
    assert out == {"room": CountOutput(value=3), "double": CountOutput(value=6)}
    assert state.outputs == out and written(state) == {"room": 3, "double": 6}
    assert model.requests == {"room": 1, "double": 1}
    assert type(events[-1]).__name__ == "RunFinished"
    # the runner collects each agent's result: how it was answered and what it cost
    assert [(r.agent, r.outcome.answered_by, r.usage.requests) for r in results] == [("room", "model", 1), ("double", "model", 1)]
    assert [r.output for r in results] == [CountOutput(value=3), CountOutput(value=6)]


async def test_run_agents_resumes_from_a_store_and_restores_state(tmp_path: Path) -> None:
    store = FileRunStore(tmp_path / "agents")
    await run_agents([RoomAgent(), DoubleAgent()], make_state(3), SolverModel(), store=store)
    state, model = make_state(3), SolverModel()
    out = await run_agents([RoomAgent(), DoubleAgent()], state, model, store=store)
    assert model.requests == {}  # nothing asked again
    assert out == {"room": CountOutput(value=3), "double": CountOutput(value=6)}
    assert written(state) == {"room": 3, "double": 6}  # restored by replaying apply
    other, model = make_state(4), SolverModel()
    again = await run_agents([RoomAgent(), DoubleAgent()], other, model, store=store)
    assert again["double"] == CountOutput(value=8)
    assert model.requests == {"room": 1, "double": 1}  # a different scene is a different config key


async def test_unusable_agent_output_fails_the_node() -> None:
    with pytest.raises(NodeFailedError) as info:
        await run_agents([RoomAgent(), DoubleAgent()], make_state(), SolverModel(bad_for="double"))
    assert isinstance(info.value.cause, AgentOutputError) and info.value.node == "double"
    assert info.value.partial == {"room": CountOutput(value=3)}


def test_dependencies_are_trimmed_to_the_agents_present_and_last_agents_wait_for_all() -> None:
    class NeedsAbsent(DoubleAgent):
        depends_on: ClassVar[tuple[str, ...]] = ("room", "not_in_this_run")

    class Last(RoomAgent):
        name: ClassVar[str] = "last"
        runs_last: ClassVar[bool] = True

    deps = agent_dependencies([Last(), RoomAgent(), NeedsAbsent()])
    assert deps == {"last": ("room", "double"), "room": (), "double": ("room",)}


async def test_an_absent_dependency_does_not_block_the_run() -> None:
    class NeedsAbsent(DoubleAgent):
        depends_on: ClassVar[tuple[str, ...]] = ("room", "not_in_this_run")

    out = await run_agents([NeedsAbsent(), RoomAgent()], make_state(2), SolverModel())
    assert out["double"] == CountOutput(value=4)


async def test_a_manager_node_schedules_agents_at_run_time() -> None:
    state, model = make_state(2), SolverModel()

    async def manager(ctx: NodeContext) -> list[str]:
        add_agent_nodes([DoubleAgent(), RoomAgent()], state, model)
        return ["room", "double"]

    out = await Runner([Node("manager", manager)]).run()
    assert out["double"] == CountOutput(value=4) and written(state) == {"room": 2, "double": 4}


class _HandshakeAgent(RoomAgent):
    """A room agent whose ``gather`` blocks until a coroutine on the event loop answers it."""

    name: ClassVar[str] = "room"

    def __init__(self, from_loop: threading.Event, threads: dict[str, int]) -> None:
        self.from_loop = from_loop
        self.threads = threads

    def gather(self, state: SceneState) -> CountEvidence:
        self.threads["gather"] = threading.get_ident()
        # Only possible if gather is off the loop: the loop must run to set the event.
        assert self.from_loop.wait(5.0), "gather blocked the event loop"
        return super().gather(state)

    def check(self, output: CountOutput, state: SceneState) -> list[str]:
        self.threads["check"] = threading.get_ident()
        return super().check(output, state)

    def apply(self, output: CountOutput, state: SceneState) -> None:
        self.threads["apply"] = threading.get_ident()
        super().apply(output, state)


async def test_agent_scene_work_and_rule_solvers_run_off_the_event_loop() -> None:
    from scenemosaic.models import RulesModel

    loop_thread = threading.get_ident()
    from_loop, threads = threading.Event(), dict[str, int]()
    agent = _HandshakeAgent(from_loop, threads)
    solver_threads: list[int] = []
    solve = agent.solve

    def recording_solve(evidence: CountEvidence) -> CountOutput:
        solver_threads.append(threading.get_ident())
        return solve(evidence)

    agent.solve = recording_solve  # type: ignore[method-assign]

    async def answer() -> None:
        await asyncio.sleep(0)
        from_loop.set()

    state = make_state(3)
    _, result = await asyncio.gather(answer(), run_agent(agent, state, RulesModel()))
    assert result.output == CountOutput(value=3) and written(state) == {"room": 3}
    assert set(threads) == {"gather", "check", "apply"}
    assert loop_thread not in threads.values() and solver_threads and loop_thread not in solver_threads


async def test_agents_may_keep_their_hooks_on_the_loop() -> None:
    loop_thread = threading.get_ident()
    seen: list[int] = []

    class OnLoop(RoomAgent):
        offload: ClassVar[bool] = False

        def apply(self, output: CountOutput, state: SceneState) -> None:
            seen.append(threading.get_ident())
            super().apply(output, state)

    await run_agent(OnLoop(), make_state(2), SolverModel())
    assert seen == [loop_thread]


async def test_cancelling_during_apply_leaves_the_state_whole_and_no_task() -> None:
    applying, release, finished = threading.Event(), threading.Event(), threading.Event()

    class SlowApply(DoubleAgent):
        def apply(self, output: CountOutput, state: SceneState) -> None:
            applying.set()
            assert release.wait(5.0)
            state.scene.metadata["double"] = output.value
            state.scene.metadata["double_checked"] = True  # a second write: must never be seen alone
            finished.set()

    state = make_state(3)
    task = asyncio.create_task(run_agents([RoomAgent(), SlowApply()], state, SolverModel()))
    assert await asyncio.to_thread(applying.wait, 5.0)
    task.cancel()
    release.set()
    with pytest.raises(RunCancelledError) as info:
        await asyncio.wait_for(task, 5.0)
    # the worker thread ended before the run reported the cancel: nothing writes to the state afterwards
    assert finished.is_set()
    assert info.value.partial == {"room": CountOutput(value=3)}
    assert written(state) == {"room": 3, "double": 6, "double_checked": True}
    assert not state.lock.locked()
    assert asyncio.all_tasks() == {asyncio.current_task()}

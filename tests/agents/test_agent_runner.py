"""Agents return, the runner applies: ``run`` changes nothing, ``run_agent`` writes the result, and
one ``AgentLog`` collects every result with what its requests cost."""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import Any, ClassVar

import pytest
from agent_solvers import solver_answer
from pydantic import BaseModel

from scenemosaic.agents import (
    AgentLog,
    AgentOutput,
    AgentPolicy,
    AppliesOutput,
    SceneState,
    TaskAgent,
    apply_result,
    run_agent,
    run_agents,
)
from scenemosaic.evolve import ActorAgent, ArchetypeAgent, CriticAgent, PoseAgent
from scenemosaic.exceptions import ModelHTTPError, NodeFailedError, OutputValidationError
from scenemosaic.exchange import load_scene
from scenemosaic.metrics import JudgeAgent
from scenemosaic.models import (
    Message,
    Model,
    ModelSettings,
    RequestContext,
    RulesModel,
    Usage,
    open_run_model,
)
from scenemosaic.models._base import OutputT
from scenemosaic.perception import InventoryAgent, VerifyAgent
from scenemosaic.scene import Scene
from scenemosaic.structure import DEFAULT_AGENTS, ManagerAgent, structure_scene

BEDROOM = Path(__file__).resolve().parents[1] / "fixtures" / "bedroom_22.json"


def _bedroom() -> Scene:
    scene = load_scene(BEDROOM)
    assert isinstance(scene, Scene)
    return scene


class Count(BaseModel):
    n: int


class Echo(AgentOutput):
    value: int


class JudgeOfN(TaskAgent[SceneState, Count, Echo]):
    """Answers with ``metadata["n"]`` and only judges: it has no ``apply``."""

    name: ClassVar[str] = "judge_of_n"
    prompt: ClassVar[str] = "Repeat n.\n"

    def gather(self, state: SceneState) -> Count:
        return Count(n=int(state.scene.metadata["n"]))

    def solve(self, evidence: Count) -> Echo:
        return Echo(value=evidence.n)


class EchoAgent(JudgeOfN):
    """The same answer, written into the scene; usable only while it still equals ``n``."""

    name: ClassVar[str] = "echo"

    def check(self, output: Echo, state: SceneState) -> list[str]:
        n = state.scene.metadata["n"]
        return [] if output.value == n else [f"value {output.value} is not n ({n})"]

    def apply(self, output: Echo, state: SceneState) -> None:
        state.scene.metadata["echo"] = output.value


def _state(n: int = 3) -> SceneState:
    return SceneState(scene=Scene(metadata={"n": n}), policy=AgentPolicy(solver_fallback=False))


async def test_run_leaves_the_state_untouched_and_the_runner_applies_it() -> None:
    state = _state(3)
    before = state.scene.model_dump_json()
    result = await EchoAgent().run(state, RulesModel())
    assert result.output == Echo(value=3) and result.outcome.answered_by == "rules"
    assert state.scene.model_dump_json() == before and state.outputs == {} and state.revision == 0

    log = AgentLog()
    applied = await run_agent(EchoAgent(), state, RulesModel(), log=log)
    assert applied.output == Echo(value=3) and state.scene.metadata["echo"] == 3
    assert state.outputs == {"echo": Echo(value=3)} and state.revision == 1
    assert log.results == [applied] and log.outcomes["echo"].answered_by == "rules"


async def test_a_judgement_only_agent_has_no_apply_and_the_runner_changes_no_scene() -> None:
    judges: tuple[TaskAgent[Any, Any, Any], ...] = (JudgeOfN(), ManagerAgent(), CriticAgent(), ArchetypeAgent(), JudgeAgent())
    for judge in judges:
        assert not hasattr(judge, "apply") and not isinstance(judge, AppliesOutput), judge.name
    writers: list[TaskAgent[Any, Any, Any]] = [*DEFAULT_AGENTS, ActorAgent(), PoseAgent(), InventoryAgent(), VerifyAgent(), EchoAgent()]
    for writer in writers:
        assert isinstance(writer, AppliesOutput), writer.name

    state = _state(4)
    before = state.scene.model_dump_json()
    result = await run_agent(JudgeOfN(), state, RulesModel())
    assert result.output == Echo(value=4) and state.outputs == {"judge_of_n": Echo(value=4)}
    assert state.scene.model_dump_json() == before  # the runner recorded the verdict, the scene is as it was
    apply_result(JudgeOfN(), Echo(value=9), state)  # no apply to call: nothing but the output is written
    assert state.scene.model_dump_json() == before


class Scripted(Model):
    """Answers each agent with its rule solver's answer; each request costs its own, distinct tokens.
    The first request of ``broken_for`` is not JSON (an invalid reply that still costs tokens)."""

    name = "scripted"
    vision = False

    def __init__(self, broken_for: str = "attributes") -> None:
        self.spent: list[tuple[str, Usage]] = []
        self.broken_for = broken_for

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        assert context is not None
        usage = Usage(requests=1, input_tokens=100 + 7 * len(self.spent), output_tokens=3 + len(self.spent))
        first = all(agent != context.agent for agent, _ in self.spent)
        self.spent.append((context.agent, usage))
        await asyncio.sleep(0)
        if context.agent == self.broken_for and first:
            raise OutputValidationError("not JSON", raw_reply="oops", errors=["not JSON"], usage=usage)
        return output_type.model_validate(solver_answer(messages, context).model_dump()), usage


def _sums(spent: list[tuple[str, Usage]]) -> dict[str, Usage]:
    out: dict[str, Usage] = {}
    for agent, usage in spent:
        out[agent] = out.get(agent, Usage()) + usage
    return out


async def test_the_log_s_usage_by_agent_is_the_sum_of_the_requests_usage() -> None:
    model, log = Scripted(), AgentLog()
    scene = await structure_scene(_bedroom(), model, agent_log=log)
    assert scene.structure is not None and model.spent
    assert log.usage_by_agent == _sums(model.spent)
    assert log.usage == sum((u for _, u in model.spent), Usage())
    assert log.outcomes["attributes"].repairs == 1 and log.fallbacks == []
    assert sum(r.outcome.requests for r in log.results) == len(model.spent) == len(log.calls)
    assert log.results[0].agent == "manager"  # in the plan's order


async def test_the_log_reads_what_the_run_model_s_tracker_reads() -> None:
    """A stage's usage from its agent log equals the difference of the run model's usage readings."""
    async with await open_run_model(Scripted()) as stack:
        mark, log = stack.mark(), AgentLog()
        await structure_scene(_bedroom(), stack.model, agent_log=log)
        tracked, logged = stack.usage_since(mark), log.usage_summary()
    tracked.pop("latency_s")
    assert logged.pop("latency_s")["max"] >= 0.0
    assert logged == tracked and logged["requests"] > 0 and logged["failed_calls"] == 1


async def test_a_run_that_raises_still_hands_its_requests_to_the_log() -> None:
    class Refusing(Model):
        name = "refusing"
        vision = False

        async def request(self, messages, output_type, settings=None, *, context=None):  # type: ignore[no-untyped-def]
            raise ModelHTTPError("bad key", status_code=401, body="{}")

    log = AgentLog()
    with pytest.raises(NodeFailedError) as failed:
        await run_agents([EchoAgent()], _state(), Refusing(), log=log)
    assert isinstance(failed.value.cause, ModelHTTPError)
    assert log.results == [] and len(log.failed_calls) == 1
    assert log.usage_summary()["failed_calls"] == 1 and log.usage_by_agent == {"echo": Usage(requests=1)}


async def test_an_answer_that_went_stale_before_it_was_applied_is_asked_for_again() -> None:
    """Another agent's result applied between this agent's check and its application: the runner
    checks the answer again, and asks the agent again when it no longer fits."""
    checking, go_on = threading.Event(), threading.Event()

    class SlowFirstCheck(EchoAgent):
        checks = 0

        def check(self, output: Echo, state: SceneState) -> list[str]:
            type(self).checks += 1
            if type(self).checks == 1:  # the first check holds the lock until the test says so
                checking.set()
                assert go_on.wait(5.0)
            return super().check(output, state)

    class Asking(Model):
        name = "asking"
        vision = False

        async def request(self, messages, output_type, settings=None, *, context=None):  # type: ignore[no-untyped-def]
            return output_type.model_validate({"value": context.evidence.n}), Usage(requests=1)

    class SetN(EchoAgent):
        name: ClassVar[str] = "set_n"

        def apply(self, output: Echo, state: SceneState) -> None:
            state.scene.metadata["n"] = output.value

    state = _state(3)
    echo = asyncio.create_task(run_agent(SlowFirstCheck(), state, Asking()))
    assert await asyncio.to_thread(checking.wait, 5.0)

    async def write() -> None:
        async with state.lock:  # queued behind the first check, ahead of the echo's application
            apply_result(SetN(), Echo(value=5), state)

    writer = asyncio.create_task(write())
    for _ in range(5):
        await asyncio.sleep(0)
    go_on.set()
    await writer
    result = await echo
    assert state.scene.metadata == {"n": 5, "echo": 5} and result.output == Echo(value=5)
    assert result.outcome.requests == 2 and result.usage.requests == 2 and len(result.calls) == 2
    assert result.problems == (("value 3 is not n (5)",),)


def test_rule_solvers_in_a_graph_each_apply_before_the_next_gathers() -> None:
    """With the rules, independent agents run one at a time in the scheduler's order."""
    seen: list[tuple[str, Any]] = []

    class Reads(EchoAgent):
        def gather(self, state: SceneState) -> Count:
            seen.append((self.name, dict(state.scene.metadata)))
            return super().gather(state)

        def apply(self, output: Echo, state: SceneState) -> None:
            state.scene.metadata[self.name] = output.value

    class A(Reads):
        name: ClassVar[str] = "a"

    class B(Reads):
        name: ClassVar[str] = "b"

    asyncio.run(run_agents([A(), B()], _state(1), RulesModel()))
    assert seen == [("a", {"n": 1}), ("b", {"n": 1, "a": 1})]

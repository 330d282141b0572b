"""Large scenes are asked in chunks of objects: each chunk checked in the whole scene's context."""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

from agent_solvers import SOLVERS

from scenemosaic.agents import AgentPolicy, SceneState, run_agent
from scenemosaic.exchange import load_scene
from scenemosaic.models import FunctionModel, Message, RequestContext, RulesModel
from scenemosaic.structure import RoomAgent, SupportAgent

BEDROOM = Path(__file__).resolve().parents[1] / "fixtures" / "bedroom_22.json"


class SmallChunks(SupportAgent):
    chunk_size: ClassVar[int | None] = 5


def _parents(state: SceneState) -> dict[str, str]:
    return {r.child: r.parent for r in state.scene.relations if r.is_support}


async def _roomed() -> SceneState:
    state = SceneState(load_scene(BEDROOM), policy=AgentPolicy(solver_fallback=True))
    await run_agent(RoomAgent(), state, RulesModel())
    return state


async def test_chunked_answers_match_the_one_shot_answer() -> None:
    rules = await _roomed()
    await run_agent(SupportAgent(), rules, RulesModel())
    evidence_sizes: list[int] = []

    def reply(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None and context.evidence is not None
        evidence_sizes.append(len(context.evidence.objects))
        return SOLVERS["support"].solve(context.evidence)  # a model that agrees with the rules

    chunked = await _roomed()
    agent = SmallChunks()
    result = await run_agent(agent, chunked, FunctionModel(reply, vision=False))
    assert len(evidence_sizes) == 5  # 22 objects, 5 a chunk
    assert max(evidence_sizes) < len(chunked.scene.objects)  # each prompt shows part of the scene
    assert _parents(chunked) == _parents(rules)
    assert result.outcome.answered_by == "model" and result.fallback is None


async def test_a_chunk_that_stays_wrong_falls_back_alone() -> None:
    def reply(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None and context.evidence is not None
        answer = SOLVERS["support"].solve(context.evidence)
        if any(o.id == "pillow_0" for o in context.evidence.objects):  # this chunk: a mug carries the bed
            for a in answer.assignments:
                if a.object_id == "bed":
                    a.parent = "mug_0"
        return answer

    state = await _roomed()
    result = await run_agent(SmallChunks(), state, FunctionModel(reply, vision=False))
    assert _parents(state)["bed"] == "floor"  # the solver's part for that chunk
    record = result.fallback
    assert record is not None and record.agent == "support" and "rule solver for 5 objects" in record.reason
    assert result.outcome.answered_by == "solver_fallback" and result.outcome.repairs == 2  # sent back twice first
    assert len(result.problems) == 3 and all(p for p in result.problems)  # the bad chunk's three refusals


async def test_the_reply_cap_follows_the_objects_asked_about() -> None:
    """A reply may take ``base + per_object x objects`` tokens, never more than the run's cap: a
    small model that starts repeating itself is cut there, not at the run's 2048."""
    import json

    from llm_fakes import FakeServer, chat_reply

    from scenemosaic.models import ModelSettings

    state = await _roomed()
    answer = SupportAgent().solve(SupportAgent().gather(state))
    server = FakeServer(chat_reply(json.loads(answer.model_dump_json())))
    model, _ = server.model()
    await run_agent(SupportAgent(), state, model, ModelSettings(max_tokens=4000))
    base, per_object = SupportAgent.reply_tokens or (0, 0)
    assert server.bodies[0]["max_tokens"] == base + per_object * 22
    capped = SupportAgent().reply_settings(ModelSettings(max_tokens=300), SupportAgent().gather(state))
    assert capped is not None and capped.max_tokens == 300  # the run's cap is never raised

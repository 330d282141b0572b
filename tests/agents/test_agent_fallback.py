"""The agent owns repair and fallback: one attempt budget, then its rule solver, never silently for setup errors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import ClassVar

import pytest
from pydantic import BaseModel

from scenemosaic import GenerateConfig, generate, load_scene
from scenemosaic.agents import AgentOutput, AgentPolicy, SceneState, TaskAgent, run_agent
from scenemosaic.exceptions import (
    AgentOutputError,
    ModelConfigError,
    ModelHTTPError,
    OutputValidationError,
    ReplayMissError,
)
from scenemosaic.models import FunctionModel, Message, Model, RequestContext, RulesModel, TextPart
from scenemosaic.scene import Scene
from scenemosaic.structure import SupportAgent


class Answer(AgentOutput):
    value: int


class Number(BaseModel):
    value: int


class DoublingAgent(TaskAgent[SceneState, Number, Answer]):
    """Evidence 3, rule answer 6; the model's answer is written into the scene's metadata."""

    name: ClassVar[str] = "demo"
    prompt: ClassVar[str] = "Double the number.\n"

    def gather(self, state: SceneState) -> Number:
        return Number(value=3)

    def solve(self, evidence: Number) -> Answer:
        return Answer(value=evidence.value * 2)

    def check(self, output: Answer, state: SceneState) -> list[str]:
        return [] if output.value % 2 == 0 else [f"{output.value} is odd; the double of a whole number is even"]

    def apply(self, output: Answer, state: SceneState) -> None:
        state.scene.metadata["demo"] = output.value


FALLBACK = AgentPolicy(solver_fallback=True)


class FailingModel(Model):
    """Raises the given error on every request and counts the requests."""

    name = "failing"

    def __init__(self, error: Exception) -> None:
        self.error = error
        self.calls = 0

    async def request(self, messages, output_type, settings=None, *, context=None):  # type: ignore[no-untyped-def]
        self.calls += 1
        raise self.error


@pytest.mark.parametrize(
    "error",
    [
        OutputValidationError("not JSON", raw_reply="oops", errors=["not JSON"]),
        ModelHTTPError("overloaded", status_code=503, body="{}"),
        ModelHTTPError("slow down", status_code=429, body="{}"),
    ],
)
async def test_persistent_model_failures_fall_back_to_the_solver(error: Exception) -> None:
    state = SceneState(scene=Scene(), policy=FALLBACK)
    model = FailingModel(error)
    result = await run_agent(DoublingAgent(), state, model)
    assert result.output == Answer(value=6) and state.scene.metadata["demo"] == 6
    assert result.fallback is not None and result.fallback.agent == "demo"
    assert type(error).__name__ in result.fallback.reason or "attempts" in result.fallback.reason
    # a bad reply is repaired within the one budget; an HTTP failure (already retried by the transport) is not
    assert model.calls == (state.policy.max_attempts if isinstance(error, OutputValidationError) else 1)


async def test_one_budget_covers_schema_and_check_repairs() -> None:
    """A reply that is not JSON, then one that fails the check, then a good one: three requests."""
    replies = iter(["not json", '{"value": 7}', '{"value": 8}'])
    seen: list[list[Message]] = []

    def answer(messages: list[Message], context: RequestContext | None) -> str:
        seen.append(messages)
        return next(replies)

    state = SceneState(scene=Scene())
    result = await DoublingAgent().run(state, FunctionModel(answer, vision=False))
    assert result.output == Answer(value=8) and result.usage.requests == 3 and result.fallback is None
    assert result.outcome.answered_by == "model" and result.outcome.repairs == 2
    assert result.problems == (("7 is odd; the double of a whole number is even",),)  # the check's refusal only
    repair_1, repair_2 = seen[1][-1].parts[0].text, seen[2][-1].parts[0].text  # type: ignore[union-attr]
    assert "not a valid Answer" in repair_1
    assert "7 is odd" in repair_2 and "cannot be applied" in repair_2


async def test_without_fallback_an_exhausted_budget_fails_the_agent() -> None:
    state = SceneState(scene=Scene(), policy=AgentPolicy(max_attempts=2, solver_fallback=False))
    model = FunctionModel(lambda m, c: '{"value": 5}', vision=False)
    with pytest.raises(AgentOutputError, match="5 is odd"):
        await DoublingAgent().run(state, model)
    assert "demo" not in state.scene.metadata


@pytest.mark.parametrize(
    "error",
    [
        ModelHTTPError("bad key", status_code=401, body="{}"),
        ReplayMissError("no entry", differing=["messages[1]"]),
    ],
)
async def test_setup_errors_are_not_hidden(error: Exception) -> None:
    state = SceneState(scene=Scene(), policy=FALLBACK)
    with pytest.raises(type(error)):
        await DoublingAgent().run(state, FailingModel(error))
    assert "demo" not in state.scene.metadata


async def test_the_rules_model_is_never_asked() -> None:
    state = SceneState(scene=Scene())
    result = await DoublingAgent().run(state, RulesModel())
    assert result.output == Answer(value=6) and result.usage.requests == 0 and result.fallback is None
    assert result.outcome.answered_by == "rules"
    with pytest.raises(ModelConfigError, match="rule solver"):
        await RulesModel().request([Message.text("user", "hi")], Answer)


def _hallucinating(messages: list[Message], context: RequestContext) -> BaseModel:
    """Answers the support agent with a schema-valid reply naming an object that does not exist."""
    assert context.evidence is not None
    good = SupportAgent().solve(context.evidence).model_dump()  # type: ignore[arg-type]
    good["assignments"][0]["object_id"] = "no_such_object"
    return SupportAgent.output_type.model_validate(good)


async def test_agent_falls_back_when_checked_output_stays_unusable(repo_data: Path) -> None:
    scene = load_scene(repo_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json")
    hallucinating = FunctionModel(_hallucinating, vision=False)
    with pytest.raises(AgentOutputError, match="no_such_object"):
        await SupportAgent().run(SceneState(scene=scene), hallucinating)

    state = SceneState(scene=scene, policy=FALLBACK)
    result = await run_agent(SupportAgent(), state, hallucinating)
    assert result.output == SupportAgent().solve(SupportAgent().gather(SceneState(scene=scene)))
    assert result.fallback is not None and result.fallback.agent == "support"
    assert "object id 'no_such_object' does not exist in this scene" in result.fallback.reason
    assert any("support" in note and "rule solver" in note for note in state.scene.provenance.notes)
    assert all(state.scene.support_of(o.id) is not None for o in state.scene.objects)


def test_generate_with_a_broken_model_still_delivers_a_scene(tmp_path: Path, repo_data: Path) -> None:
    source = repo_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
    broken = FunctionModel(lambda messages, context: "this is not json {", vision=False)
    result = generate(source, tmp_path, GenerateConfig(model=broken, stabilize=False))
    report = json.loads((tmp_path / "report.json").read_text())
    structure = next(s for s in report["stages"] if s["name"] == "structure")
    assert report["status"] == "degraded" and result.status == "degraded"  # a scene, but honestly labelled
    assert structure["detail"]["solver_fallbacks"], "every agent should have fallen back"
    assert any("rule solver" in w for w in report["warnings"])
    assert all(result.scene.support_of(o.id) is not None for o in result.scene.objects)


async def test_a_context_refusal_compacts_the_prompt_once_then_falls_back() -> None:
    """First a shorter prompt (coarser evidence, no format note or legend); if refused too, the solver."""
    from scenemosaic.exceptions import ModelContextLengthError

    prompts: list[str] = []

    def refuse_long(messages: list[Message], context: RequestContext | None) -> str:
        prompts.append("".join(p.text for m in messages for p in m.parts if isinstance(p, TextPart)))
        if len(prompts) == 1:
            raise ModelContextLengthError("too long", status_code=400, body="{}", prompt_tokens=5000, context_tokens=4096)
        return '{"value": 6}'

    state = SceneState(scene=Scene(), policy=FALLBACK)
    result = await DoublingAgent().run(state, FunctionModel(refuse_long, vision=False))
    assert result.output == Answer(value=6) and result.fallback is None  # the compact prompt was answered
    assert len(prompts[1]) < len(prompts[0])
    assert "Evidence format" in prompts[0] and "Evidence format" not in prompts[1]
    assert "schema" not in prompts[0].replace("requested schema", "")  # the schema goes with the request

    always = FailingModel(ModelContextLengthError("too long", status_code=400, body="{}"))
    state = SceneState(scene=Scene(), policy=FALLBACK)
    result = await DoublingAgent().run(state, always)
    assert result.output == Answer(value=6) and always.calls == 2  # full prompt, compact prompt, then the solver
    assert result.fallback is not None and "ModelContextLengthError" in result.fallback.reason


async def test_a_fallback_comes_back_in_the_result_not_in_the_state() -> None:
    """The run's result says the solver answered and why; the shared state gets only the applied output."""
    state = SceneState(scene=Scene(), policy=FALLBACK)
    before = set(vars(state))
    result = await run_agent(DoublingAgent(), state, FunctionModel(lambda m, c: '{"value": 5}', vision=False))
    assert result.output == Answer(value=6) and result.agent == "demo"
    outcome = result.outcome
    assert outcome.answered_by == "solver_fallback" and outcome.requests == 3 and outcome.repairs == 2
    assert outcome.reason.startswith("unusable after 3 attempts: 5 is odd")
    assert result.fallback is not None and result.fallback.reason.startswith("unusable after 3 attempts")
    assert len(result.problems) == 3  # every refused answer, in order
    assert set(vars(state)) == before and not hasattr(state, "outcomes") and not hasattr(state, "fallbacks")
    assert state.outputs == {"demo": Answer(value=6)} and state.scene.metadata["demo"] == 6

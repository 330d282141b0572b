"""SolverFallbackModel: a failing model is replaced by the asking agent's rule solver, never silently for setup errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from pydantic import BaseModel

from scenemosaic import (
    FunctionModel,
    GenerateConfig,
    Message,
    Model,
    ModelSettings,
    RequestContext,
    SceneState,
    Usage,
    generate,
    load_scene,
)
from scenemosaic.agents import SupportAgent
from scenemosaic.exceptions import AgentOutputError, ModelHTTPError, OutputValidationError, ReplayMissError
from scenemosaic.models import SolverFallbackModel


class Answer(BaseModel):
    value: int


class FailingModel(Model):
    """Raises the given error on every request and counts the requests."""

    name = "failing"

    def __init__(self, error: Exception) -> None:
        self.error = error
        self.calls = 0

    async def request(self, messages, output_type, settings=None, *, context=None):  # type: ignore[no-untyped-def]
        self.calls += 1
        raise self.error


def _ctx() -> RequestContext:
    return RequestContext(agent="demo", evidence=3, solve=lambda e: Answer(value=e * 2))


@pytest.mark.parametrize(
    "error",
    [
        OutputValidationError("not JSON", raw_reply="oops"),
        ModelHTTPError("overloaded", status_code=503, body="{}"),
        ModelHTTPError("slow down", status_code=429, body="{}"),
    ],
)
async def test_persistent_model_failures_fall_back_to_the_solver(error: Exception) -> None:
    model = SolverFallbackModel(FailingModel(error))
    out, usage = await model.request([Message.text("user", "hi")], Answer, ModelSettings(), context=_ctx())
    assert out == Answer(value=6)
    assert usage == Usage()
    assert [f.agent for f in model.fallbacks] == ["demo"]
    assert type(error).__name__ in model.fallbacks[0].reason


@pytest.mark.parametrize(
    "error",
    [
        ModelHTTPError("bad key", status_code=401, body="{}"),
        ReplayMissError("no entry", differing=["messages[1]"]),
    ],
)
async def test_setup_errors_are_not_hidden(error: Exception) -> None:
    model = SolverFallbackModel(FailingModel(error))
    with pytest.raises(type(error)):
        await model.request([Message.text("user", "hi")], Answer, context=_ctx())
    assert model.fallbacks == []


def _hallucinating(messages: list[Message], context: RequestContext) -> BaseModel:
    """Answers the support agent with a schema-valid reply naming an object that does not exist."""
    assert context.solve is not None
    good = context.solve(context.evidence).model_dump()
    good["assignments"][0]["object_id"] = "no_such_object"
    return SupportAgent.output_type.model_validate(good)


async def test_agent_falls_back_when_checked_output_stays_unusable(shared_data: Path) -> None:
    scene = load_scene(shared_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json")
    strict = FunctionModel(_hallucinating, vision=False)
    with pytest.raises(AgentOutputError, match="no_such_object"):
        await SupportAgent().run(SceneState(scene=scene), strict)

    state = SceneState(scene=scene)
    lenient = SolverFallbackModel(FunctionModel(_hallucinating, vision=False))
    output, _ = await SupportAgent().run(state, lenient)
    assert output == SupportAgent().solve(SupportAgent().gather(SceneState(scene=scene)))
    assert [f.agent for f in lenient.fallbacks] == ["support"]
    assert any("support" in note and "rule solver" in note for note in state.scene.provenance.notes)
    assert all(state.scene.support_of(o.id) is not None for o in state.scene.objects)


def test_generate_with_a_broken_model_still_delivers_a_scene(tmp_path: Path, shared_data: Path) -> None:
    source = shared_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
    broken = FunctionModel(lambda messages, context: "this is not json {", vision=False)
    result = generate(source, tmp_path, GenerateConfig(model=broken, stabilize=False))
    report = json.loads((tmp_path / "report.json").read_text())
    structure = next(s for s in report["stages"] if s["name"] == "structure")
    assert report["status"] == "ok"
    assert structure["detail"]["solver_fallbacks"], "every agent should have fallen back"
    assert all(result.scene.support_of(o.id) is not None for o in result.scene.objects)

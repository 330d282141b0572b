"""The base check: every agent's declared id fields are checked for unknown and repeated ids, in one wording."""

from __future__ import annotations

from typing import ClassVar

import pytest
from pydantic import BaseModel, Field

from scenemosaic.agents import AgentOutput, AgentPolicy, SceneState, TaskAgent, run_agent
from scenemosaic.exceptions import AgentOutputError
from scenemosaic.models import FunctionModel
from scenemosaic.scene import AssetRef, Pose, Scene, SceneObject
from scenemosaic.structure import AttributesAgent, SemanticsAgent, SupportAgent, VerificationAgent


class Pick(AgentOutput):
    object_id: str
    near: list[str] = Field(default_factory=list)


class Picks(AgentOutput):
    picks: list[Pick]


class Nothing(BaseModel):
    pass


class PickAgent(TaskAgent[SceneState, Nothing, Picks]):
    """Picks objects: each at most once, each naming any objects it is near."""

    name: ClassVar[str] = "picks"
    prompt: ClassVar[str] = "Pick objects.\n"
    object_id_fields: ClassVar[tuple[str, ...]] = ("picks.object_id",)
    object_ref_fields: ClassVar[tuple[str, ...]] = ("picks.near",)

    def gather(self, state: SceneState) -> Nothing:
        return Nothing()

    def solve(self, evidence: Nothing) -> Picks:
        return Picks(picks=[])

    def apply(self, output: Picks, state: SceneState) -> None:
        state.scene.metadata["picks"] = [p.object_id for p in output.picks]


def _scene(*ids: str) -> Scene:
    return Scene(
        objects=[
            SceneObject(id=i, category="chair", asset=AssetRef(kind="box", extents=(0.5, 0.5, 0.9)), pose=Pose.from_yaw((k, 0.0, 0.0), 0.0))
            for k, i in enumerate(ids)
        ]
    )


def test_unknown_and_repeated_ids_are_reported_once_each_in_one_wording() -> None:
    state = SceneState(_scene("chair_0", "chair_1"))
    output = Picks(
        picks=[
            Pick(object_id="chair_0", near=["chair_1", "chair_1"]),  # a reference field may repeat
            Pick(object_id="ghost", near=["phantom"]),
            Pick(object_id="chair_0"),
            Pick(object_id="chair_0"),
            Pick(object_id="ghost"),
        ]
    )
    assert PickAgent().problems(output, state) == [
        "object id 'ghost' does not exist in this scene",
        "object 'chair_0' is listed twice",
        "object id 'phantom' does not exist in this scene",
    ]
    assert PickAgent().check(output, state) == []  # the agent's own check adds nothing here
    assert PickAgent().problems(Picks(picks=[Pick(object_id="chair_1", near=["chair_0"])]), state) == []


async def test_a_model_answer_with_an_unknown_id_is_sent_back_with_the_base_wording() -> None:
    replies = iter(['{"picks": [{"object_id": "ghost"}]}', '{"picks": [{"object_id": "chair_0"}]}'])
    sent: list[str] = []

    def answer(messages, context):  # type: ignore[no-untyped-def]
        sent.append(messages[-1].parts[0].text)
        return next(replies)

    state = SceneState(_scene("chair_0"), policy=AgentPolicy(solver_fallback=False))
    result = await run_agent(PickAgent(), state, FunctionModel(answer, vision=False))
    assert result.output.picks[0].object_id == "chair_0" and state.scene.metadata["picks"] == ["chair_0"]
    assert result.problems == (("object id 'ghost' does not exist in this scene",),)
    assert "- object id 'ghost' does not exist in this scene" in sent[1]


@pytest.mark.parametrize(
    ("agent", "fields"),
    [
        (SupportAgent(), ("assignments.object_id",)),
        (AttributesAgent(), ("objects.object_id",)),
        (SemanticsAgent(), ("objects.object_id",)),
        (VerificationAgent(), ("fixes.object_id", "moves.object_id", "lay_down")),
    ],
    ids=lambda a: getattr(a, "name", ""),
)
def test_built_in_agents_declare_their_id_fields(agent: TaskAgent[SceneState, BaseModel, BaseModel], fields: tuple[str, ...]) -> None:
    assert agent.object_id_fields == fields


def test_the_output_type_is_declared_once_by_the_type_parameter() -> None:
    assert PickAgent.output_type is Picks and SupportAgent.output_type.__name__ == "SupportOutput"
    with pytest.raises(TypeError, match="declares its output type twice"):

        class Twice(TaskAgent[SceneState, Nothing, Picks]):  # defining it is the test
            output_type: ClassVar[type[BaseModel]] = Picks


async def test_an_unknown_id_fails_a_strict_run_with_the_base_wording() -> None:
    state = SceneState(_scene("chair_0"), policy=AgentPolicy(max_attempts=1, solver_fallback=False))
    model = FunctionModel(lambda m, c: '{"picks": [{"object_id": "chair_0"}, {"object_id": "chair_0"}]}', vision=False)
    with pytest.raises(AgentOutputError, match="object 'chair_0' is listed twice"):
        await PickAgent().run(state, model)

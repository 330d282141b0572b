"""The Critic-Actor loop driven by a scripted model (a FunctionModel standing in for a VLM).

* a critic note becomes actor expressions and resolved poses, and round two's prompts carry the
  memory of round one;
* a hostile actor reply is refused by the sandbox and the actor is asked again with the reasons;
* a critic that keeps pushing an object back and forth is seen oscillating.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import pytest
from PIL import Image

from scenemosaic import GenerateConfig, generate
from scenemosaic.agents import AgentPolicy
from scenemosaic.evolve import ActorEvidence, CriticEvidence, LayoutMemory, evolve_layout, unit_context
from scenemosaic.models import FunctionModel, ImagePart, Message, RequestContext
from scenemosaic.physics import object_shape
from scenemosaic.scene import Scene, UnitLayout

DINING = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"


@pytest.fixture(scope="module")
def dining(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    """The dining room as the rules refined it: no rule finding the loop must act on, so what a
    scripted critic says is all that drives it (binding rule findings: test_rules_outrank_a_model)."""
    scene = generate(DINING, tmp_path_factory.mktemp("dining"), GenerateConfig()).scene
    assert isinstance(scene, Scene)
    return scene


@pytest.fixture(scope="module")
def stabilized(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    """The dining room as the stabilize stage leaves it (chairs scattered by the prior)."""
    scene = generate(DINING, tmp_path_factory.mktemp("stabilized"), GenerateConfig(evolve=False)).scene
    assert isinstance(scene, Scene)
    return scene


def _floor(scene: Scene) -> Any:
    assert scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    return unit_context(scene, unit, [], set())


def _text(messages: list[Message]) -> str:
    return "\n".join(p.text for m in messages for p in m.parts if hasattr(p, "text"))


async def test_note_to_expressions_to_poses_with_memory_and_a_refused_hostile_reply(dining: Scene) -> None:
    seen: dict[str, Any] = {"critic": [], "actor": []}

    def critic(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        ev = context.evidence
        assert isinstance(ev, CriticEvidence)
        seen["critic"].append((ev, _text(messages)))
        if ev.round == 1:
            return {
                "should_modify": True, "reasoning": "the chair stands a little far left",
                "modification_notes": ["Move (dining_chair_0) ten centimetres to the right."],
                "quality_basis": "one chair off", "quality_score": 70,
            }  # fmt: skip
        return {"should_modify": False, "reasoning": "fine now", "modification_notes": [], "quality_basis": "", "quality_score": 92}

    def actor(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        ev = context.evidence
        assert isinstance(ev, ActorEvidence)
        seen["actor"].append(_text(messages))
        assert ev.may_change == ["dining_chair_0"]  # only what the note names may change
        if len(seen["actor"]) == 1:
            return {"reasoning": "try", "pose_expressions": ["dining_chair_0.center.u = __import__('os').getcwd()"]}
        return {"reasoning": "to the right", "pose_expressions": ["dining_chair_0.center.u = dining_chair_0.center.u + 0.1"]}

    ctx = _floor(dining)
    layout = UnitLayout.from_scene(dining, ctx.unit)
    u0 = layout.center("dining_chair_0")[0]
    model = FunctionModel({"critic": critic, "actor": actor}, vision=False)
    shapes = {o.id: object_shape(o, None) for o in dining.objects}
    result = await evolve_layout(dining, ctx, layout, shapes, model, policy=AgentPolicy(max_attempts=3))

    first = result.rounds[0]
    assert first.notes == ["Move (dining_chair_0) ten centimetres to the right."]
    assert first.expressions == ["dining_chair_0.center.u = dining_chair_0.center.u + 0.1"]
    assert first.resolved["dining_chair_0"][0] == pytest.approx(u0 + 0.1, abs=1e-9)
    assert first.refused and "__import__" in seen["actor"][1] and "only the functions" in first.refused[0]
    # the repair request carried the refusal back to the actor
    assert "cannot be applied" in seen["actor"][1]
    # round two's critic saw round one in its memory
    ev2, prompt2 = seen["critic"][1]
    assert ev2.round == 2 and "round 1" in ev2.memory and "dining_chair_0.center.u + 0.1" in prompt2
    assert result.stop_reason == "critic asked for no change"
    actor_outcome = result.agents.outcomes["actor"]
    assert actor_outcome.answered_by == "model" and actor_outcome.repairs == 1


async def test_an_oscillating_critic_is_detected_and_said_in_the_next_prompt(dining: Scene) -> None:
    critics: list[CriticEvidence] = []
    moves = iter([0.2, -0.2, 0.2, -0.2, 0.2])

    def critic(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        critics.append(context.evidence)  # type: ignore[arg-type]
        return {
            "should_modify": True, "reasoning": "move it", "modification_notes": ["Shift (dining_chair_1) sideways."],
            "quality_basis": "", "quality_score": 50,
        }  # fmt: skip

    def actor(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        d = next(moves)
        return {"reasoning": "", "pose_expressions": [f"dining_chair_1.center.u = dining_chair_1.center.u + {d}"]}

    ctx = _floor(dining)
    layout = UnitLayout.from_scene(dining, ctx.unit)
    model = FunctionModel({"critic": critic, "actor": actor}, vision=False)
    shapes = {o.id: object_shape(o, None) for o in dining.objects}
    result = await evolve_layout(dining, ctx, layout, shapes, model, max_rounds=4)
    assert LayoutMemory(result.rounds).oscillating() == {"dining_chair_1": "u"}
    assert "oscillating" not in critics[1].memory  # two poses are not an oscillation yet
    assert "oscillating" in critics[2].memory and "dining_chair_1 along u" in critics[2].memory
    assert result.stop_reason == "round cap (4)"


def test_the_rule_critic_pivots_away_from_an_oscillating_object(stabilized: Scene) -> None:
    """Given the memory's avoid set, a collision fix moves the other object of the pair."""
    from scenemosaic.evolve import find_problems, physical_check
    from scenemosaic.physics import object_shape

    dining = stabilized
    ctx = _floor(dining)
    layout = UnitLayout.from_scene(dining, ctx.unit)
    u, v = layout.center("dining_chair_3")
    layout.set_center("dining_chair_2", u + 0.1, v)  # into its neighbour
    shapes = {o.id: object_shape(o, None) for o in dining.objects}
    check = physical_check(layout, ctx, shapes)
    [pair] = [p for p in check.collisions if {p.a, p.b} == {"dining_chair_2", "dining_chair_3"}]
    assert pair.contacts > 0
    first = [f for f in find_problems(layout, ctx, check) if f.kind == "collision"]
    assert set(first[0].fixes) == {"dining_chair_2"}  # equal chairs: the first id moves
    pivot = [f for f in find_problems(layout, ctx, check, avoid={"dining_chair_2"}) if f.kind == "collision"]
    assert set(pivot[0].fixes) == {"dining_chair_3"}


async def test_a_vision_critic_sees_the_unit_view_and_hallucinated_ids_or_prose_are_sent_back(dining: Scene) -> None:
    replies = iter(
        [
            "Looks fine to me!",  # not JSON
            {"should_modify": True, "reasoning": "", "modification_notes": ["Move (sofa_9) left."], "quality_basis": "", "quality_score": 50},
            {"should_modify": False, "reasoning": "ok", "modification_notes": [], "quality_basis": "", "quality_score": 95},
        ]
    )
    seen: list[list[Message]] = []

    def critic(messages: list[Message], context: RequestContext) -> Any:
        seen.append(messages)
        return next(replies)

    ctx = _floor(dining)
    layout = UnitLayout.from_scene(dining, ctx.unit)
    model = FunctionModel({"critic": critic}, vision=True)
    shapes = {o.id: object_shape(o, None) for o in dining.objects}
    result = await evolve_layout(dining, ctx, layout, shapes, model, policy=AgentPolicy(max_attempts=3))
    images = [p for m in seen[0] for p in m.parts if isinstance(p, ImagePart)]
    assert len(images) == 1
    with Image.open(io.BytesIO(images[0].png)) as view:
        assert view.size == (1024, 1024)
    assert "not a valid CriticOutput" in _text(seen[1])
    assert "'sofa_9', which is not an object of this unit" in _text(seen[2])
    critic_outcome = result.agents.outcomes["critic"]
    assert critic_outcome.answered_by == "model" and critic_outcome.repairs == 2
    assert result.stop_reason == "critic asked for no change"


async def test_the_critic_and_the_actor_get_an_explicit_round_input(dining: Scene) -> None:
    """A frozen round input, not fields the loop sets on a shared state; a refusal comes back in the result."""
    import dataclasses

    from scenemosaic.evolve import (
        ActorAgent,
        CriticAgent,
        EvolveState,
        RoundInput,
        RoundState,
        physical_check,
    )

    ctx = _floor(dining)
    layout = UnitLayout.from_scene(dining, ctx.unit)
    shapes = {o.id: object_shape(o, None) for o in dining.objects}
    state = EvolveState(scene=dining, layout=layout, context=ctx, policy=AgentPolicy(max_attempts=2, solver_fallback=True))
    judged = RoundInput(round=3, check=physical_check(layout, ctx, shapes))
    with pytest.raises(dataclasses.FrozenInstanceError):
        judged.round = 4  # type: ignore[misc]
    assert CriticAgent().gather(RoundState(**state.shared(), input=judged)).round == 3

    note = "Move (dining_chair_0) ten centimetres to the right."
    acting = RoundState(**state.shared(), input=dataclasses.replace(judged, notes=(note,)))
    hostile = FunctionModel(lambda m, c: {"reasoning": "x", "pose_expressions": ["__import__('os')"]}, vision=False)
    result = await ActorAgent().run(acting, hostile)
    assert result.outcome.answered_by == "solver_fallback" and len(result.problems) == 2
    assert all("not one assignment" in "; ".join(p) for p in result.problems)  # the sandbox's reasons
    assert state.layout is layout and not hasattr(acting, "refused")  # the actor wrote only its own state's layout


async def test_rules_outrank_a_model_that_answers_no_change(stabilized: Scene) -> None:
    """A critic that always answers "no change" and an actor that changes nothing: the binding
    rule findings (chairs the prior scattered) are still noted, and their rule fixes are applied
    and recorded, so the layout ends as valid as the rules make it."""
    from scenemosaic.models import parse_model

    def critic(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        return {"should_modify": False, "reasoning": "looks fine", "modification_notes": [], "quality_basis": "", "quality_score": 95}

    def actor(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        return {"reasoning": "nothing to do", "pose_expressions": []}

    ctx = _floor(stabilized)
    layout = UnitLayout.from_scene(stabilized, ctx.unit)
    shapes = {o.id: object_shape(o, None) for o in stabilized.objects}
    lazy = await evolve_layout(stabilized, ctx, layout, shapes, FunctionModel({"critic": critic, "actor": actor}, vision=False))
    rules = await evolve_layout(stabilized, ctx, layout, shapes, parse_model("rules"))
    first = lazy.rounds[0]
    assert first.notes and any("Seat the chairs" in n for n in first.notes), first.notes
    assert first.enforced, "the rule fixes the actor left undone were applied"
    assert "rule fixes applied for" in LayoutMemory(lazy.rounds).text()
    assert lazy.valid and len(lazy.violations) <= len(rules.violations), lazy.violations


async def test_a_model_round_that_changes_nothing_ends_the_loop(stabilized: Scene, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 57: with a model, a round that moved nothing ends the layout's loop even when the layout
    is not clean (the next round would ask the same about the same layout); the critic is asked once,
    not once per round up to the cap. The rules' own fixes of binding findings (which would move the
    chair whatever the actor says) are switched off here, to leave a collision nothing fixes."""
    from scenemosaic.evolve import _loop

    monkeypatch.setattr(_loop, "_enforce", lambda before, after, findings: [])
    asked: list[str] = []

    def critic(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        asked.append("critic")
        return {
            "should_modify": True, "reasoning": "two chairs meet", "modification_notes": ["Move (dining_chair_2) apart."],
            "quality_basis": "", "quality_score": 40,
        }  # fmt: skip

    def actor(messages: list[Message], context: RequestContext) -> dict[str, Any]:
        asked.append("actor")
        return {"reasoning": "nothing to do", "pose_expressions": []}

    ctx = _floor(stabilized)
    layout = UnitLayout.from_scene(stabilized, ctx.unit)
    u, v = layout.center("dining_chair_3")
    layout.set_center("dining_chair_2", u + 0.1, v)  # into its neighbour: not clean
    model = FunctionModel({"critic": critic, "actor": actor}, vision=False)
    shapes = {o.id: object_shape(o, None) for o in stabilized.objects}
    result = await evolve_layout(stabilized, ctx, layout, shapes, model, max_rounds=8)
    assert result.stop_reason == "early stop: the last round changed nothing", result.stop_reason
    assert asked.count("critic") == 1 and len(result.rounds) == 1

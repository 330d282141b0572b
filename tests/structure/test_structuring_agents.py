"""Per-agent tests: rule solvers on real-sized scenes, checks against hostile outputs."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from agent_solvers import solver_answer
from shapely.geometry import Polygon

from scenemosaic.agents import AgentPolicy, SceneState, TaskAgent, agent_dependencies, run_agent
from scenemosaic.exceptions import AgentOutputError
from scenemosaic.models import FunctionModel, Message, RequestContext, RulesModel
from scenemosaic.physics import is_fixed
from scenemosaic.scene import CEILING, FLOOR, AssetRef, Pose, Relation, Room, Scene, SceneObject, load_priors
from scenemosaic.structure import (
    AttributesAgent,
    ConstraintsAgent,
    ContainmentAgent,
    ManagerAgent,
    RoomAgent,
    SemanticsAgent,
    SupportAgent,
    VerificationAgent,
    WallAttachmentAgent,
    plan_structuring,
    structure_scene,
)


def box(oid: str, cat: str, size: tuple[float, float, float], pos: tuple[float, float, float], yaw: float = 0.0) -> SceneObject:
    return SceneObject(id=oid, category=cat, asset=AssetRef(kind="box", extents=size), pose=Pose.from_yaw(pos, yaw))


async def run_chain(state: SceneState, agents: list[TaskAgent[SceneState, Any, Any]]) -> None:
    model = RulesModel()
    for a in agents:
        await run_agent(a, state, model)


@pytest.fixture(scope="module")
def priors(procthor_dir: Path) -> Any:
    return load_priors(procthor_dir)


# -- room ------------------------------------------------------------------------------------
async def test_room_keeps_input_room_and_completes_walls() -> None:
    room = Room(floor=[(0, 0), (4, 0), (4, 3), (0, 3)], ceiling_height=2.5)
    scene = Scene(room=room, objects=[box("t", "table", (1, 1, 0.7), (2, 1.5, 0))])
    state = SceneState(scene)
    out = (await run_agent(RoomAgent(), state, RulesModel())).output
    assert out.kept_input
    assert state.scene.room is not None
    assert state.scene.room.floor == room.floor and state.scene.room.ceiling_height == 2.5
    assert [w.id for w in state.scene.room.walls] == ["wall_0", "wall_1", "wall_2", "wall_3"]


async def test_room_fits_rotated_rectangle_and_snaps_to_wall_furniture() -> None:
    yaw = math.radians(30)
    c, s = math.cos(yaw), math.sin(yaw)

    def at(u: float, v: float) -> tuple[float, float, float]:
        return (c * u - s * v, s * u + c * v, 0.0)

    scene = Scene(objects=[
        # wardrobe with its back (+v) to the far side
        box("wardrobe", "wardrobe", (1.2, 0.6, 2.0), at(0.0, 2.0), yaw),
        box("bed", "double_bed", (1.6, 2.0, 0.6), at(0.0, -0.5), yaw),
        box("chair", "chair", (0.5, 0.5, 0.9), at(1.8, 0.0), yaw),
    ])
    state = SceneState(scene)
    out = (await run_agent(RoomAgent(), state, RulesModel())).output
    assert abs(out.yaw_deg - 30.0) < 1e-6
    poly = Polygon(out.floor)
    assert poly.area < 0.95 * Polygon(out.floor).envelope.area  # rotated, not axis-aligned
    for o in scene.objects:
        assert poly.buffer(1e-6).contains(Polygon(o.footprint()))
    # the side behind the wardrobe is snapped (2 cm), the chair's side keeps the free margin
    w = scene.get("wardrobe")
    assert 0.0 < poly.exterior.distance(Polygon(w.footprint()).exterior) <= 0.03
    assert poly.exterior.distance(Polygon(scene.get("chair").footprint()).exterior) > 0.2


# -- support ---------------------------------------------------------------------------------
def desk_scene() -> Scene:
    return Scene(objects=[
        box("desk", "desk", (1.4, 0.7, 0.75), (0, 0, 0)),
        box("mug", "mug", (0.08, 0.08, 0.1), (0.3, 0.1, 0.752)),
        box("laptop", "laptop", (0.33, 0.23, 0.02), (-0.3, 0.0, 0.70)),  # sunk 5 cm into the top
        box("chair", "dining_chair", (0.45, 0.5, 0.9), (0.1, 0.3, 0.37)),  # floating over the desk footprint
        box("lamp", "pendant_lamp", (0.3, 0.3, 0.6), (0, 0, 0.0)),  # standing on the floor
        box("bed", "double_bed", (1.6, 2.0, 0.5), (3, 0, -0.4)),  # sunk
    ])


async def test_support_rules(priors: Any) -> None:
    state = SceneState(desk_scene())
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    parent = {o.id: state.scene.support_of(o.id).parent for o in state.scene.objects}  # type: ignore[union-attr]
    assert parent == {"desk": FLOOR, "mug": "desk", "laptop": "desk", "chair": FLOOR, "lamp": CEILING, "bed": FLOOR}


def _scripted(bad: dict[str, Any], calls: list[list[Message]]) -> FunctionModel:
    def reply(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None
        if context.agent in bad:
            calls.append(messages)
            return bad[context.agent]
        return solver_answer(messages, context)

    return FunctionModel(reply)


def _support_reply(**parents: str) -> dict[str, Any]:
    return {"assignments": [{"object_id": k, "parent": v} for k, v in parents.items()]}


BASE = {"desk": FLOOR, "laptop": "desk", "chair": FLOOR, "lamp": CEILING, "bed": FLOOR}


@pytest.mark.parametrize(
    ("reply", "needle"),
    [
        (_support_reply(**BASE, mug="ghost_7"), "'ghost_7'"),  # unknown parent id
        (_support_reply(**BASE, mug="desk", phantom="floor"), "'phantom' does not exist"),  # unknown object id
        (_support_reply(**{**BASE, "desk": "laptop", "laptop": "desk"}, mug="desk"), "cycle"),  # parent cycle
        (_support_reply(**{**BASE, "bed": "mug"}, mug="desk"), "cannot carry"),  # a mug cannot support a bed
    ],
)
async def test_support_hostile_outputs_fail_cleanly(priors: Any, reply: dict[str, Any], needle: str) -> None:
    state = SceneState(desk_scene())
    await run_agent(RoomAgent(), state, RulesModel())
    before = state.scene.to_json()
    calls: list[list[Message]] = []
    with pytest.raises(AgentOutputError) as err:
        await run_agent(SupportAgent(priors), state, _scripted({"support": reply}, calls))
    assert any(needle in p for p in err.value.problems), err.value.problems
    assert err.value.agent == "support"
    assert len(calls) == AgentPolicy().max_attempts
    repair = calls[1][-1].parts[0].text  # type: ignore[union-attr]
    assert "cannot be applied" in repair and needle in repair
    assert state.scene.to_json() == before  # nothing applied
    assert "support" not in state.outputs


async def test_hostile_output_through_the_whole_dag_leaves_input_untouched(procthor_dir: Path) -> None:
    scene = desk_scene()
    before = scene.to_json()
    calls: list[list[Message]] = []
    model = _scripted({"support": _support_reply(**{**BASE, "desk": "mug"}, mug="desk")}, calls)
    with pytest.raises(AgentOutputError, match="cycle"):
        await structure_scene(scene, model, priors_dir=procthor_dir)
    assert scene.to_json() == before


async def test_repair_succeeds_on_second_reply(priors: Any) -> None:
    state = SceneState(desk_scene())
    await run_agent(RoomAgent(), state, RulesModel())
    replies = [_support_reply(**BASE, mug="ghost"), _support_reply(**BASE, mug="desk")]
    model = FunctionModel({"support": lambda m, c: replies.pop(0)})
    _out = (await run_agent(SupportAgent(priors), state, model)).output
    assert not replies
    assert state.scene.support_of("mug").parent == "desk"  # type: ignore[union-attr]


# -- containment -----------------------------------------------------------------------------
async def test_containment_books_in_shelf_and_toy_in_box(priors: Any) -> None:
    scene = Scene(objects=[
        box("shelf", "bookshelf", (0.8, 0.3, 1.8), (0, 0, 0)),
        box("book_a", "book", (0.03, 0.2, 0.25), (-0.2, 0, 0.42)),
        box("book_b", "book", (0.03, 0.2, 0.25), (0.1, 0, 1.2)),
        box("crate", "box", (0.5, 0.4, 0.35), (2, 0, 0)),
        box("toy", "vase", (0.1, 0.1, 0.15), (2, 0, 0.05)),
        box("vase", "vase", (0.1, 0.1, 0.3), (0.2, 0.0, 1.8)),  # on top of the shelf, not inside
    ])
    state = SceneState(scene)
    await run_chain(state, [RoomAgent(), SupportAgent(priors), ContainmentAgent(priors)])
    rel = {o.id: state.scene.support_of(o.id) for o in scene.objects}
    assert rel["book_a"].kind == "contain" and rel["book_a"].parent == "shelf" and rel["book_a"].opening == "front"  # type: ignore[union-attr]
    assert rel["book_b"].kind == "contain" and rel["book_b"].parent == "shelf"  # type: ignore[union-attr]
    assert rel["toy"].kind == "contain" and rel["toy"].parent == "crate" and rel["toy"].opening == "top"  # type: ignore[union-attr]
    assert rel["vase"].kind == "attach" and rel["vase"].parent == "shelf"  # type: ignore[union-attr]


async def test_containment_rejects_a_leaf_container(priors: Any) -> None:
    state = SceneState(desk_scene())
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    bad = {"items": [{"object_id": "laptop", "container_id": "mug", "opening": "top"}]}
    with pytest.raises(AgentOutputError, match="mug"):
        await run_agent(ContainmentAgent(priors), state, _scripted({"containment": bad}, []))


# -- walls -----------------------------------------------------------------------------------
def wall_scene() -> Scene:
    """A 5 x 4 m room; yaw 0 faces -Y, so furniture on the y=4 wall (wall_2) faces the room at yaw 0."""
    room = Room.rectangle(0, 0, 5, 4, ceiling_height=2.7)
    return Scene(room=room, objects=[
        box("wardrobe", "wardrobe", (1.2, 0.6, 2.0), (1.0, 3.65, 0.0), 0.0),  # back to wall_2, 5 cm gap
        box("tv", "television", (1.2, 0.08, 0.7), (2.5, 3.93, 1.2), 0.0),  # hanging, nothing under
        box("painting", "painting", (0.8, 0.04, 0.6), (0.03, 2.0, 1.4), math.pi / 2),  # on wall_3 (x=0)
        box("tv_stand", "tv_stand", (1.6, 0.4, 0.5), (2.5, 3.78, 0.0), 0.0),
        box("sofa", "multi_seat_sofa", (2.0, 0.9, 0.8), (2.5, 0.5, 0.0), math.pi),  # back to wall_0 (y=0)
        box("table", "coffee_table", (1.0, 0.6, 0.45), (2.5, 1.6, 0.0)),
    ])


async def test_walls_flush_and_mounted(priors: Any) -> None:
    state = SceneState(wall_scene())
    out = (await run_wall_chain(state, priors)).output
    items = {i.object_id: i for i in out.items}
    assert items["wardrobe"].wall_id == "wall_2" and items["wardrobe"].flush and items["wardrobe"].facing == "back"
    assert abs(items["wardrobe"].distance - 0.05) < 0.01
    assert items["tv"].mounted and not items["tv"].flush
    assert items["painting"].mounted and items["painting"].wall_id == "wall_3"
    assert items["sofa"].wall_id == "wall_0" and items["sofa"].flush and items["sofa"].facing == "back"
    assert "table" not in items  # 1.3 m from every wall: not reported
    against = {r.child: r for r in state.scene.relations if r.kind == "against"}
    assert against["wardrobe"].parent == "wall_2"
    tv = state.scene.support_of("tv")
    assert tv is not None and tv.parent == "wall_2" and tv.distance is not None


async def run_wall_chain(state: SceneState, priors: Any) -> Any:
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    return await run_agent(WallAttachmentAgent(), state, RulesModel())


async def test_walls_reject_unknown_wall(priors: Any) -> None:
    state = SceneState(wall_scene())
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    bad = {"items": [{"object_id": "wardrobe", "wall_id": "wall_9", "distance": 0.0, "facing": "back", "flush": True}]}
    with pytest.raises(AgentOutputError, match="wall_9"):
        await run_agent(WallAttachmentAgent(), state, _scripted({"walls": bad}, []))


# -- semantics -------------------------------------------------------------------------------
async def test_semantics_turns_wardrobe_facing_the_wall_and_reports_chairs(priors: Any) -> None:
    room = Room.rectangle(0, 0, 5, 4)
    scene = Scene(room=room, objects=[
        box("wardrobe", "Wardrobe", (1.2, 0.6, 2.0), (1.0, 3.65, 0.0), 0.0),  # front (-Y at yaw 0)... faces +Y? no
        box("table", "dining_table", (1.4, 0.9, 0.75), (3.0, 2.0, 0.0)),
        box("chair_ok", "dining_chair", (0.45, 0.5, 0.9), (3.0, 1.2, 0.0), math.pi),  # faces +Y, toward the table
        box("chair_away", "dining_chair", (0.45, 0.5, 0.9), (3.0, 2.8, 0.0), math.pi),  # faces +Y, away from it
        box("chair_side", "Dining Chair 3", (0.45, 0.5, 0.9), (2.0, 2.0, 0.0), 0.0),  # faces -Y: sideways to it
    ])
    # put the wardrobe's front toward the wall: yaw pi turns its front to +Y (the wall at y=4)
    scene = scene.model_copy(update={"objects": [
        o.model_copy(update={"pose": o.pose.with_yaw(math.pi)}) if o.id == "wardrobe" else o for o in scene.objects
    ]})
    scene = Scene.model_validate(scene.model_dump())
    state = SceneState(scene)
    await run_chain(state, [RoomAgent(), SupportAgent(priors), WallAttachmentAgent()])
    out = (await run_agent(SemanticsAgent(), state, RulesModel())).output
    items = {i.object_id: i for i in out.objects}
    assert items["wardrobe"].yaw_fix_deg == 180 and not items["wardrobe"].front_ok
    w = state.scene.get("wardrobe")
    assert abs(abs(w.pose.yaw) - 0.0) < 1e-6  # turned to face the room (-Y)
    assert items["chair_ok"].front_ok and items["chair_ok"].yaw_fix_deg == 0
    assert abs(items["chair_away"].yaw_fix_deg) == pytest.approx(180.0)
    assert items["chair_side"].yaw_fix_deg == 0  # sideways, not away: a chair pulled out is left alone
    assert state.scene.get("chair_side").category == "dining_chair"
    assert "dining chair" in state.scene.get("chair_ok").description


# -- attributes ------------------------------------------------------------------------------
async def test_attributes_table(priors: Any) -> None:
    state = SceneState(wall_scene())
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    out = (await run_agent(AttributesAgent(), state, RulesModel())).output
    sim = {o.id: o.sim for o in state.scene.objects}
    # wall-mounted: dynamic in their wall unit (gravity toward the wall settles them onto it), held
    # where they hang in the whole scene under real gravity
    assert not sim["tv"].static and not sim["painting"].static
    assert "hangs" in (sim["painting"].source or "")
    assert is_fixed(state.scene, state.scene.get("tv")) and is_fixed(state.scene, state.scene.get("painting"))
    assert not is_fixed(state.scene, state.scene.get("wardrobe"))
    assert not sim["wardrobe"].static and sim["wardrobe"].mass_kg is not None and sim["wardrobe"].mass_kg >= 45
    assert sim["table"].mass_kg is not None and 8 <= sim["table"].mass_kg <= 40
    assert all(0.2 <= s.friction <= 1.0 for s in sim.values())
    assert len(out.objects) == len(state.scene.objects)


async def test_attributes_reject_implausible_mass(priors: Any) -> None:
    state = SceneState(desk_scene())
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    bad = {"objects": [{"object_id": "mug", "mass_kg": 50.0, "friction": 0.4}]}
    with pytest.raises(AgentOutputError, match="implausible"):
        await run_agent(AttributesAgent(), state, _scripted({"attributes": bad}, []))


# -- constraints -----------------------------------------------------------------------------
async def test_wall_tv_and_stand_constraint(priors: Any, procthor_dir: Path) -> None:
    out = await structure_scene(wall_scene(), priors_dir=procthor_dir)
    tv = [c for c in out.constraints if c.kind == "placement" and "tv" in c.anchor_a.related_objects]
    assert len(tv) == 1
    assert tv[0].anchor_a.anchor_id == "wall_2" and tv[0].anchor_b.anchor_id == FLOOR
    assert tv[0].anchor_b.related_objects == ["tv_stand"]
    # no weak pair (painting <-> sofa) is ever emitted
    for c in out.constraints:
        assert "painting" not in c.anchor_a.related_objects + c.anchor_b.related_objects


async def test_constraints_reject_weak_pair_and_foreign_objects(priors: Any) -> None:
    state = SceneState(wall_scene())
    await run_chain(state, [RoomAgent(), SupportAgent(priors), WallAttachmentAgent()])
    weak = {"constraints": [{
        "id": "c0", "kind": "placement", "description": "painting above the sofa",
        "anchor_a": {"anchor_id": "wall_3", "related_objects": ["painting"], "layout_note": "centre it"},
        "anchor_b": {"anchor_id": "floor", "related_objects": ["sofa"], "layout_note": "below"},
    }]}
    with pytest.raises(AgentOutputError, match="weak pair"):
        await run_agent(ConstraintsAgent(), state, _scripted({"constraints": weak}, []))
    foreign = {"constraints": [{
        "id": "c0", "kind": "orientation", "description": "sofa faces table",
        "anchor_a": {"anchor_id": "table", "related_objects": ["sofa"], "layout_note": "x"},
        "anchor_b": {"anchor_id": "floor", "related_objects": ["table", "ghost"], "layout_note": "y"},
    }]}
    with pytest.raises(AgentOutputError) as err:
        await run_agent(ConstraintsAgent(), state, _scripted({"constraints": foreign}, []))
    assert any("not in the unit" in p for p in err.value.problems)
    assert any("'ghost'" in p for p in err.value.problems)
    assert state.scene.constraints == []


# -- verification ----------------------------------------------------------------------------
async def test_verification_fixes_missing_parents_and_builds_the_tree() -> None:
    scene = Scene(
        room=Room.rectangle(0, 0, 4, 4),
        objects=[
            box("table", "table", (1, 1, 0.7), (2, 2, 0)),
            box("cup", "cup", (0.1, 0.1, 0.1), (2, 2, 0.7)),
            box("lamp", "pendant_lamp", (0.3, 0.3, 0.5), (1, 1, 2.2)),
        ],
        relations=[Relation(kind="attach", child="cup", parent="table")],
    )
    state = SceneState(scene)
    out = (await run_agent(VerificationAgent(), state, RulesModel())).output
    assert {(f.object_id, f.parent) for f in out.fixes} == {("table", FLOOR), ("lamp", CEILING)}
    assert state.scene.structure is not None
    assert [u.anchor_id for u in state.scene.structure.units] == [FLOOR, CEILING, "table"]


async def test_verification_rejects_a_fix_that_leaves_a_cycle() -> None:
    scene = Scene(objects=[box("a", "table", (1, 1, 0.7), (0, 0, 0)), box("b", "table", (1, 1, 0.7), (0, 0, 0.7))])
    state = SceneState(scene)
    bad = {"fixes": [{"object_id": "a", "parent": "b"}, {"object_id": "b", "parent": "a"}]}
    with pytest.raises(AgentOutputError, match="cycle"):
        await run_agent(VerificationAgent(), state, _scripted({"verify": bad}, []))
    assert state.scene.structure is None


# -- manager ---------------------------------------------------------------------------------
async def test_manager_plans_by_scene_content(priors: Any) -> None:
    plan, agents = plan_structuring(desk_scene(), priors=priors)
    names = [a.name for a in agents]
    assert "containment" not in names and {s.name for s in plan.skipped} == {"containment"}
    assert names[0] == "room" and names[-1] == "verify"
    deps = agent_dependencies(agents)
    assert "containment" not in deps["constraints"]  # trimmed to scheduled agents
    assert set(deps["verify"]) == set(names) - {"verify"}  # runs last: waits for every other agent
    shelf = Scene(objects=[box("shelf", "bookshelf", (0.8, 0.3, 1.8), (0, 0, 0)),
                           box("book", "book", (0.03, 0.2, 0.25), (0, 0, 0.4))])
    _plan2, agents2 = plan_structuring(shelf, priors=priors)
    assert "containment" in [a.name for a in agents2]
    assert "constraints" not in [a.name for a in agents2]


async def test_built_ins_and_plugins_say_when_they_are_needed_through_one_seam(priors: Any) -> None:
    """The manager has no table of built-in names: every agent answers ``needed`` on the scene's
    summary, and a plugin that says it has nothing to do here is skipped like a built-in."""
    from scenemosaic.agents import Need
    from scenemosaic.structure import DEFAULT_AGENTS, REQUIRED_AGENTS

    class OnlyWithPlants(TaskAgent[SceneState, Any, Any]):  # a plugin that knows when it has work
        name = "plants"
        prompt = "unused"

        def needed(self, summary: Any) -> Need:
            found = tuple(c for c in summary.categories if "plant" in c)
            return Need(bool(found), "plants to water" if found else "no plant in the scene", evidence=found, insist="plants are present")

        def gather(self, state: SceneState) -> Any:
            return None

        def solve(self, evidence: Any) -> Any:
            return None

    plan, agents = plan_structuring(desk_scene(), agents=[*DEFAULT_AGENTS, OnlyWithPlants()], priors=priors)
    assert "plants" not in [a.name for a in agents]
    assert {s.name: s.reason for s in plan.skipped}["plants"] == "no plant in the scene"
    plant = Scene(objects=[*desk_scene().objects, box("fern", "house_plant", (0.3, 0.3, 0.6), (1.5, 1.5, 0))])
    plan, agents = plan_structuring(plant, agents=[*DEFAULT_AGENTS, OnlyWithPlants()], priors=priors)
    assert "plants" in [a.name for a in agents]
    # a model's plan leaving it out while the scene holds a plant is refused, naming what called for it
    manager = ManagerAgent([*DEFAULT_AGENTS, OnlyWithPlants()], priors=priors)
    without = plan.model_copy(update={"agents": [p for p in plan.agents if p.name != "plants"]})
    assert any("schedule 'plants': plants are present (plant)" in p for p in manager.check(without, SceneState(plant)))
    # the names every plan must hold are those the built-ins call required
    summary = manager.gather(SceneState(plant))
    assert {a.name for a in DEFAULT_AGENTS if a.needed(summary).required} == REQUIRED_AGENTS


async def test_manager_rejects_a_plan_without_support(priors: Any) -> None:
    state = SceneState(desk_scene())
    bad = {"agents": [{"name": "room"}, {"name": "verify"}]}
    with pytest.raises(AgentOutputError, match="support"):
        await run_agent(ManagerAgent(priors=priors), state, _scripted({"manager": bad}, []))


async def test_semantics_rejects_a_renamed_category(priors: Any) -> None:
    """A model may fix a category's spelling, not turn a pendant lamp into a bed (a later agent
    would then weigh it as one)."""
    scene = Scene(room=Room.rectangle(0, 0, 4, 4), objects=[
        box("lamp", "Pendant Lamp", (0.4, 0.4, 0.4), (2.0, 2.0, 2.2)),
        box("bed", "double_bed", (1.6, 2.0, 0.5), (2.0, 1.5, 0.0)),
    ])
    state = SceneState(scene)
    await run_chain(state, [RoomAgent(), SupportAgent(priors)])
    renamed = {"objects": [{"object_id": "lamp", "category": "double_bed"}, {"object_id": "bed", "category": "double_bed"}]}
    with pytest.raises(AgentOutputError, match="keep its category"):
        await run_agent(SemanticsAgent(), state, _scripted({"semantics": renamed}, []))
    respelled = {"objects": [{"object_id": "lamp", "category": "pendant_lamp"}, {"object_id": "bed", "category": "double_bed"}]}
    await run_agent(SemanticsAgent(), state, _scripted({"semantics": respelled}, []))
    assert state.scene.get("lamp").category == "pendant_lamp"


async def test_support_rejects_furniture_hung_from_the_ceiling_or_a_wall(priors: Any) -> None:
    """A small model once hung a bed, a shelf and a wardrobe from the ceiling: refused, with what to do."""
    scene = Scene(room=Room.rectangle(0, 0, 4, 4, ceiling_height=2.7), objects=[
        box("bed", "double_bed", (1.6, 2.0, 0.5), (2.0, 1.5, 0.0)),
        box("wardrobe", "wardrobe", (1.2, 0.6, 2.0), (3.0, 3.65, 0.0)),
        box("lamp", "pendant_lamp", (0.4, 0.4, 0.4), (2.0, 2.0, 2.3)),
    ])
    state = SceneState(scene)
    await run_agent(RoomAgent(), state, RulesModel())
    wrong = {"assignments": [
        {"object_id": "bed", "parent": "ceiling"},
        {"object_id": "wardrobe", "parent": "wall_2"},
        {"object_id": "lamp", "parent": "floor"},
    ]}
    with pytest.raises(AgentOutputError) as info:
        await run_agent(SupportAgent(priors), state, _scripted({"support": wrong}, []))
    problems = " ".join(info.value.problems)
    assert "'bed' (double_bed) does not hang from the ceiling" in problems
    assert "'wardrobe' (wardrobe) stands on the floor" in problems
    assert "'lamp' (pendant_lamp) hangs from the ceiling" in problems

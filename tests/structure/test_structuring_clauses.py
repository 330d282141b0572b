"""Per-unit clauses stay inside their unit; the verification pass fixes or reports what is wrong."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
from agent_solvers import solver_answer

from scenemosaic import demo_scene
from scenemosaic.agents import SceneState, run_agent
from scenemosaic.exceptions import AgentOutputError
from scenemosaic.models import FunctionModel, Message, RequestContext, RulesModel
from scenemosaic.scene import (
    FLOOR,
    AssetRef,
    ConstraintClause,
    CrossUnitConstraint,
    Pose,
    Relation,
    Room,
    Scene,
    SceneObject,
)
from scenemosaic.structure import ConstraintsAgent, VerificationAgent, structure_scene


def _box(oid: str, cat: str, size: tuple[float, float, float], pos: tuple[float, float, float],
         yaw: float = 0.0) -> SceneObject:
    return SceneObject(id=oid, category=cat, asset=AssetRef(kind="box", extents=size), pose=Pose.from_yaw(pos, yaw))


def _living_with_wall_tv() -> Scene:
    """Wall TV over a TV stand, a sofa facing both across a coffee table: every pair kind but seats/beds."""
    return Scene(id="tv_room", room=Room.rectangle(0, 0, 5, 4, ceiling_height=2.7), objects=[
        _box("tv", "television", (1.2, 0.08, 0.7), (2.5, 3.93, 1.2)),
        _box("tv_stand", "tv_stand", (1.6, 0.4, 0.5), (2.5, 3.78, 0.0)),
        _box("sofa", "multi_seat_sofa", (2.0, 0.9, 0.8), (2.5, 0.5, 0.0), math.pi),
        _box("table", "coffee_table", (1.0, 0.6, 0.45), (2.5, 1.6, 0.0)),
        _box("remote", "remote_control", (0.05, 0.15, 0.02), (2.4, 1.6, 0.45)),
    ])


_PAREN = re.compile(r"\(([^()]*)\)")


def _named_in_note(note: str, ids: set[str]) -> set[str]:
    return {t.strip() for g in _PAREN.findall(note) for t in g.split(",") if t.strip() in ids}


async def test_every_clause_names_only_its_own_unit(
    physcene_scenes: dict[str, Scene], procthor_dir: Path, sam3d_scene: Scene
) -> None:
    scenes = {**physcene_scenes, "demo": demo_scene(), "sam3d": sam3d_scene, "tv_room": _living_with_wall_tv()}
    kinds_seen: set[str] = set()
    object_clauses_with_children = 0
    for name, scene in scenes.items():
        out = await structure_scene(scene, priors_dir=procthor_dir)
        assert out.structure is not None
        ids = {o.id for o in out.objects}
        units = {u.anchor_id: u for u in out.structure.units}
        for c in out.constraints:
            kinds_seen.add(c.kind)
            for clause in (c.anchor_a, c.anchor_b):
                anchor = clause.anchor_id
                own = set(out.children_of(anchor)) | {anchor}
                where = f"{name}: {c.id} ({c.description}) @{anchor}"
                assert set(clause.related_objects) <= own, (
                    f"{where}: related {sorted(set(clause.related_objects) - own)} are not children of {anchor}"
                )
                foreign = _named_in_note(clause.layout_note, ids) - own
                assert not foreign, f"{where}: note {clause.layout_note!r} names {sorted(foreign)}"
                # the clause is listed in the unit it belongs to: its anchor's, or for an anchor that
                # carries nothing (a table nobody put anything on), the unit holding the anchor
                if anchor in units:
                    holder = units[anchor]
                    object_clauses_with_children += bool(clause.related_objects) and anchor in ids
                else:
                    assert clause.related_objects in ([], [anchor]), where
                    parent = out.support_of(anchor)
                    assert parent is not None, where
                    holder = units[parent.parent]
                    assert anchor in holder.children, where
                assert clause in holder.clauses, where
    # the check above is not vacuous: both kinds occur, and object anchors do carry named children
    assert kinds_seen == {"orientation", "placement"}
    assert object_clauses_with_children >= 2


def _scripted(replies: dict[str, Any]) -> FunctionModel:
    def reply(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None
        if context.agent in replies:
            return replies[context.agent]
        return solver_answer(messages, context)

    return FunctionModel(reply)


async def test_wall_tv_clauses_do_not_name_each_other(procthor_dir: Path) -> None:
    out = await structure_scene(_living_with_wall_tv(), priors_dir=procthor_dir)
    [tv] = [c for c in out.constraints if c.kind == "placement"]
    wall = next(cl for cl in (tv.anchor_a, tv.anchor_b) if cl.anchor_id.startswith("wall_"))
    floor = next(cl for cl in (tv.anchor_a, tv.anchor_b) if cl.anchor_id == FLOOR)
    assert wall.related_objects == ["tv"] and "(tv_stand)" not in wall.layout_note
    assert floor.related_objects == ["tv_stand"] and "(tv)" not in floor.layout_note


async def test_constraint_note_naming_another_units_object_is_rejected(
    sam3d_scene: Scene, procthor_dir: Path
) -> None:
    structured = await structure_scene(sam3d_scene, priors_dir=procthor_dir)
    state = SceneState(structured)
    bad = {"constraints": [{
        "id": "c0", "kind": "orientation", "description": "chair faces desk",
        "anchor_a": {"anchor_id": "floor", "related_objects": ["chair", "desk"], "layout_note": "(chair) faces (desk)"},
        # the desk clause lists only its own objects but its note steers the floor unit's chair
        "anchor_b": {"anchor_id": "desk", "related_objects": ["mug"], "layout_note": "pull (chair) under (desk)"},
    }]}
    with pytest.raises(AgentOutputError) as err:
        await run_agent(ConstraintsAgent(priors_dir=procthor_dir), state, _scripted({"constraints": bad}))
    assert any("layout note of 'desk' names (chair)" in p for p in err.value.problems), err.value.problems
    assert state.scene is structured  # nothing applied


# -- verification: fix or report -------------------------------------------------------------


async def test_verification_solver_breaks_a_parent_cycle() -> None:
    scene = Scene(
        room=Room.rectangle(0, 0, 4, 4),
        objects=[_box("a", "table", (1, 1, 0.7), (2, 2, 0)), _box("b", "table", (1, 1, 0.7), (2, 2, 0.7))],
        relations=[Relation(kind="attach", child="a", parent="b"), Relation(kind="attach", child="b", parent="a")],
    )
    state = SceneState(scene)
    out = (await run_agent(VerificationAgent(), state, RulesModel())).output
    assert [(f.object_id, f.parent) for f in out.fixes] == [("a", FLOOR)]  # the lower one stands on the floor
    assert state.scene.support_of("a").parent == FLOOR  # type: ignore[union-attr]
    assert state.scene.support_of("b").parent == "a"  # type: ignore[union-attr]
    assert state.scene.structure is not None
    assert [(u.anchor_id, u.children) for u in state.scene.structure.units] == [(FLOOR, ["a"]), ("a", ["b"])]
    assert any("broke a parent cycle" in n for n in state.scene.provenance.notes)


def _desk_scene_with(constraint: CrossUnitConstraint) -> Scene:
    return Scene(
        room=Room.rectangle(0, 0, 4, 4),
        objects=[
            _box("desk", "desk", (1.2, 0.6, 0.75), (2, 3, 0)),
            _box("mug", "mug", (0.08, 0.08, 0.1), (2, 3, 0.75)),
            _box("chair", "office_chair", (0.5, 0.5, 0.9), (2, 2.3, 0), math.pi),
        ],
        relations=[
            Relation(kind="attach", child="desk", parent=FLOOR),
            Relation(kind="attach", child="mug", parent="desk"),
            Relation(kind="attach", child="chair", parent=FLOOR),
        ],
        constraints=[constraint],
    )


@pytest.mark.parametrize(
    ("desk_clause", "culprit"),
    [
        (ConstraintClause(anchor_id="desk", related_objects=["chair"], layout_note="keep it"), "chair"),
        (ConstraintClause(anchor_id="desk", related_objects=["mug"], layout_note="turn (chair) to it"), "chair"),
    ],
)
async def test_verification_drops_and_reports_a_constraint_leaving_its_unit(
    desk_clause: ConstraintClause, culprit: str
) -> None:
    floor = ConstraintClause(anchor_id=FLOOR, related_objects=["chair", "desk"], layout_note="(chair) faces (desk)")
    scene = _desk_scene_with(
        CrossUnitConstraint(id="c7", kind="orientation", description="chair faces desk", anchor_a=floor,
                            anchor_b=desk_clause)
    )
    state = SceneState(scene)
    out = (await run_agent(VerificationAgent(), state, RulesModel())).output
    assert out.drop_constraints == ["c7"]
    assert state.scene.constraints == []
    note = next(n for n in state.scene.provenance.notes if "c7" in n)
    assert culprit in note and "not in the unit of desk" in note
    assert state.scene.structure is not None and all(not u.clauses for u in state.scene.structure.units)


async def test_verification_keeps_a_valid_constraint() -> None:
    floor = ConstraintClause(anchor_id=FLOOR, related_objects=["chair", "desk"], layout_note="(chair) faces (desk)")
    desk = ConstraintClause(anchor_id="desk", related_objects=["mug"], layout_note="(desk) is the reference")
    c = CrossUnitConstraint(id="c1", kind="orientation", description="d", anchor_a=floor, anchor_b=desk)
    state = SceneState(_desk_scene_with(c))
    out = (await run_agent(VerificationAgent(), state, RulesModel())).output
    assert out.drop_constraints == [] and out.fixes == []
    assert state.scene.constraints == [c]
    units = {u.anchor_id: u for u in state.scene.structure.units}  # type: ignore[union-attr]
    assert units["desk"].clauses == [desk] and units[FLOOR].clauses == [floor]


@pytest.mark.parametrize(
    ("reply", "needle"),
    [
        ({"fixes": [{"object_id": "ghost", "parent": "floor"}]}, "'ghost' does not exist"),
        ({"fixes": [{"object_id": "mug", "parent": "nowhere"}]}, "'nowhere' of 'mug' is not a valid anchor"),
        ({"drop_constraints": ["c99"]}, "'c99' does not exist"),
        ({"fixes": []}, "without a parent after the fixes: lamp"),
    ],
)
async def test_verification_rejects_hallucinated_ids(reply: dict[str, Any], needle: str) -> None:
    scene = Scene(
        room=Room.rectangle(0, 0, 4, 4),
        objects=[_box("table", "table", (1, 1, 0.7), (2, 2, 0)), _box("mug", "mug", (0.1, 0.1, 0.1), (2, 2, 0.7)),
                 _box("lamp", "pendant_lamp", (0.3, 0.3, 0.5), (1, 1, 2.2))],
        relations=[Relation(kind="attach", child="table", parent=FLOOR),
                   Relation(kind="attach", child="mug", parent="table")],
    )
    state = SceneState(scene)
    before = scene.to_json()
    with pytest.raises(AgentOutputError) as err:
        await run_agent(VerificationAgent(), state, _scripted({"verify": reply}))
    assert any(needle in p for p in err.value.problems), err.value.problems
    assert state.scene.to_json() == before and state.scene.structure is None

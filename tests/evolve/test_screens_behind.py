"""What faces can see (issue 53): no bed or sofa is left with its back to the screen it was grouped
with. ``scene.screens_behind`` finds them (a bed whose head stands on the TV's wall; a TV at the
bed's foot or on a side wall is not behind) and the rule patterns refuse a placement that makes one
(``evolve.screens_put_behind``); ``evaluate`` reports them in every row."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.evolve import rule_archetypes, screens_put_behind, unit_context, unit_obstacles
from scenemosaic.metrics import evaluate
from scenemosaic.physics import is_thin
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject, UnitLayout, screens_behind
from tests.conftest import PHYSCENE_DIR


def _piece(oid: str, category: str, extents: tuple[float, float, float], xy: tuple[float, float], yaw: float) -> SceneObject:
    return SceneObject(
        id=oid, category=category, asset=AssetRef(kind="procedural", extents=extents), pose=Pose.from_yaw((*xy, 0.0), yaw)
    )


def _bedroom(tv_xy: tuple[float, float], tv_yaw: float) -> Scene:
    """A 4 x 4 m room, a 1 m bed with its head against the south wall (its front, the foot, to the
    north), and a TV stand at ``tv_xy`` turned by ``tv_yaw`` (0: its front to the south)."""
    bed = _piece("bed", "bed", (1.0, 2.0, 0.6), (2.0, 1.0), math.pi)
    tv = _piece("tv", "tv_stand", (1.0, 0.4, 0.6), tv_xy, tv_yaw)
    return Scene(
        id="bedroom", room=Room.rectangle(0, 0, 4.0, 4.0), objects=[bed, tv],
        relations=[Relation(kind="attach", child=o.id, parent="floor") for o in (bed, tv)],
    )  # fmt: skip


def test_a_screen_on_the_wall_of_the_beds_head_is_behind_it_and_one_at_its_foot_is_not() -> None:
    assert screens_behind(_bedroom((3.1, 0.25), math.pi)) == [("bed", "tv")]  # beside the head, facing the room
    assert screens_behind(_bedroom((2.0, 3.75), 0.0)) == []  # at the foot, facing the bed
    assert screens_behind(_bedroom((3.75, 2.0), math.pi / 2)) == []  # on a side wall
    assert screens_behind(_bedroom((3.1, 0.25), 0.0)) == []  # its back to the bed too


@pytest.mark.asyncio
async def test_the_patterns_never_turn_a_beds_head_to_its_tv(tmp_path: Path) -> None:
    scene = (await agenerate(PHYSCENE_DIR / "Bedroom-11659_bedroom.json", tmp_path / "run", GenerateConfig(evolve=False))).scene
    assert scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    ctx = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), {o.id for o in scene.objects if is_thin(o)})
    layout = UnitLayout.from_scene(scene, unit, ctx.surface)
    assert ctx.screens_behind == []
    turned = layout.copy()
    turned.set_rotation("double_bed_0", layout.rotation("double_bed_0") + 180.0)  # degrees
    assert screens_put_behind(turned, ctx) == ["double_bed_0 turns its back on tv_stand_0"]
    candidates = rule_archetypes(layout, ctx)
    assert candidates
    for cand in candidates:
        placed = cand.place(layout, ctx)
        trial = layout.copy()
        for k, (u, v, r) in placed.items():
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        assert screens_put_behind(trial, ctx) == [], cand.layout_id


def test_evaluate_reports_screens_behind_for_rooms_and_houses() -> None:
    bad, good = _bedroom((3.1, 0.25), math.pi), _bedroom((2.0, 3.75), 0.0)
    report = evaluate(good, [bad])
    assert report["base"]["screens_behind"] == [] and report["variants"][0]["screens_behind"] == [["bed", "tv"]]

"""Collision, out-of-bounds, containment, wall/ceiling gravity and blow-up fallback on small scenes."""

from __future__ import annotations

import math

import pytest

from scenemosaic.physics import (
    COLLISION_TOLERANCE_M,
    SettleSettings,
    check_collisions,
    check_out_of_bounds,
    stabilize_scene,
    validate_scene,
)
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject


def _box(
    oid: str, size: tuple[float, float, float], pos: tuple[float, float, float], yaw: float = 0.0
) -> SceneObject:
    return SceneObject(
        id=oid,
        category=oid.rstrip("0123456789_"),
        asset=AssetRef(kind="box", extents=size),
        pose=Pose.from_yaw(pos, yaw),
    )


def _scene(objs: list[SceneObject], supports: dict[str, str]) -> Scene:
    rels = [Relation(kind="attach", child=c, parent=p) for c, p in supports.items()]
    return Scene(room=Room.rectangle(0, 0, 4, 4), objects=objs, relations=rels)


@pytest.mark.parametrize(("overlap", "counted"), [(0.03, True), (0.003, False)])
def test_collision_depth_and_tolerance(overlap: float, counted: bool) -> None:
    a = _box("a", (1.0, 1.0, 1.0), (1.0, 1.0, 0.0))
    b = _box("b", (1.0, 1.0, 1.0), (2.0 - overlap, 1.0, 0.0))
    report = check_collisions(_scene([a, b], {}))
    assert report.tolerance_m == COLLISION_TOLERANCE_M
    assert report.count == (1 if counted else 0)
    pair = (report.pairs or report.shallow)[0]
    assert pair.depth_m == pytest.approx(overlap, abs=1e-4)


def test_thin_objects_are_not_counted() -> None:
    rug = _box("rug", (2.0, 1.5, 0.01), (2.0, 2.0, 0.0))
    table = _box("table", (1.0, 1.0, 0.7), (2.0, 2.0, -0.005))
    report = check_collisions(_scene([rug, table], {}))
    assert report.count == 0 and report.thin_excluded == ["rug"]


def test_out_of_bounds_uses_the_99_percent_rule() -> None:
    half_out = _box("half", (1.0, 1.0, 1.0), (0.0, 2.0, 0.0))
    barely = _box("barely", (1.0, 1.0, 1.0), (0.504, 3.0, 0.0))  # 0.4 % outside
    desk = _box("desk", (1.0, 0.6, 0.75), (2.5, 2.0, 0.0))
    mug = _box("mug", (0.1, 0.1, 0.1), (3.0, 2.0, 0.75))  # half over the desk's edge
    report = check_out_of_bounds(_scene([half_out, barely, desk, mug], {"mug": "desk"}))
    found = {o.object_id: o for o in report.objects}
    assert set(found) == {"half", "mug"}
    assert found["half"].inside_fraction == pytest.approx(0.5, abs=1e-6)
    assert found["mug"].anchor_id == "desk"


async def test_containment_moves_children_inside_and_reports_oversize() -> None:
    desk = _box("desk", (1.0, 0.6, 0.75), (2.0, 2.0, 0.0))
    mug = _box("mug", (0.1, 0.1, 0.1), (2.52, 2.2, 0.80))  # over the edge, floating
    board = _box("board", (1.4, 0.2, 0.02), (2.0, 2.0, 0.75))  # wider than the desk
    scene = _scene([desk, mug, board], {"desk": "floor", "mug": "desk", "board": "desk"})
    fixed, report = await stabilize_scene(scene)
    unit = next(u for u in report.units if u.anchor_id == "desk")
    assert unit.containment_moves["mug"] == pytest.approx(0.072, abs=0.003)
    assert unit.larger_than_anchor == ["board"]
    mug_after = fixed.get("mug")
    assert mug_after.aabb()[1][0] <= 2.5 + 1e-6
    assert mug_after.pose.position[2] == pytest.approx(0.75, abs=0.005)


async def test_wall_and_ceiling_units_settle_toward_their_anchor() -> None:
    painting = _box("painting", (0.8, 0.05, 0.6), (2.0, 0.08, 1.5))  # 5.5 cm off the south wall (y = 0)
    lamp = _box("lamp", (0.3, 0.3, 0.5), (1.0, 1.0, 2.0))  # hangs 0.3 m under the ceiling
    scene = _scene([painting, lamp], {"painting": "wall_0", "lamp": "ceiling"})
    fixed, report = await stabilize_scene(scene)
    p = fixed.get("painting")
    assert p.aabb()[0][1] == pytest.approx(0.0, abs=0.005)
    assert p.pose.position[2] == pytest.approx(1.5, abs=0.005)  # wall gravity is horizontal: no drop
    assert fixed.get("lamp").aabb()[1][2] == pytest.approx(2.8, abs=0.005)
    assert {u.anchor_kind for u in report.units} == {"wall", "ceiling"}
    val = validate_scene(fixed)
    assert val.ok and val.support_gaps_m["painting"] == pytest.approx(0.0, abs=0.005)


async def test_blow_up_falls_back_and_rolls_back() -> None:
    a = _box("a", (0.5, 0.5, 0.5), (1.0, 1.0, 0.3))
    b = _box("b", (0.5, 0.5, 0.5), (1.3, 1.0, 0.1))  # overlapping a
    scene = _scene([a, b], {"a": "floor", "b": "floor"})
    fixed, report = await stabilize_scene(scene, settle=SettleSettings(blowup_speed_mps=1e-9))
    unit = report.units[0]
    assert unit.fallbacks[0].startswith("default: blow-up")
    assert unit.rolled_back == ["a", "b"] and not unit.converged
    # rolled back to the snapped, separated pose: on the floor and apart
    assert fixed.get("a").pose.position[2] == pytest.approx(0.0, abs=1e-9)
    assert check_collisions(fixed).count == 0
    assert math.isclose(fixed.get("a").pose.yaw, 0.0, abs_tol=1e-9)

"""Collision, out-of-bounds, containment, wall/ceiling gravity and blow-up fallback on small scenes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scenemosaic.physics import (
    COLLISION_TOLERANCE_M,
    SettleSettings,
    SimSettings,
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


def test_a_scene_checked_again_gets_the_same_report_and_a_moved_one_its_own() -> None:
    """Reports are kept by what decides them (a house's variants are checked at compose and again
    for their metrics): asking again answers the same, a caller's edits stay its own, and a move
    is a new question."""
    a = _box("a", (1.0, 1.0, 1.0), (1.0, 1.0, 0.0))
    b = _box("b", (1.0, 1.0, 1.0), (1.97, 1.0, 0.0))
    first = check_collisions(_scene([a, b], {}))
    assert first.count == 1
    first.pairs.clear()  # the caller's copy
    again = check_collisions(_scene([a, b], {}))
    assert again.count == 1 and again.pairs[0].depth_m == pytest.approx(0.03, abs=1e-4)
    apart = check_collisions(_scene([a, b.model_copy(update={"pose": Pose.from_yaw((2.2, 1.0, 0.0), 0.0)})], {}))
    assert apart.count == 0 and not apart.shallow
    looser = check_collisions(_scene([a, b], {}), tolerance_m=0.05)
    assert looser.count == 0 and len(looser.shallow) == 1


def test_the_metrics_check_of_a_validated_scene_reuses_the_validations_measure(monkeypatch: pytest.MonkeyPatch) -> None:
    """A run validates its scene and then measures COL on the same poses: the collisions are
    measured once, and each caller gets a copy of its own; hull pieces given for one call are
    measured for that call only."""
    import scenemosaic.physics._checks as checks

    measured: list[int] = []
    measure = checks.collision_report_for

    def counting(*args: object, **kwargs: object) -> object:
        measured.append(1)
        return measure(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(checks, "collision_report_for", counting)
    a = _box("a", (1.0, 1.0, 1.0), (1.0, 1.0, 0.0))
    b = _box("b", (1.0, 1.0, 1.0), (1.9613, 1.0, 0.0))  # a pose no other test asks about
    scene = _scene([a, b], {})
    validated = validate_scene(scene)
    assert validated.collisions.count == 1 and len(measured) == 1
    validated.collisions.pairs.clear()  # the validation's copy
    col = check_collisions(scene)
    assert len(measured) == 1, "measured again"
    assert col.count == 1 and col.pairs[0].depth_m == pytest.approx(1.0 - 0.9613, abs=1e-4)
    cube = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (0.0, 1.0)])
    check_collisions(scene, hulls={"a": [cube], "b": [cube]})
    assert len(measured) == 2  # given pieces: nothing shared

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


async def test_blow_up_falls_back_and_rolls_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo logs unstable states to ./MUJOCO_LOG.TXT
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


@pytest.mark.parametrize(("overlap", "counted"), [(0.006, True), (0.004, False)])
def test_tolerance_boundary_is_five_millimetres(overlap: float, counted: bool) -> None:
    """Just either side of 5 mm: a pair counts only when it would still intersect after a 5 mm move."""
    a = _box("a", (0.6, 0.6, 0.8), (1.0, 1.0, 0.0))
    b = _box("b", (0.6, 0.6, 0.8), (1.6 - overlap, 1.0, 0.0))
    report = check_collisions(_scene([a, b], {}))
    assert report.count == (1 if counted else 0)
    assert [p.depth_m for p in report.pairs + report.shallow] == [pytest.approx(overlap, abs=1e-4)]
    moved_apart = _box("b", (0.6, 0.6, 0.8), (1.6 - overlap + COLLISION_TOLERANCE_M, 1.0, 0.0))
    assert check_collisions(_scene([a, moved_apart], {})).count == 0


def test_flat_but_not_thin_objects_are_counted() -> None:
    """Thinness is relative: a 10 cm slab of 1 m is not a rug and its overlaps count."""
    slab = _box("slab", (1.0, 1.0, 0.1), (2.0, 2.0, 0.0))
    table = _box("table", (1.0, 1.0, 0.7), (2.0, 2.0, 0.05))
    report = check_collisions(_scene([slab, table], {}))
    assert report.thin_excluded == [] and report.count == 1
    assert report.pairs[0].depth_m == pytest.approx(0.05, abs=1e-4)


def test_out_of_bounds_boundary_just_under_99_percent() -> None:
    """1.5 % of the footprint outside the floor is out of bounds; 0.5 % is not."""
    out = _box("out", (1.0, 1.0, 1.0), (0.485, 1.0, 0.0))
    kept = _box("kept", (1.0, 1.0, 1.0), (0.495, 3.0, 0.0))
    report = check_out_of_bounds(_scene([out, kept], {}))
    assert [o.object_id for o in report.objects] == ["out"]
    assert report.objects[0].inside_fraction == pytest.approx(0.985, abs=1e-6)
    assert report.checked_objects == 2


@pytest.mark.parametrize(
    ("wall", "pos", "axis", "face"),
    [
        ("wall_0", (2.0, 0.10, 1.5), 1, 0.0),  # south wall, y = 0: gravity -y
        ("wall_1", (3.90, 2.0, 1.5), 0, 4.0),  # east wall, x = 4: gravity +x
        ("wall_2", (2.0, 3.90, 1.5), 1, 4.0),  # north wall, y = 4: gravity +y
        ("wall_3", (0.10, 2.0, 1.5), 0, 0.0),  # west wall, x = 0: gravity -x
    ],
)
async def test_wall_gravity_points_into_each_wall(
    wall: str, pos: tuple[float, float, float], axis: int, face: float
) -> None:
    """A frame hung 7-8 cm off any of the four walls ends flat against that wall, at its height."""
    yaw = {"wall_0": 0.0, "wall_1": math.pi / 2, "wall_2": math.pi, "wall_3": -math.pi / 2}[wall]
    frame = _box("frame", (0.6, 0.05, 0.4), pos, yaw)
    fixed, report = await stabilize_scene(_scene([frame], {"frame": wall}))
    lo, hi = fixed.get("frame").aabb()
    touching = lo[axis] if face == 0.0 else hi[axis]
    assert touching == pytest.approx(face, abs=0.005)
    assert fixed.get("frame").pose.position[2] == pytest.approx(1.5, abs=0.005)
    assert report.units[0].anchor_kind == "wall" and report.units[0].rolled_back == []
    assert validate_scene(fixed).support_gaps_m["frame"] == pytest.approx(0.0, abs=0.005)


async def test_ceiling_gravity_is_up_even_from_the_floor() -> None:
    """A hanging lamp placed on the floor rises to the ceiling (gravity up), not stays down."""
    lamp = _box("lamp", (0.3, 0.3, 0.4), (2.0, 2.0, 0.0))
    fixed, report = await stabilize_scene(_scene([lamp], {"lamp": "ceiling"}))
    assert fixed.get("lamp").aabb()[1][2] == pytest.approx(2.8, abs=0.005)
    assert report.units[0].anchor_kind == "ceiling"


def test_non_finite_state_is_a_blow_up(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo logs unstable states to ./MUJOCO_LOG.TXT
    """NaN velocities in the simulator end the run and name the body, instead of propagating."""
    from scenemosaic.physics._hulls import object_shape
    from scenemosaic.physics._simulate import run_until_settled
    from scenemosaic.physics._world import WorldBuilder

    objs = [_box("a", (0.5, 0.5, 0.5), (1.0, 1.0, 0.0)), _box("b", (0.5, 0.5, 0.5), (3.0, 3.0, 0.0))]
    builder = WorldBuilder(SimSettings())
    builder.add_room(_scene(objs, {}).room)
    for o in objs:
        builder.add_dynamic(o, object_shape(o), mode="free")
    world = builder.compile()
    body_b = next(b for b in world.bodies if b.object_id == "b")
    world.data.qvel[body_b.dof_slice] = float("nan")
    outcome = run_until_settled(world, SettleSettings())
    assert outcome.blown_up == ["b"] and not outcome.converged


async def test_blow_up_recovers_with_the_smaller_step(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo logs unstable states to ./MUJOCO_LOG.TXT
    """The first fallback is really used: a blow-up at the default step is settled at half the step."""
    import scenemosaic.physics._settle as settle_mod

    real = settle_mod.run_until_settled
    timesteps: list[float] = []

    def blows_up_at_default_step(world, settle):  # type: ignore[no-untyped-def]
        timesteps.append(float(world.model.opt.timestep))
        outcome = real(world, settle)
        if world.model.opt.timestep == SimSettings().timestep:
            outcome.blown_up = ["a"]
        return outcome

    monkeypatch.setattr(settle_mod, "run_until_settled", blows_up_at_default_step)
    a = _box("a", (0.5, 0.5, 0.5), (1.0, 1.0, 0.04))  # floating 4 cm
    fixed, report = await stabilize_scene(_scene([a], {"a": "floor"}))
    unit = report.units[0]
    assert timesteps == [SimSettings().timestep, SimSettings().timestep / 2]
    assert unit.fallbacks == ["default: blow-up of ['a']"]
    assert unit.rolled_back == [] and unit.converged
    assert fixed.get("a").pose.position[2] == pytest.approx(0.0, abs=0.005)


@pytest.mark.parametrize("field", ["position", "quaternion"])
async def test_nan_pose_is_a_physics_error_naming_the_object(field: str) -> None:
    """Bad input loses nothing: a NaN pose (possible through model_copy) is refused up front, the input
    scene is untouched, and every entry point names the object instead of failing inside GEOS/MuJoCo."""
    from scenemosaic.exceptions import PhysicsError
    from scenemosaic.physics import support_gaps
    from scenemosaic.physics._hulls import object_shape

    good = _box("good", (0.5, 0.5, 0.5), (1.0, 1.0, 0.0))
    bad = _box("bad", (0.5, 0.5, 0.5), (3.0, 3.0, 0.0))
    value = (math.nan, 3.0, 0.0) if field == "position" else (math.nan, 0.0, 0.0, 1.0)
    bad.pose = bad.pose.model_copy(update={field: value})
    scene = _scene([good, bad], {"good": "floor", "bad": "floor"})
    before = scene.model_dump_json()
    with pytest.raises(PhysicsError, match="bad") as info:
        await stabilize_scene(scene)
    assert info.value.object_ids == ["bad"]
    assert scene.model_dump_json() == before
    for check in (check_collisions, check_out_of_bounds, validate_scene):
        with pytest.raises(PhysicsError) as info:
            check(scene)
        assert info.value.object_ids == ["bad"]
    with pytest.raises(PhysicsError):
        support_gaps(scene, {o.id: object_shape(o) for o in scene.objects})


def test_across_counts_only_the_pairs_between_the_two_sides() -> None:
    """``collision_report_for(..., across=)`` (compose's check of two groups against each other)
    reports the same pairs as the full check, less those with both objects on one side."""
    from scenemosaic.physics import collision_report_for, object_shape

    a1 = _box("a1", (1.0, 1.0, 1.0), (1.0, 1.0, 0.0))
    a2 = _box("a2", (1.0, 1.0, 1.0), (1.95, 1.0, 0.0))  # into a1: one side
    b1 = _box("b1", (1.0, 1.0, 1.0), (2.9, 1.0, 0.0))  # into a2: across
    b2 = _box("b2", (0.5, 0.5, 0.5), (1.0, 3.0, 0.0))  # apart from all
    scene = _scene([a1, a2, b1, b2], {})
    shapes = {o.id: object_shape(o) for o in scene.objects}
    full = {(p.a, p.b) for p in collision_report_for(scene, shapes).pairs}
    assert full == {("a1", "a2"), ("a2", "b1")}
    assert [(p.a, p.b) for p in collision_report_for(scene, shapes, across={"a1", "a2"}).pairs] == [("a2", "b1")]
    assert collision_report_for(scene, shapes, across={"b2"}).pairs == []

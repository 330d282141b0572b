"""Final validation of a whole scene: checks plus one short gravity run of every unit together."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import overload

import mujoco
import numpy as np
import structlog

from scenemosaic.assets import (
    HullCache,
    object_mesh_arrays,
    object_part_arrays,
    part_openings,
    with_room_doors,
)
from scenemosaic.physics._checks import (
    check_out_of_bounds,
    collision_report_for,
    nested_furniture,
    require_finite_poses,
    shared_collision_report,
)
from scenemosaic.physics._hulls import HullInput, ObjectShape, object_shape
from scenemosaic.physics._reports import ObjectMotion, ValidationReport
from scenemosaic.physics._settings import (
    FELL_DROP_M,
    PART_DRIFT_DEG,
    PART_DRIFT_M,
    TIPPED_TILT_DEG,
    SettleSettings,
    SimSettings,
)
from scenemosaic.physics._simulate import run_until_settled
from scenemosaic.physics._world import WorldBuilder, house_slabs
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    House,
    Pose,
    Scene,
    SceneObject,
    quat_multiply,
    quat_to_matrix,
    yaw_from_quat,
)

__all__ = [
    "house_world",
    "is_fixed",
    "motion_between",
    "scene_world",
    "support_gaps",
    "validate_scene",
    "write_house_mjcf",
    "write_scene_mjcf",
]

log = structlog.get_logger(__name__)

_VALIDATION_SETTLE = SettleSettings(max_time_s=1.0)
_VALIDATION_MIN_S = 0.3
_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)


def scene_world(
    scene: Scene, shapes: Mapping[str, ObjectShape], sim: SimSettings | None = None
) -> WorldBuilder:
    """The whole scene as one MuJoCo world with gravity down: the room static, objects hung from
    the ceiling or a wall and ``static`` ones welded, every other object on a free joint; the
    drawers, doors and lids of furniture that opens each on its own joint, where the scene's
    metadata delivers them (closed unless ``--open-state`` says otherwise).

    Validation simulates this world and the MJCF export writes it (:func:`write_scene_mjcf`).
    """
    builder = WorldBuilder(sim or SimSettings(), gravity_dir=(0.0, 0.0, -1.0), articulated=True)
    builder.add_room(scene.room)
    _add_objects(builder, scene, shapes)
    return builder


def _add_objects(builder: WorldBuilder, scene: Scene, shapes: Mapping[str, ObjectShape]) -> None:
    """Every object of ``scene``: welded when :func:`is_fixed`, else on a free joint; its parts
    at the pose the scene's metadata delivers them in (:func:`~scenemosaic.assets.part_openings`)."""
    builder.openings.update(part_openings(scene))
    for o in scene.objects:
        if is_fixed(scene, o):
            builder.add_static(o, shapes[o.id])
        else:
            builder.add_dynamic(o, shapes[o.id], mode="free")


def house_world(
    house: House, shapes: Mapping[str, ObjectShape], sim: SimSettings | None = None
) -> WorldBuilder:
    """A whole house as one MuJoCo world with gravity down: the static boxes of
    :func:`~scenemosaic.physics.house_slabs` (one floor, every room's walls cut around their
    openings with shared walls once, each room's ceiling over its own floor), and every object of
    every room placed as :func:`scene_world` places it in its own room (:func:`is_fixed` asked of
    that room's scene), its movable parts on their joints."""
    builder = WorldBuilder(sim or SimSettings(), gravity_dir=(0.0, 0.0, -1.0), articulated=True)
    builder.add_slabs(house_slabs(house))
    for scene in house.rooms:
        _add_objects(builder, scene, shapes)
    return builder


def _write_world(
    builder: WorldBuilder,
    objects: list[SceneObject],
    base_dir: str | Path | None,
    out_dir: str | Path,
    name: str,
) -> Path:
    """Add each object's visual mesh to ``builder`` (split by movable part for an object whose
    parts have their own bodies) and write its MJCF under ``out_dir``."""
    for obj in objects:
        try:  # the meshes as arrays made once per asset (a house's variants share their furniture)
            if builder.part_names(obj.id):
                meshes = object_part_arrays(obj, base_dir)
            else:
                meshes = {None: object_mesh_arrays(obj, base_dir)}
        except Exception as exc:  # the visual is optional: the collision pieces still describe the object
            log.warning("mjcf_visual_mesh_failed", object_id=obj.id, error=str(exc))
            continue
        for part, (vertices, faces) in meshes.items():
            builder.add_visual(obj, vertices, faces, part=part)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = builder.write_mjcf(out, model_name=name)
    log.info("mjcf_exported", path=str(path), objects=len(objects))
    return path


def write_scene_mjcf(
    scene: Scene,
    out_dir: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    sim: SimSettings | None = None,
) -> Path:
    """Write ``out_dir/scene.xml`` + ``out_dir/mjcf/`` for plain MuJoCo: :func:`scene_world` (the
    world validation simulates) plus each object's visual mesh as a non-colliding geom (group 2;
    collision pieces are group 3). Paths are relative. Raises
    :class:`~scenemosaic.exceptions.PhysicsError` naming any object whose pose is not finite.
    """
    require_finite_poses(scene, "export MJCF")
    shapes = {o.id: object_shape(o, base_dir, cache=hull_cache, hulls=hulls) for o in scene.objects}
    return _write_world(scene_world(scene, shapes, sim), list(scene.objects), base_dir, out_dir, scene.id)


def write_house_mjcf(
    house: House,
    out_dir: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    sim: SimSettings | None = None,
) -> Path:
    """Write a whole house as ``out_dir/scene.xml`` + ``out_dir/mjcf/`` for plain MuJoCo.

    The world is :func:`house_world`; every object carries its visual mesh as
    :func:`write_scene_mjcf` gives it. Bodies are named by object id; the static boxes by
    ``floor``, ``<room id>/<wall id>[/<k>]`` and ``<room id>/ceiling[/<k>]``. ``base_dir``
    resolves every room's relative mesh uris. Raises
    :class:`~scenemosaic.exceptions.PhysicsError` naming any object whose pose is not finite.
    """
    for scene in house.rooms:
        require_finite_poses(scene, "export MJCF")
    objects = house.objects
    shapes = {o.id: object_shape(o, base_dir, cache=hull_cache, hulls=hulls) for o in objects}
    return _write_world(house_world(house, shapes, sim), objects, base_dir, out_dir, house.id)


def is_fixed(scene: Scene, obj: SceneObject) -> bool:
    """Objects held in place in whole-scene simulation: static ones, and those hung from the ceiling or a wall."""
    if obj.sim.static:
        return True
    rel = scene.support_of(obj.id)
    if rel is None:
        return False
    return rel.parent == CEILING or scene.anchor_kind(rel.parent) == "wall"


def motion_between(object_id: str, before: Pose, after: Pose) -> ObjectMotion:
    """Displacement, yaw change and tilt between two poses of one object."""
    disp = float(np.linalg.norm(np.subtract(after.position, before.position)))
    dyaw = (yaw_from_quat(after.quaternion) - yaw_from_quat(before.quaternion) + math.pi) % (
        2 * math.pi
    ) - math.pi
    up_before = quat_to_matrix(before.quaternion)[:, 2]
    up_after = quat_to_matrix(after.quaternion)[:, 2]
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(up_before @ up_after)))))
    return ObjectMotion(
        object_id=object_id,
        displacement_m=round(disp, 6),
        yaw_change_deg=round(abs(math.degrees(dyaw)), 4),
        tilt_deg=round(tilt, 4),
    )


def support_gaps(scene: Scene, shapes: Mapping[str, ObjectShape]) -> dict[str, float]:
    """Per object, the distance to its support along gravity (negative = sunk in), metres.

    Floor: lowest hull point above z = 0. Ceiling: ceiling height minus the highest point.
    Wall: distance of the hull from the wall's inner face. Object: signed hull distance to the anchor.
    """
    require_finite_poses(scene, "measure support gaps")
    gaps: dict[str, float] = {}
    builder = WorldBuilder(SimSettings())
    for o in scene.objects:
        builder.add_static(o, shapes[o.id])
    world = builder.compile()
    room = scene.room
    for o in scene.objects:
        rel = scene.support_of(o.id)
        anchor = rel.parent if rel is not None else FLOOR
        verts = np.concatenate(shapes[o.id].world_vertices(o.pose.matrix(with_scale=False)))
        if anchor == FLOOR:
            gap = float(verts[:, 2].min())
        elif anchor == CEILING:
            height = room.ceiling_height if room is not None else 2.8
            gap = height - float(verts[:, 2].max())
        elif scene.anchor_kind(anchor) == "wall":
            assert room is not None
            w = room.wall(anchor)
            n = np.array([w.inward_normal[0], w.inward_normal[1], 0.0])
            start = np.array([w.start[0], w.start[1], 0.0])
            gap = float((verts @ n).min() - start @ n)
        else:
            gap = min(
                float(mujoco.mj_geomDistance(world.model, world.data, ga, gb, 1.0, None))
                for ga in world.object_geoms[o.id]
                for gb in world.object_geoms[anchor]
            )
        gaps[o.id] = round(gap, 6)
    return gaps


def _static_report(scene: Scene, shapes: Mapping[str, ObjectShape], *, shared: bool) -> ValidationReport:
    """What one scene's poses say before anything moves: collisions, out of bounds, support gaps,
    nested furniture. ``shared``: the shapes are :func:`object_shape`'s own (no ``hulls`` given),
    so the collisions are measured once for these poses (``shared_collision_report``: a run's
    metrics ask for the same report)."""
    return ValidationReport(
        collisions=shared_collision_report(scene, shapes) if shared else collision_report_for(scene, shapes),
        out_of_bounds=check_out_of_bounds(scene, shapes=shapes),
        support_gaps_m=support_gaps(scene, shapes) if scene.objects else {},
        nested=nested_furniture(scene),
    )


@dataclass
class _Settled:
    """How a world's objects moved when it settled under gravity."""

    motions: dict[str, ObjectMotion] = field(default_factory=dict)
    tipped: set[str] = field(default_factory=set)
    fell: set[str] = field(default_factory=set)
    simulated_s: float = 0.0
    parts_moved: dict[str, float] = field(default_factory=dict)
    """Joint name (``<object id>/<part>``) -> how far it moved (degrees or metres), past the drift allowed."""


def _settle_world(builder: WorldBuilder, objects: Mapping[str, SceneObject]) -> _Settled:
    """Run ``builder``'s world under gravity until it settles; how each of ``objects`` moved."""
    world = builder.compile()
    outcome = run_until_settled(world, _VALIDATION_SETTLE, min_time_s=_VALIDATION_MIN_S)
    settled = _Settled(simulated_s=round(outcome.simulated_s, 6))
    for wb in world.bodies:
        before = objects[wb.object_id].pose
        pos = world.data.xpos[wb.body_id]
        quat = tuple(float(v) for v in world.data.xquat[wb.body_id])
        if not all(math.isfinite(v) for v in (*pos, *quat)):
            settled.fell.add(wb.object_id)
            continue
        after = Pose(
            position=(float(pos[0]), float(pos[1]), float(pos[2])),
            quaternion=quat_multiply(quat, (1.0, 0.0, 0.0, 0.0)),
            scale=before.scale,
        )
        mot = motion_between(wb.object_id, before, after)
        settled.motions[wb.object_id] = mot
        if mot.tilt_deg > TIPPED_TILT_DEG:
            settled.tipped.add(wb.object_id)
        if before.position[2] - after.position[2] > FELL_DROP_M:
            settled.fell.add(wb.object_id)
    settled.fell.update(outcome.blown_up)
    model, data = world.model, world.data
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if "/" not in model.joint(j).name or kind not in (_HINGE, _SLIDE):
            continue
        adr = int(model.jnt_qposadr[j])
        drift = abs(float(data.qpos[adr]) - float(model.qpos0[adr]))
        moved = math.degrees(drift) if kind == _HINGE else drift
        if not math.isfinite(moved) or moved > (PART_DRIFT_DEG if kind == _HINGE else PART_DRIFT_M):
            settled.parts_moved[model.joint(j).name] = round(moved, 4) if math.isfinite(moved) else math.inf
    return settled


def _with_motion(static: ValidationReport, scene: Scene, settled: _Settled) -> ValidationReport:
    """``static`` completed with how ``scene``'s objects moved in a settled world (in the
    scene's object order; an object that blew up counts as fallen), and which of its parts (its
    room doors' leaves among them: ``scene`` as :func:`~scenemosaic.assets.with_room_doors`
    hangs them) moved from where they are delivered."""
    ids = [o.id for o in scene.objects]
    motions = [settled.motions[i] for i in ids if i in settled.motions]
    mine = set(ids)
    return static.model_copy(
        update={
            "tipped": [i for i in ids if i in settled.tipped],
            "fell": [i for i in ids if i in settled.fell],
            "motions": motions,
            "max_displacement_m": max((m.displacement_m for m in motions), default=0.0),
            "simulated_s": settled.simulated_s,
            "parts_moved": {k: v for k, v in settled.parts_moved.items() if k.rsplit("/", 1)[0] in mine},
        }
    )


@overload
def validate_scene(
    scene: Scene, base_dir: str | Path | None = None, *, hull_cache: HullCache | None = None,
    hulls: HullInput | None = None, sim: SimSettings | None = None,
) -> ValidationReport: ...


@overload
def validate_scene(
    scene: House, base_dir: str | Path | None = None, *, hull_cache: HullCache | None = None,
    hulls: HullInput | None = None, sim: SimSettings | None = None,
) -> dict[str, ValidationReport]: ...


def validate_scene(
    scene: Scene | House,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    sim: SimSettings | None = None,
) -> ValidationReport | dict[str, ValidationReport]:
    """Check a composed scene, or a whole house, as it is delivered.

    Counts residual collisions (above ``COLLISION_TOLERANCE_M``) and out-of-bounds objects on the
    given poses, measures each object's gap to its support, then simulates every unit together
    with gravity down (ceiling and wall objects and ``static`` ones held fixed, the rest on free
    joints) and reports displacement, objects that tipped (tilt above ``TIPPED_TILT_DEG``) and
    objects that fell (dropped more than ``FELL_DROP_M``). A :class:`~scenemosaic.scene.House` is
    checked room by room on its poses and settled once as the whole world ``scene.xml`` holds
    (:func:`house_world`); its result is each room's report by room id. Raises
    :class:`~scenemosaic.exceptions.PhysicsError` naming any object with a non-finite pose.
    """
    if isinstance(scene, House):
        return _validate_house(scene, base_dir, hull_cache=hull_cache, hulls=hulls, sim=sim)
    require_finite_poses(scene, "validate the scene")
    hung = with_room_doors(scene)  # the world as the simulator exports deliver it, its doors hung
    assert isinstance(hung, Scene)
    shapes = {o.id: object_shape(o, base_dir, cache=hull_cache, hulls=hulls) for o in hung.objects}
    static = _static_report(scene, {o.id: shapes[o.id] for o in scene.objects}, shared=hulls is None)
    settled = _settle_world(scene_world(hung, shapes, sim), {o.id: o for o in hung.objects})
    return _with_motion(static, hung, settled)


def _validate_house(
    house: House,
    base_dir: str | Path | None,
    *,
    hull_cache: HullCache | None,
    hulls: HullInput | None,
    sim: SimSettings | None,
) -> dict[str, ValidationReport]:
    """:func:`validate_scene` of a whole house: each room's report by room id."""
    for scene in house.rooms:
        require_finite_poses(scene, "validate the house")
    hung = with_room_doors(house)  # the world as the simulator exports deliver it, its doors hung
    assert isinstance(hung, House)
    shapes = {o.id: object_shape(o, base_dir, cache=hull_cache, hulls=hulls) for o in hung.objects}
    settled = _settle_world(house_world(hung, shapes, sim), {o.id: o for o in hung.objects})
    return {
        scene.id: _with_motion(_static_report(scene, {o.id: shapes[o.id] for o in scene.objects}, shared=hulls is None), with_doors, settled)
        for scene, with_doors in zip(house.rooms, hung.rooms, strict=True)
    }

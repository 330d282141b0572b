"""Collision and out-of-bounds checks, counted the way SceneEval counts them."""

from __future__ import annotations

from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from shapely.geometry import Polygon

from scenemosaic._memo import Memo
from scenemosaic.assets import HullCache
from scenemosaic.exceptions import PhysicsError
from scenemosaic.physics._hulls import HullInput, ObjectShape, object_shape
from scenemosaic.physics._reports import CollisionPair, CollisionReport, OutOfBoundsObject, OutOfBoundsReport
from scenemosaic.physics._settings import COLLISION_TOLERANCE_M, OOB_MIN_INSIDE_FRACTION, SimSettings
from scenemosaic.physics._world import WorldBuilder
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    FloatArray,
    Scene,
    SceneObject,
    convex_hull_2d,
    is_thin,
    nested_pairs,
)

__all__ = [
    "RESTING_MIN_INSIDE_FRACTION",
    "check_collisions",
    "check_out_of_bounds",
    "collision_report_for",
    "nested_furniture",
    "require_finite_poses",
    "resting_footprint",
    "rests_within",
    "shared_collision_report",
    "support_polygon",
]


def require_finite_poses(scene: Scene, action: str) -> None:
    """Raise :class:`PhysicsError` naming every object whose pose or size is not finite.

    Scene models validate poses on construction, but ``model_copy(update=...)`` and
    ``model_construct`` skip validation, and a NaN fed to the geometry and the simulator
    fails deep inside them (GEOS, MuJoCo) or, worse, silently counts as "no collision".
    Checking up front turns such input into one clear error that names the objects; the
    caller's scene is never modified, so nothing computed before is lost.
    """
    bad = [
        o.id
        for o in scene.objects
        if not (
            np.all(np.isfinite(o.pose.position))
            and np.all(np.isfinite(o.pose.quaternion))
            and np.all(np.isfinite(o.pose.scale))
            and np.all(np.isfinite(o.size))
        )
    ]
    if bad:
        raise PhysicsError(
            f"cannot {action}: non-finite pose or size (NaN or inf) for {', '.join(bad)}", object_ids=bad
        )


def collision_report_for(
    scene: Scene,
    shapes: Mapping[str, ObjectShape],
    *,
    tolerance_m: float = COLLISION_TOLERANCE_M,
    across: Collection[str] | None = None,
) -> CollisionReport:
    """Pairwise hull penetration of every non-thin object pair whose bounds overlap (only the
    objects of such pairs go into the MuJoCo world that measures it); with ``across``, only the
    pairs with one object in it and the other not (two groups' pieces against each other: a
    world is built only when two of them come near)."""
    objs = [o for o in scene.objects]
    thin = [o.id for o in objs if is_thin(o)]
    solid = [o for o in objs if o.id not in thin]
    report = CollisionReport(tolerance_m=tolerance_m, thin_excluded=thin, checked_objects=len(solid))
    if len(solid) < 2:
        return report
    # per-geom world AABBs from the hull vertices, for a cheap broad phase
    boxes: dict[str, tuple[FloatArray, FloatArray]] = {}
    for o in solid:
        mat = o.pose.matrix(with_scale=False)
        verts = shapes[o.id].world_vertices(mat)
        boxes[o.id] = (np.stack([v.min(axis=0) for v in verts]), np.stack([v.max(axis=0) for v in verts]))
    reach = tolerance_m + 0.002
    lo = np.stack([boxes[o.id][0].min(axis=0) for o in solid])
    hi = np.stack([boxes[o.id][1].max(axis=0) for o in solid])
    # every pair's boxes at once (the same comparisons a pair-by-pair loop makes), in (i, j > i) order
    close = ~((lo[:, None, :] > hi[None, :, :] + reach).any(axis=2) | (lo[None, :, :] > hi[:, None, :] + reach).any(axis=2))
    if across is not None:
        side = np.array([o.id in across for o in solid])
        close &= side[:, None] != side[None, :]
    near = [(solid[i], solid[j]) for i, j in zip(*np.nonzero(np.triu(close, k=1)), strict=True)]
    if not near:
        return report
    builder = WorldBuilder(SimSettings(), gravity_dir=(0.0, 0.0, -1.0))
    involved = {o.id for pair in near for o in pair}
    for o in solid:
        if o.id in involved:
            builder.add_static(o, shapes[o.id])
    world = builder.compile()
    m, d = world.model, world.data
    geoms = world.object_geoms
    for a, b in near:
        deepest: float | None = None
        contacts = 0
        (alo, ahi), (blo, bhi) = boxes[a.id], boxes[b.id]
        apart = (alo[:, None, :] > bhi[None, :, :] + reach).any(axis=2) | (blo[None, :, :] > ahi[:, None, :] + reach).any(axis=2)
        for ia, ib in zip(*np.nonzero(~apart), strict=True):
            dist = float(mujoco.mj_geomDistance(m, d, geoms[a.id][ia], geoms[b.id][ib], reach, None))
            if dist < 0:
                contacts += 1
            if dist < reach and (deepest is None or -dist > deepest):
                deepest = -dist
        if deepest is None or deepest < 0:
            continue
        pair = CollisionPair(a=a.id, b=b.id, depth_m=round(deepest, 6), contacts=contacts)
        (report.pairs if deepest > tolerance_m else report.shallow).append(pair)
    return report


def check_collisions(
    scene: Scene,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    tolerance_m: float = COLLISION_TOLERANCE_M,
) -> CollisionReport:
    """Object pairs whose convex hulls interpenetrate deeper than ``tolerance_m`` (default 5 mm).

    Depth is the largest penetration over all hull-piece pairs (MuJoCo's signed geom distance).
    Thin objects (rugs, paper) are excluded, as in the method. Touching pairs at or under the
    tolerance are listed separately in ``shallow``. Raises :class:`PhysicsError` for a
    non-finite pose.
    """
    require_finite_poses(scene, "check collisions")
    shapes = {o.id: object_shape(o, base_dir, cache=hull_cache, hulls=hulls) for o in scene.objects}
    if hulls is not None:  # pieces given for this call: nothing to share
        return collision_report_for(scene, shapes, tolerance_m=tolerance_m)
    return shared_collision_report(scene, shapes, tolerance_m=tolerance_m)


def shared_collision_report(
    scene: Scene, shapes: Mapping[str, ObjectShape], *, tolerance_m: float = COLLISION_TOLERANCE_M
) -> CollisionReport:
    """:func:`collision_report_for` of ``scene`` measured once per set of poses, shapes and
    tolerance (a copy of it each call). ``shapes`` must come from :func:`object_shape` without
    ``hulls`` (its memo's frozen, shared shapes: the memo entry holds them, so their ids stay
    theirs and name them): a house run checks each variant's rooms at compose and again for its
    metrics, and a run's validation measures the base's rooms that its metrics measure again."""
    key = (tolerance_m, tuple((o.id, id(shapes[o.id]), is_thin(o), o.pose.position, o.pose.quaternion) for o in scene.objects))
    report, _ = _REPORTS.get(key, lambda: (collision_report_for(scene, shapes, tolerance_m=tolerance_m), tuple(shapes.values())))
    return report.model_copy(deep=True)


_REPORTS: Memo[tuple[Any, ...], tuple[CollisionReport, tuple[ObjectShape, ...]]] = Memo(512)
"""Collision reports by what decides them (each object's id, shape, thinness and pose, the
tolerance), with the shapes they were measured on (:func:`shared_collision_report`)."""


def _footprint(obj: SceneObject) -> Polygon:
    return Polygon(convex_hull_2d(obj.corners()[:, :2]))


def support_polygon(scene: Scene, anchor_id: str) -> Polygon | None:
    """The surface an anchor offers its children, seen along gravity (XY; wall: along-wall, height)."""
    room = scene.room
    if anchor_id in (FLOOR, CEILING):
        return Polygon(room.floor) if room is not None else None
    kind = scene.anchor_kind(anchor_id)
    if kind == "wall":
        assert room is not None
        w = room.wall(anchor_id)
        u0 = float(np.dot(w.start, w.direction))
        return Polygon([(u0, 0.0), (u0 + w.length, 0.0), (u0 + w.length, w.height), (u0, w.height)])
    return _footprint(scene.get(anchor_id))


def resting_footprint(obj: SceneObject, shape: ObjectShape) -> Polygon:
    """What ``obj`` stands on, seen from above (world XY): the outline of its pieces within
    ``BASE_BAND_M`` of its lowest point. A television on a foot rests on the foot; a box on its box."""
    m = obj.pose.matrix(with_scale=False)
    world = shape.base_vertices() @ m[:3, :3].T + m[:3, 3]
    return Polygon(convex_hull_2d(world[:, :2]))


RESTING_MIN_INSIDE_FRACTION = 0.85
"""What an object stands on may reach past the top it stands on, up to this fraction inside, when
its centre is over the top (a television's foot a little deeper than its stand): it still stands,
its centre of mass over its support."""


def rests_within(foot: Polygon, surface: Polygon) -> tuple[float, bool]:
    """``(inside fraction, in bounds)`` of what an object stands on, over the top it stands on: in
    bounds at ``OOB_MIN_INSIDE_FRACTION``, or at ``RESTING_MIN_INSIDE_FRACTION`` with its centre over the top."""
    area = float(foot.area)
    inside = float(foot.intersection(surface).area) / area if area > 1e-12 else 1.0
    ok = inside >= OOB_MIN_INSIDE_FRACTION or (
        inside >= RESTING_MIN_INSIDE_FRACTION and surface.contains(foot.centroid)
    )
    return inside, ok


def check_out_of_bounds(
    scene: Scene,
    *,
    min_inside_fraction: float = OOB_MIN_INSIDE_FRACTION,
    shapes: Mapping[str, ObjectShape] | None = None,
) -> OutOfBoundsReport:
    """Objects with less than ``min_inside_fraction`` of their footprint over their support surface.

    Floor, ceiling and unsupported objects are judged against the floor polygon (SceneEval's
    rule); objects on objects against the anchor's footprint; wall objects against the wall
    rectangle, in the wall's plane. Footprints are the objects' oriented boxes, except that with
    ``shapes`` an object resting on another object is judged by what it stands on
    (:func:`resting_footprint`: a television wider than its stand is in bounds when its foot is).
    Raises :class:`PhysicsError` for a non-finite pose.
    """
    require_finite_poses(scene, "check bounds")
    report = OutOfBoundsReport(min_inside_fraction=min_inside_fraction)
    for obj in scene.objects:
        rel = scene.support_of(obj.id)
        anchor = rel.parent if rel is not None else FLOOR
        surface = support_polygon(scene, anchor)
        if surface is None:
            report.skipped.append(obj.id)
            continue
        if scene.anchor_kind(anchor) == "wall":
            assert scene.room is not None
            w = scene.room.wall(anchor)
            c = obj.corners()
            e1 = np.array([w.direction[0], w.direction[1], 0.0])
            uv = np.stack([c @ e1, c[:, 2]], axis=1)
            foot = Polygon(convex_hull_2d(uv))
        elif shapes is not None and obj.id in shapes and scene.anchor_kind(anchor) == "object":
            report.checked_objects += 1
            inside, ok = rests_within(resting_footprint(obj, shapes[obj.id]), surface)
            if not ok:
                report.objects.append(
                    OutOfBoundsObject(object_id=obj.id, anchor_id=anchor, inside_fraction=round(inside, 6))
                )
            continue
        else:
            foot = _footprint(obj)
        report.checked_objects += 1
        area = float(foot.area)
        inside = float(foot.intersection(surface).area) / area if area > 1e-12 else 1.0
        if inside < min_inside_fraction:
            report.objects.append(
                OutOfBoundsObject(object_id=obj.id, anchor_id=anchor, inside_fraction=round(inside, 6))
            )
    return report


def nested_furniture(scene: Scene) -> list[str]:
    """Pairs of floor-standing furniture whose boxes stand inside each other, as ``"a ~ b"``
    (the scene layer's :func:`scenemosaic.scene.nested_pairs`)."""
    return [p.label() for p in nested_pairs(scene)]

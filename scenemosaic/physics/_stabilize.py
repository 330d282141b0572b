"""``stabilize_scene``: every local unit, top-down, off the event loop."""

from __future__ import annotations

import asyncio
import functools
import time
import zlib
from collections.abc import Mapping
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np
import structlog

from scenemosaic.assets import HullCache
from scenemosaic.physics._checks import collision_report_for, require_finite_poses
from scenemosaic.physics._hulls import HullInput, ObjectShape, object_shape
from scenemosaic.physics._reports import StabilizationReport, UnitReport
from scenemosaic.physics._settings import SettleSettings, SimSettings
from scenemosaic.physics._settle import settle_unit
from scenemosaic.physics._units import UnitPlan, plan_units
from scenemosaic.physics._validate import motion_between
from scenemosaic.scene import FLOOR, Pose, Scene, SceneObject, rigid_moves

__all__ = ["AGAINST_GAP_M", "AGAINST_MAX_MOVE_M", "stabilize_scene", "stabilize_scene_sync"]

AGAINST_GAP_M = 0.005
"""Gap (metres) left between a piece of furniture standing ``against`` a wall and that wall."""
AGAINST_MAX_MOVE_M = 0.3
"""Largest slide (metres) toward or away from its wall an ``against`` object is given."""

log = structlog.get_logger(__name__)


def _apply(scene: Scene, poses: dict[str, Pose]) -> None:
    """Write new poses; descendants of a moved object follow it rigidly (``scene.rigid_moves``)."""
    for oid, pose in rigid_moves(scene, poses).items():
        scene.get(oid).pose = pose


def _snap_against(scene: Scene, children: set[str], shapes: Mapping[str, ObjectShape]) -> list[str]:
    """Move each floor object that stands ``against`` a wall so its box touches that wall.

    The object (and whatever rests on it) slides along the wall's inward normal until its
    footprint is ``AGAINST_GAP_M`` from the wall line: flush within 1 cm, back to the wall, front
    into the room (the walls agent only marks an object ``against`` when its back faces the
    wall). Larger corrections than ``AGAINST_MAX_MOVE_M`` are left alone (the relation is stale).
    """
    room = scene.room
    if room is None:
        return []
    walls = {w.id: w for w in room.walls}
    moves: dict[str, Pose] = {}
    for rel in scene.relations:
        if rel.kind != "against" or rel.child not in children or rel.parent not in walls:
            continue
        wall = walls[rel.parent]
        inward = np.asarray(wall.inward_normal, dtype=np.float64)
        obj = scene.get(rel.child)
        shift = wall.gap(obj.footprint()) - AGAINST_GAP_M
        if abs(shift) < 1e-4 or abs(shift) > AGAINST_MAX_MOVE_M:
            continue
        x, y, z = obj.pose.position
        moved = obj.pose.model_copy(
            update={"position": (x - shift * float(inward[0]), y - shift * float(inward[1]), z)}
        )
        before = _deepest_contact(scene, obj, shapes)
        if _deepest_contact(scene, obj.model_copy(update={"pose": moved}), shapes) > before + 1e-3:
            continue  # sliding to the wall would drive it into a neighbour: leave it where physics put it
        moves[obj.id] = moved
        _apply(scene, {obj.id: moved})  # one at a time: the next check sees this one in place
    return sorted(moves)


def _refresh_wall_distances(scene: Scene) -> None:
    """Relations that record a gap to a wall (``against``, wall-mounted) get the gap after physics."""
    if scene.room is None:
        return
    walls = {w.id: w for w in scene.room.walls}
    for rel in scene.relations:
        if rel.distance is not None and rel.parent in walls:
            rel.distance = round(max(walls[rel.parent].gap(scene.get(rel.child).footprint()), 0.0), 4)


def _deepest_contact(scene: Scene, obj: SceneObject, shapes: Mapping[str, ObjectShape]) -> float:
    """Deepest hull penetration (metres, 0 when none) between ``obj`` and the objects near it."""
    lo, hi = obj.aabb()
    near = [
        o
        for o in scene.objects
        if o.id != obj.id and not (np.any(o.aabb()[0] > hi + 0.05) or np.any(lo > o.aabb()[1] + 0.05))
    ]
    if not near:
        return 0.0
    sub = Scene(id="snap", objects=[obj, *near])
    pairs = collision_report_for(sub, shapes, tolerance_m=0.0).pairs
    return max((p.depth_m for p in pairs if obj.id in (p.a, p.b)), default=0.0)


def _unit_seed(seed: int, plan: UnitPlan) -> int:
    return zlib.crc32(f"{seed}:{plan.anchor_id}".encode())


async def stabilize_scene(
    scene: Scene,
    *,
    base_dir: str | Path | None = None,
    seed: int = 0,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    sim: SimSettings | None = None,
    settle: SettleSettings | None = None,
    executor: Executor | None = None,
) -> tuple[Scene, StabilizationReport]:
    """Make a scene physically valid, unit by unit, top-down through the support tree.

    Each unit (anchor + immediate children) gets containment correction, snapping onto its
    support, separation of deep interpenetrations and gravity settling in MuJoCo (see
    :mod:`scenemosaic.physics._settle`). Units of the same depth run concurrently in worker
    threads (MuJoCo releases the GIL while stepping); the event loop is never blocked. The
    input scene is not modified; the result is a copy. Deterministic for a given ``seed``.

    ``hulls`` optionally gives precomputed convex pieces per object id (local frame, scaled),
    which win over the assets layer; ``hull_cache`` is passed to ``scenemosaic.assets.object_hulls``.

    ``executor`` runs the units instead of the default worker threads, e.g. a
    ``ProcessPoolExecutor`` (spawn context) shared by a batch of scenes, so the pure-Python
    parts of settling (snapping, separation) also run in parallel. Results are identical.

    An object with a non-finite pose (NaN, inf) raises
    :class:`~scenemosaic.exceptions.PhysicsError` naming it before any work starts.
    """
    require_finite_poses(scene, "stabilize the scene")
    t0 = time.perf_counter()
    sim = sim or SimSettings()
    settle = settle or SettleSettings()
    out = scene.model_copy(deep=True)
    units, defaulted = plan_units(out)
    shapes: dict[str, ObjectShape] = await asyncio.to_thread(
        lambda: {o.id: object_shape(o, base_dir, cache=hull_cache, hulls=hulls) for o in out.objects}
    )
    report = StabilizationReport(seed=seed, unsupported_defaulted=defaulted)
    done: list[str] = []
    for depth in sorted({u.depth for u in units}):
        level = [u for u in units if u.depth == depth]
        snapshot = out.model_copy(deep=True)  # units of one level read the same state
        neighbours = list(done)
        loop = asyncio.get_running_loop()
        results: list[tuple[dict[str, Pose], UnitReport]] = await asyncio.gather(
            *(
                loop.run_in_executor(
                    executor,
                    functools.partial(
                        settle_unit,
                        snapshot,
                        u,
                        shapes,
                        neighbours,
                        sim=sim,
                        settle=settle,
                        seed=_unit_seed(seed, u),
                    ),
                )
                for u in level
            )
        )
        for u, (poses, unit_report) in zip(level, results, strict=True):
            _apply(out, poses)
            report.units.append(unit_report)
            done.extend(u.children)
            if u.anchor_id == FLOOR:
                # hull contact checks compile MuJoCo worlds: off the event loop
                snapped = await asyncio.to_thread(_snap_against, out, set(u.children), shapes)
                report.against_snapped.extend(snapped)
    _refresh_wall_distances(out)
    report.motions = [motion_between(o.id, scene.get(o.id).pose, o.pose) for o in out.objects]
    out.provenance.steps.append("stabilize")
    if defaulted:
        out.provenance.notes.append(
            f"stabilize: no support relation, treated as on the floor: {', '.join(defaulted)}"
        )
    report.wall_s = round(time.perf_counter() - t0, 6)
    log.info("scene_stabilized", scene=scene.id, units=len(report.units), wall_s=report.wall_s)
    return out, report


def stabilize_scene_sync(scene: Scene, **kwargs: Any) -> tuple[Scene, StabilizationReport]:
    """Blocking form of :func:`stabilize_scene` for scripts (must not be called inside a running loop)."""
    return asyncio.run(stabilize_scene(scene, **kwargs))

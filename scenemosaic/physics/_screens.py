"""Screens hung where nobody can watch them: a wall TV behind a bed's head or a sofa's back moves.

A source (a ProcTHOR house, an image-to-3D layout) may hang a TV on the stretch of wall a bed or a
sofa backs onto (``scene.on_backing_wall``): whoever lies or sits there faces away from it.
:func:`rehang_screens` carries such a TV to the wall the bed or sofa faces (else to the wall nearest to facing it),
centred on its axis as far as the wall allows, at the same height and distance from the wall, turned to face
into the room; a place is taken only when the TV lies whole on that wall, clear (by
``OPENING_CLEAR_M``) of its doors and windows, of every door's clearance zone, of every other
object's hull, and not behind another bed or sofa. Its support relation then names the new
wall. A TV with no such place stays (and is reported).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from scenemosaic.physics._checks import collision_report_for
from scenemosaic.physics._hulls import ObjectShape
from scenemosaic.scene import (
    Scene,
    build_structure,
    door_blockers,
    fits_wall,
    front_vector,
    is_screen,
    on_backing_wall,
    quat_from_yaw,
    quat_multiply,
)

__all__ = ["SCREEN_STEP_M", "rehang_screens"]

SCREEN_STEP_M = 0.1
"""Step (metres) of the places along a wall tried for a re-hung TV, outward from the bed's (sofa's) axis."""


def rehang_screens(scene: Scene, shapes: Mapping[str, ObjectShape]) -> tuple[Scene, dict[str, str], list[str]]:
    """Move every wall TV hung behind a bed's head or a sofa's back (module docstring). Returns the scene (a
    copy when something moved; the input is kept), ``{tv: new wall}`` and the TVs left where they hang."""
    moved: dict[str, str] = {}
    stuck: list[str] = []
    if scene.room is None:
        return scene, moved, stuck
    for tv in [o for o in scene.objects if is_screen(o.category)]:
        piece_id = on_backing_wall(scene, tv.id)
        if piece_id is None:
            continue
        placed = _rehang(scene, shapes, tv.id, piece_id)
        if placed is None:
            stuck.append(tv.id)
            continue
        scene, wall = placed
        moved[tv.id] = wall
    return scene, moved, stuck


def _rehang(scene: Scene, shapes: Mapping[str, ObjectShape], tv_id: str, piece_id: str) -> tuple[Scene, str] | None:
    assert scene.room is not None
    tv, piece = scene.get(tv_id), scene.get(piece_id)
    rel = scene.support_of(tv_id)
    assert rel is not None
    old = scene.room.wall(rel.parent)
    front = front_vector(piece.pose.quaternion)[:2]
    front = front / max(float(np.linalg.norm(front)), 1e-9)
    p0 = np.asarray(tv.pose.position[:2], dtype=np.float64)
    depth = float((p0 - np.asarray(old.start)) @ old.inward_normal)
    walls = sorted(
        (w for w in scene.room.walls if w.id != old.id and w.length > 0.3),
        key=lambda w: (float(np.asarray(w.inward_normal) @ front), w.id),  # the wall the piece faces first
    )
    blocked_before = {b.object_id for b in door_blockers(scene)}
    piece_xy = np.asarray(piece.pose.position[:2], dtype=np.float64)
    for wall in walls:
        n, t, start = np.asarray(wall.inward_normal), np.asarray(wall.direction), np.asarray(wall.start, dtype=np.float64)
        spin = math.atan2(float(n[1]), float(n[0])) - math.atan2(float(old.inward_normal[1]), float(old.inward_normal[0]))
        quat = quat_multiply(quat_from_yaw(spin), tv.pose.quaternion)
        centre = float((piece_xy - start) @ t)
        offsets = np.arange(0.0, wall.length + 1e-9, SCREEN_STEP_M)
        for d in sorted({*offsets, *(-offsets)}, key=lambda x: (abs(x), x)):
            along = centre + float(d)
            xy = start + t * along + n * depth
            pose = tv.pose.model_copy(update={"position": (float(xy[0]), float(xy[1]), tv.pose.position[2]), "quaternion": quat})
            hung = tv.model_copy(update={"pose": pose})
            if not fits_wall(hung, wall, None):  # within the wall, clear of its doors and windows
                continue
            relations = [r.model_copy(update={"parent": wall.id}) if r.child == tv_id and r.parent == old.id else r for r in scene.relations]
            objects = [hung if o.id == tv_id else o for o in scene.objects]
            trial = scene.model_copy(update={"objects": objects, "relations": relations})
            if on_backing_wall(trial, tv_id) is not None:
                break  # another bed or sofa backs onto this wall
            if tv_id in {b.object_id for b in door_blockers(trial)} - blocked_before:
                continue
            if any(tv_id in (p.a, p.b) for p in collision_report_for(trial, shapes).pairs):
                continue
            if trial.structure is not None:
                trial = trial.model_copy(update={"structure": build_structure(trial)})
            note = f"screens: moved {tv_id} from the wall behind {piece_id} ({old.id}) to {wall.id}"
            trial = trial.model_copy(update={"provenance": trial.provenance.model_copy(update={"notes": [*trial.provenance.notes, note]})})
            return trial, wall.id
    return None

"""Door clearance repair: furniture standing in front of a door is moved out of the way.

A room cut from a house has doors in its walls (``Opening`` of kind ``door``); the zone in front
of each (:func:`scenemosaic.scene.door_zones`: the door's width by ``DOOR_CLEARANCE_DEPTH_M``)
must hold nothing a robot walks into. A wall piece hung low in a zone (a picture beside the
door frame) slides along its wall out of it, or, with no place there, is re-hung on another wall
of the room. :func:`clear_doors` then takes every floor-standing piece whose
footprint enters a zone (an item on a table in the zone moves with its table) and packs it back
onto the floor less the zones, the other furniture standing where it stands
(:func:`scenemosaic.scene.pack_surface`: the nearest free place), then checks the moved room for
interpenetration on the objects' hulls. A piece with no free place, or whose new place collides,
stays and is reported.

A clear zone is not yet a usable door: a bed and a ball lying beside it can close the way from
the door into the room. So the repair then checks that every door's zone opens onto the room's
largest walkable piece (:func:`scenemosaic.scene.cut_off_doors`) and, where one does not, moves
the smallest nearby piece whose removal opens the way (``RECONNECT_REACH_M``, ``RECONNECT_ROUNDS``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

from scenemosaic.physics._checks import collision_report_for
from scenemosaic.physics._hulls import ObjectShape
from scenemosaic.scene import (
    DOOR_CLEARANCE_DEPTH_M,
    FLOOR,
    DoorZone,
    PackItem,
    Pose,
    Scene,
    SceneObject,
    Wall,
    build_structure,
    convex_hull_2d,
    cut_off_doors,
    descendants,
    door_blockers,
    door_zones,
    fits_wall,
    is_thin,
    pack_surface,
    quat_from_yaw,
    quat_multiply,
    rigid_moves,
)

__all__ = ["DOOR_PACK_CELL_M", "RECONNECT_REACH_M", "RECONNECT_ROUNDS", "WALL_SLIDE_STEP_M", "DoorRepair", "clear_doors"]

DOOR_PACK_CELL_M = 0.02
"""Raster cell (metres) of the search for a free place on the floor."""
RECONNECT_REACH_M = 1.0
"""How far from a cut-off door zone (metres) a piece may stand to be moved to reopen it; a piece
moved for it goes at least this far from every door."""
RECONNECT_ROUNDS = 4
"""Most pieces moved to reopen the room's doors."""
WALL_SLIDE_STEP_M = 0.05
"""Step (metres) of the places along its wall tried for a wall piece hung in a door's way."""


@dataclass
class DoorRepair:
    """What :func:`clear_doors` did: the pieces moved (id -> metres moved) and those it could not."""

    moved: dict[str, float] = field(default_factory=dict)
    stuck: list[str] = field(default_factory=list)
    cut_off: list[str] = field(default_factory=list)
    """Doors whose clear zone still opens onto no part of the room's main walkable floor."""

    def notes(self) -> list[str]:
        """One provenance note per piece moved or left in a door's way."""
        out = [
            f"doors: moved {oid} {d:.2f} m out of a door's way"
            for oid, d in sorted(self.moved.items())
        ]
        out += [
            f"doors: {oid} stands in a door's clearance zone and found no free place" for oid in self.stuck
        ]
        out += [f"doors: door {door} opens onto a pocket of the room cut off from the rest" for door in self.cut_off]
        return out


def clear_doors(
    scene: Scene, shapes: Mapping[str, ObjectShape], *, depth: float = DOOR_CLEARANCE_DEPTH_M
) -> tuple[Scene, DoorRepair]:
    """Move the furniture standing in front of the room's doors out of their clearance zones, then
    whatever cuts a clear zone off from the rest of the room (see the module docstring); returns
    the repaired scene (a copy; the input is kept) and what moved. A room without doors, or whose
    doors are clear and open onto the room, comes back unchanged."""
    repair = DoorRepair()
    if scene.room is None or not door_zones(scene, depth):
        return scene, repair
    hung = sorted({b.object_id for b in door_blockers(scene, depth=depth) if _wall_of(scene, b.object_id) is not None})
    repaired = _slide_along_walls(scene, shapes, hung, door_zones(scene, depth), repair) if hung else scene
    blockers = sorted({r for b in door_blockers(repaired, depth=depth) if (r := repaired.floor_root(b.object_id)) is not None})
    repaired = _move_out(repaired, shapes, blockers, door_zones(repaired, depth), 0.01, repair) if blockers else repaired
    repaired = _reconnect(repaired, shapes, depth, repair)
    repair.stuck = sorted({b.object_id for b in door_blockers(repaired, depth=depth)})
    repair.cut_off = cut_off_doors(repaired, depth=depth)
    if repair.moved or repair.stuck or repair.cut_off:
        repaired = repaired if repaired is not scene else scene.model_copy(deep=True)
        repaired.provenance.notes.extend(repair.notes())
    return repaired, repair


def _reconnect(scene: Scene, shapes: Mapping[str, ObjectShape], depth: float, repair: DoorRepair) -> Scene:
    """Move what closes off a clear door zone from the rest of the room: of the floor-standing
    pieces within ``RECONNECT_REACH_M`` of it, the smallest whose removal opens the way goes to the
    nearest free place at least that far from every door (a few rounds, until no door is cut off)."""
    for _ in range(RECONNECT_ROUNDS):
        cut = set(cut_off_doors(scene, depth=depth))
        if not cut:
            return scene
        zones = [z for z in door_zones(scene, depth) if z.door_id in cut]
        near = unary_union([z.polygon for z in zones]).buffer(RECONNECT_REACH_M)
        roots = [o for o in scene.objects if scene.floor_root(o.id) == o.id and not o.sim.static and not is_thin(o)]
        candidates = sorted(
            (o for o in roots if _foot(o).intersects(near)),
            key=lambda o: _foot(o).area,
        )
        moved = None
        for obj in candidates:
            gone = {obj.id, *descendants(scene, obj.id)}
            without = scene.model_copy(update={"objects": [o for o in scene.objects if o.id not in gone]})
            if set(cut_off_doors(without, depth=depth)) >= cut:
                continue  # not what closes the way
            after = _move_out(scene, shapes, [obj.id], door_zones(scene, depth), RECONNECT_REACH_M, repair)
            if after is not scene and len(set(cut_off_doors(after, depth=depth))) < len(cut):
                moved = after
                break
        if moved is None:
            return scene
        scene = moved
    return scene


def _wall_of(scene: Scene, object_id: str) -> str | None:
    """The wall ``object_id`` hangs on, else ``None``."""
    rel = scene.support_of(object_id)
    if rel is None or rel.parent == FLOOR or scene.anchor_kind(rel.parent) != "wall":
        return None
    return rel.parent


def _slide_along_walls(
    scene: Scene, shapes: Mapping[str, ObjectShape], movers: list[str], zones: list[DoorZone], repair: DoorRepair
) -> Scene:
    """Slide each wall piece in ``movers`` (a picture or TV hung low beside a door) along its wall,
    the shortest way (every ``WALL_SLIDE_STEP_M``) that takes its footprint out of every door zone
    and keeps it whole on its wall, or on a wall in line with it (the same plane, split by a room's
    corner elsewhere: its support relation then names that wall), clear of that wall's openings and
    of every other object's hull; a piece with no such place stays (and is reported stuck)."""
    assert scene.room is not None
    keep_out = unary_union([z.polygon for z in zones]).buffer(0.01, join_style="mitre")
    for oid in movers:
        own = scene.room.wall(_wall_of(scene, oid) or "")
        obj = scene.get(oid)
        t = np.asarray(own.direction, dtype=np.float64)
        start = np.asarray(own.start, dtype=np.float64)
        n = np.asarray(own.inward_normal, dtype=np.float64)
        inline = [
            w for w in scene.room.walls
            if float(np.asarray(w.direction) @ t) > 1 - 1e-6 and abs(float((np.asarray(w.start) - start) @ n)) < 1e-3
        ]  # fmt: skip
        spans = {w.id: (float((np.asarray(w.start) - start) @ t), float((np.asarray(w.end) - start) @ t)) for w in inline}
        zlo, zhi = (float(v[2]) for v in obj.aabb())
        reach = max(b for _, b in spans.values()) - min(a for a, _ in spans.values())
        steps = np.arange(WALL_SLIDE_STEP_M, reach + 1e-9, WALL_SLIDE_STEP_M)
        for d in sorted([*steps, *(-steps)], key=lambda x: (abs(x), x)):
            x, y, z = obj.pose.position
            pose = obj.pose.model_copy(update={"position": (x + float(t[0] * d), y + float(t[1] * d), z)})
            moved = obj.model_copy(update={"pose": pose})
            along = (moved.corners()[:, :2] - start) @ t
            lo, hi = float(along.min()), float(along.max())
            host = next((w for w in inline if spans[w.id][0] - 1e-3 <= lo and hi <= spans[w.id][1] + 1e-3), None)
            if host is None or _foot(moved).intersects(keep_out):
                continue
            a0 = spans[host.id][0]
            if any(hi - a0 > o.center - o.width / 2 and lo - a0 < o.center + o.width / 2 and zhi > o.bottom and zlo < o.bottom + o.height for o in host.openings):
                continue
            trial = _hung(scene, shapes, oid, pose, own.id, host.id)  # on the wall in line with its own, maybe
            if trial is None:
                continue
            repair.moved[oid] = repair.moved.get(oid, 0.0) + abs(float(d))
            scene = trial
            break
        else:
            scene = _to_other_wall(scene, shapes, oid, own, keep_out, repair)
    return scene


def _hung(
    scene: Scene, shapes: Mapping[str, ObjectShape], oid: str, pose: Pose, own: str, host: str
) -> Scene | None:
    """``scene`` with wall piece ``oid`` (and what rests on it) at ``pose`` on wall ``host``
    (its support relation re-parented from ``own`` when that differs, the structure rebuilt);
    ``None`` when the move makes a new collision."""
    candidate = rigid_moves(scene, {oid: pose})
    trial = scene.model_copy(update={"objects": [o.model_copy(update={"pose": candidate[o.id]}) if o.id in candidate else o for o in scene.objects]})
    moved_ids = set(candidate)
    if any((p.a in moved_ids) != (p.b in moved_ids) for p in collision_report_for(trial, shapes).pairs):
        return None
    if host != own:
        trial = trial.model_copy(update={"relations": [r.model_copy(update={"parent": host}) if r.child == oid and r.parent == own else r for r in trial.relations]})
        if trial.structure is not None:
            trial = trial.model_copy(update={"structure": build_structure(trial)})
    return trial


def _to_other_wall(
    scene: Scene, shapes: Mapping[str, ObjectShape], oid: str, own: Wall, keep_out: Polygon, repair: DoorRepair
) -> Scene:
    """A wall piece that cannot slide out of a door's way along its own wall re-hung on another
    wall of the room: as high and as far from the wall as it hung, facing into the room, the
    longest walls first and on each the place nearest its middle (every ``WALL_SLIDE_STEP_M``),
    within the wall's length, clear of its doors and windows (``scene.fits_wall``), of every door
    zone and of every other object's hull; its support relation then names that wall. The scene
    itself when no wall has such a place."""
    assert scene.room is not None
    obj = scene.get(oid)
    n0 = np.asarray(own.inward_normal, dtype=np.float64)
    xy0 = np.asarray(obj.pose.position[:2], dtype=np.float64)
    depth = float((xy0 - np.asarray(own.start)) @ n0)
    floor = Polygon(scene.room.floor).buffer(0.02)
    for wall in sorted((w for w in scene.room.walls if w.id != own.id), key=lambda w: (-w.length, w.id)):
        n1, t1 = np.asarray(wall.inward_normal, dtype=np.float64), np.asarray(wall.direction, dtype=np.float64)
        spin = math.atan2(float(n1[1]), float(n1[0])) - math.atan2(float(n0[1]), float(n0[0]))
        quat = quat_multiply(quat_from_yaw(spin), obj.pose.quaternion)
        offsets = np.arange(0.0, wall.length / 2 + 1e-9, WALL_SLIDE_STEP_M)
        for off in sorted({*offsets, *(-offsets)}, key=lambda x: (abs(x), x)):
            xy = np.asarray(wall.start) + t1 * (wall.length / 2 + off) + n1 * depth
            pose = obj.pose.model_copy(update={"position": (float(xy[0]), float(xy[1]), obj.pose.position[2]), "quaternion": quat})
            moved = obj.model_copy(update={"pose": pose})
            if not fits_wall(moved, wall, None) or _foot(moved).intersects(keep_out) or not floor.covers(_foot(moved)):
                continue
            trial = _hung(scene, shapes, oid, pose, own.id, wall.id)
            if trial is None:
                continue
            repair.moved[oid] = repair.moved.get(oid, 0.0) + float(np.linalg.norm(xy - xy0))
            return trial
    return scene


def _foot(obj: SceneObject) -> Polygon:
    return Polygon(convex_hull_2d(obj.corners()[:, :2]))


def _move_out(
    scene: Scene, shapes: Mapping[str, ObjectShape], movers: list[str], zones: list[DoorZone], keep: float,
    repair: DoorRepair,
) -> Scene:  # fmt: skip
    """Pack ``movers`` onto the floor less every door zone grown by ``keep`` metres (everything
    else on the floor stays where it stands); the scene with them moved, or the scene itself when
    no free place is found or the move would make a collision."""
    assert scene.room is not None
    keep_out = unary_union([z.polygon for z in zones]).buffer(keep, join_style="mitre")
    surface = Polygon(scene.room.floor).difference(keep_out)
    if surface.geom_type != "Polygon":  # zones cut the floor apart: keep the largest piece
        surface = max(getattr(surface, "geoms", []), key=lambda g: g.area, default=Polygon())
    items = []
    for obj in scene.objects:
        if scene.floor_root(obj.id) != obj.id or (obj.id not in movers and is_thin(obj)):
            continue  # things on furniture move with it; a rug is stood on
        items.append(PackItem(obj.id, convex_hull_2d(obj.corners()[:, :2]), movable=obj.id in movers))
    result = pack_surface(surface, items, cell=DOOR_PACK_CELL_M)
    poses: dict[str, Pose] = {}
    for oid, shift in result.shifts.items():
        if oid not in movers or oid in result.turned or float(np.linalg.norm(shift)) < 1e-9:
            continue
        p = scene.get(oid).pose
        x, y, z = p.position
        poses[oid] = p.model_copy(update={"position": (x + float(shift[0]), y + float(shift[1]), z)})
    if not poses:
        return scene
    moved_poses = rigid_moves(scene, poses)
    candidate = scene.model_copy(deep=True)
    for obj in candidate.objects:
        if obj.id in moved_poses:
            obj.pose = moved_poses[obj.id]
    moved_ids = set(moved_poses)
    pairs = collision_report_for(candidate, shapes).pairs
    if any((p.a in moved_ids) != (p.b in moved_ids) for p in pairs):  # a new collision: keep the room as it was
        return scene
    for oid, pose in poses.items():
        dist = float(np.linalg.norm(np.subtract(pose.position, scene.get(oid).pose.position)))
        repair.moved[oid] = repair.moved.get(oid, 0.0) + dist
    return candidate

"""The doors of the rooms: a hinged leaf hung on every doorway that has a door.

A room's walls carry its doors as holes (:class:`~scenemosaic.scene.Opening`, kind ``door``);
the simulator exports hang the door itself in each hole. A door is not an object of the scene
(``scene.json`` keeps the holes, and navigation, door clearance and the checks see the doorway
free, as before): it is made here, when a scene is written, as a procedural object held in place
at the doorway (:func:`room_door_leaves`) whose leaves are parts on hinges, so every export writes
it as it writes the door of a wardrobe (:func:`with_room_doors`).

The rules (``docs/articulation.md``):

* **Which holes.** A door's hole gets :attr:`Opening.leaf_count` leaves: one unless the source
  says otherwise (AI2-THOR's ``Doorframe_*`` none, ``Doorway_Double_*`` two); an open stretch of
  wall (``opening``) and a window none.
* **Where.** The door fills the hole (only as wide as the wall it is cut in,
  :meth:`~scenemosaic.scene.Wall.span`): its frame's two jambs against the hole's sides, the leaf
  between them, closed, with its front face in the face of the wall of the room it swings into;
  it hangs on the front edge of one jamb and turns into that room, up to
  :data:`ROOM_DOOR_OPEN_DEG`.
* **Which way.** The candidates, in this order: into the room that owns the door (a single
  room; in a house, the doorway's first room in the house's order), hung on its left jamb (seen
  from that room), then on its right one; then the same into the room on the other side. The
  first whose leaf swings to its limit staying on its room's floor and clear of the furniture (and
  of the parts it delivers open) and of the doors hung before it in that room (where their leaves
  swing) all the way (checked every
  :data:`FIT_STEP_DEG`) is taken; when none does, a door hung before it is hung another way if
  that lets this one swing to its limit and the earlier one no less far; else the one that swings
  furthest clear.
* **How far.** The leaf is delivered at that angle (its *open* pose: open by default, so the
  doorway stays passable), shut under ``--open-state closed``, a drawn fraction of it under
  ``random``; a value set in the scene's ``open_state`` record wins. The joint's range stays
  ``0`` (shut) to the limit.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
import structlog
from shapely.geometry import MultiPoint, Polygon
from shapely.geometry.base import BaseGeometry

from scenemosaic._memo import Memo
from scenemosaic.assets._articulation import HingeSide, PartSpec, opening
from scenemosaic.assets._furniture import ROOM_DOOR_CATEGORIES, ROOM_DOOR_HANDLE_PROUD_M, ROOM_DOOR_LEAF_M
from scenemosaic.assets._opening import OPEN_STATE_KEY, open_part_footprints, part_openings
from scenemosaic.assets._procedural import procedural_articulation, procedural_parts
from scenemosaic.scene import (
    AssetRef,
    FloatArray,
    House,
    Opening,
    Pose,
    Scene,
    SceneObject,
    SimAttributes,
    Wall,
)

__all__ = [
    "FIT_CLEARANCE_M",
    "FIT_STEP_DEG",
    "ROOM_DOOR_KG_PER_M2",
    "RoomDoor",
    "room_door_leaves",
    "with_room_doors",
]

log = structlog.get_logger(__name__)

ROOM_DOOR_KG_PER_M2 = 12.0
"""Mass of a room door per square metre of its hole, kg/m^2 (a hollow-core interior door: about
20 kg for 0.8 x 2 m); the leaves take nearly all of it, the jambs the rest."""
FIT_STEP_DEG = 5.0
"""The step, degrees, in which a leaf's swing from shut is checked clear of the furniture (it
opens as far as the first step that is not)."""
FIT_TOLERANCE_M = 0.01
"""How far, metres, a leaf's outline may reach past its room's floor (into the wall it hangs on,
or the one beside it) and still count as clear."""
FIT_CLEARANCE_M = 0.005
"""How far, metres, a leaf's outline keeps from every object's footprint for the object not to be
in its way."""
_DOOR_CATEGORIES = frozenset(ROOM_DOOR_CATEGORIES.values())
_HINGE_CHOICES: dict[int, tuple[tuple[HingeSide, ...], ...]] = {1: (("-x",), ("+x",)), 2: (("-x", "+x"),)}


@dataclass(frozen=True)
class RoomDoor:
    """The door hung on one doorway: a procedural object held in place, and its leaves' open pose."""

    room_id: str
    """The room it swings into (the room scene whose objects it joins in the exports)."""
    object: SceneObject
    """The door as an object: its frame does not move, each leaf is a part on a hinge."""
    open_values: dict[str, float]
    """Part name -> the angle (radians) the leaf is delivered at when open: its limit, or less
    where the furniture or a wall stands in its way."""
    rooms: tuple[str, ...]
    """The rooms the doorway joins (one: a door to the outside, or a single room's door)."""


@dataclass(frozen=True)
class _Side:
    room: Scene
    wall: Wall
    centre: np.ndarray  # the hole's centre on this room's wall line, XY


@dataclass(frozen=True)
class _Hole:
    id: str
    sides: tuple[_Side, ...]  # the rooms it may swing into, the owner first
    opening: Opening
    width: float


def _wall_point(wall: Wall, along: float) -> np.ndarray:
    return np.asarray(wall.start, dtype=np.float64) + wall.direction * along


def _holes_of_scene(scene: Scene) -> list[_Hole]:
    out: list[_Hole] = []
    if scene.room is None:
        return out
    for wall in scene.room.walls:
        for op in wall.openings:
            if op.leaf_count > 0:
                lo, hi = wall.span(op)  # a hole drawn past its wall's end is only as wide as the wall
                if hi - lo <= 0.0:
                    continue
                side = _Side(scene, wall, _wall_point(wall, (lo + hi) / 2))
                out.append(_Hole(f"room_door_{len(out)}", (side,), op, hi - lo))
    return out


def _holes_of_house(house: House) -> list[_Hole]:
    out: list[_Hole] = []
    rooms = {s.id: s for s in house.rooms}
    for doorway in house.doorways():
        if doorway.kind != "door":
            continue
        sides: list[_Side] = []
        found: Opening | None = None
        for face in doorway.sides:
            room = rooms[face.room_id]
            walls = room.room.walls if room.room is not None else []
            wall = next((w for w in walls if w.id == face.wall_id), None)
            if wall is None:
                continue
            doors = [op for op in wall.openings if op.kind == "door"]
            if not doors:
                continue
            along = float(np.dot(np.asarray(face.centre) - np.asarray(wall.start), wall.direction))
            op = min(doors, key=lambda o: abs(o.center - along))
            found = found or op
            sides.append(_Side(room, wall, np.asarray(face.centre, dtype=np.float64)))
        if found is not None and found.leaf_count > 0 and sides:
            out.append(_Hole(f"room_{doorway.id}", tuple(sides), found, doorway.width))
    return out


def _door_object(hole: _Hole, side: _Side, hinges: tuple[HingeSide, ...], object_id: str) -> SceneObject:
    """The door of ``hole`` swinging into ``side``'s room, hung on ``hinges``: its front (-Y)
    toward that room, the leaf's front face in the face of that room's wall."""
    n = side.wall.inward_normal
    depth = ROOM_DOOR_LEAF_M + 2 * ROOM_DOOR_HANDLE_PROUD_M
    xy = side.centre - n * (ROOM_DOOR_LEAF_M / 2)
    op = hole.opening
    yaw = math.atan2(float(n[0]), float(-n[1]))  # the object's -Y onto the room's inward normal
    return SceneObject(
        id=object_id,
        category=ROOM_DOOR_CATEGORIES[hinges],
        description=f"the door of {side.room.id}",
        asset=AssetRef(kind="procedural", extents=(hole.width, depth, op.height)),
        pose=Pose.from_yaw((float(xy[0]), float(xy[1]), float(op.bottom)), yaw),
        sim=SimAttributes(
            mass_kg=ROOM_DOOR_KG_PER_M2 * hole.width * op.height, static=True, source="room door"
        ),
    )


_PART_POINTS: Memo[tuple[str, tuple[float, float, float], tuple[int, ...]], FloatArray] = Memo(1024)
"""A part's piece vertices, object frame, homogeneous ``(N, 4)``, by (category, extents, piece
indices): a leaf's outline is taken at every step of its swing, for every candidate jamb and
every house, and building the pieces is what cost the most."""


def _part_points(category: str, extents: tuple[float, float, float], pieces: tuple[int, ...]) -> FloatArray:
    """The vertices of the pieces ``pieces`` of the procedural model, object frame, with a 1
    appended to each (read-only, shared)."""

    def make() -> FloatArray:
        built = procedural_parts(category, extents)
        local = np.concatenate([np.asarray(built[i].vertices, dtype=np.float64) for i in pieces])
        out = np.hstack([local, np.ones((len(local), 1))])
        out.setflags(write=False)
        return out

    return _PART_POINTS.get((category, extents, pieces), make)


def _outline(obj: SceneObject, part: PartSpec, value: float) -> Polygon:
    """The outline seen from above (world XY) of the leaf and its handles at joint value ``value``."""
    points = _part_points(obj.category, obj.asset.extents, part.pieces)
    world = (obj.pose.matrix() @ part.transform(value) @ points.T).T[:, :2]
    hull = MultiPoint(world).convex_hull
    return hull if isinstance(hull, Polygon) else Polygon()


def _obstacles(room: Scene, door: SceneObject) -> list[Polygon]:
    """The footprints of the room's objects that reach the height of the door's leaves, and of the
    parts the room delivers open there (a drawer left out: a leaf swung into it starts inside it)."""
    bottom = door.pose.position[2]
    top = bottom + door.asset.extents[2]
    out: list[Polygon] = []
    for obj in room.objects:
        lo, hi = obj.aabb()
        if float(hi[2]) > bottom + 0.02 and float(lo[2]) < top:
            poly = Polygon([tuple(p) for p in obj.footprint()])
            if poly.is_valid and poly.area > 0:
                out.append(poly)
    for corners in open_part_footprints(room, float(bottom) + 0.02, float(top)):
        poly = Polygon([tuple(p) for p in corners])
        if poly.is_valid and poly.area > 0:
            out.append(poly)
    return out


def _clear_angle(
    side: _Side, door: SceneObject, parts: Sequence[PartSpec], others: Sequence[Polygon] = ()
) -> float:
    """The largest angle (radians, a multiple of :data:`FIT_STEP_DEG`, or the limit) to which
    every leaf of ``door`` swings from shut staying on its room's floor and clear of the room's
    objects and of ``others`` (where the doors hung before swing in that room) at every step on the
    way (so a robot can shut it again)."""
    room = side.room.room
    floor: BaseGeometry = Polygon(room.floor) if room is not None else Polygon()
    closed = Polygon([tuple(p) for p in door.footprint()])
    allowed = floor.union(closed).buffer(FIT_TOLERANCE_M)
    shapely.prepare(allowed)  # asked once per leaf and step: the same answers, sooner
    obstacles = np.array([*_obstacles(side.room, door), *others], dtype=object)
    limit = min(p.limits[1] for p in parts)
    steps = math.floor(math.degrees(limit) / FIT_STEP_DEG - 1e-9)
    reached = 0.0
    for angle in [*(math.radians(FIT_STEP_DEG * k) for k in range(1, steps + 1)), limit]:
        outlines = [_outline(door, p, angle) for p in parts]
        if not all(allowed.contains(o) for o in outlines) or any(
            bool((shapely.distance(o, obstacles) < FIT_CLEARANCE_M).any()) for o in outlines
        ):
            break
        reached = angle
    return reached


def _swept(door: SceneObject, parts: Sequence[PartSpec], angle: float) -> list[Polygon]:
    """Where the leaves of ``door`` pass, seen from above, from shut to ``angle``: each leaf's
    outlines every :data:`FIT_STEP_DEG`, one convex hull per leaf and step pair."""
    steps = [
        *(math.radians(FIT_STEP_DEG * k) for k in range(math.floor(math.degrees(angle) / FIT_STEP_DEG) + 1)),
        angle,
    ]
    out = []
    for part in parts:
        outlines = [_outline(door, part, a) for a in steps]
        for a, b in itertools.pairwise(outlines):
            hull = a.union(b).convex_hull
            if isinstance(hull, Polygon) and hull.area > 0:
                out.append(hull)
    return out


def _fitted(
    hole: _Hole, object_id: str, swept: Mapping[str, Sequence[Polygon]]
) -> tuple[_Side, SceneObject, float]:
    """The first candidate (room, hinge jamb) whose leaves turn to their limit clear (of the room's
    furniture and of ``swept``, by room id: where the doors fitted before swing), else the one that
    turns furthest."""
    best: tuple[_Side, SceneObject, float] | None = None
    for side in hole.sides:
        for hinges in _HINGE_CHOICES[hole.opening.leaf_count]:
            door = _door_object(hole, side, hinges, object_id)
            parts = procedural_articulation(door.category, door.asset.extents)
            angle = _clear_angle(side, door, parts, swept.get(side.room.id, ()))
            if best is None or angle > best[2] + 1e-9:
                best = (side, door, angle)
            if angle >= min(p.limits[1] for p in parts) - 1e-9:
                return best
    assert best is not None
    return best


def _unique_id(wanted: str, taken: set[str]) -> str:
    out = wanted
    while out in taken:
        out += "_leaf"
    taken.add(out)
    return out


def room_door_leaves(scene: Scene | House) -> list[RoomDoor]:
    """The door of every doorway of ``scene`` (a room, or a whole house) that has one, as the
    simulator exports hang it: ``room_door_<k>`` (a room's doors in the order of its walls and
    their holes; a house's ``room_door_<k>`` after its doorway ``door_<k>``), chosen, placed and
    opened by the rules of this module's docstring. Deterministic: the same scene gives the same
    doors."""
    holes = _holes_of_house(scene) if isinstance(scene, House) else _holes_of_scene(scene)
    taken = {o.id for o in scene.objects}
    ids = [_unique_id(hole.id, taken) for hole in holes]
    fits: list[tuple[_Side, SceneObject, float]] = []

    def swept(skip: int | None = None, extra: tuple[_Side, SceneObject, float] | None = None) -> dict[str, list[Polygon]]:
        """Where the leaves of the doors fitted so far swing (but door ``skip``, and with ``extra``), by room."""
        out: dict[str, list[Polygon]] = {}
        for k, (side, door, angle) in enumerate([*fits, *([extra] if extra else [])]):
            if k != skip:
                out.setdefault(side.room.id, []).extend(_swept(door, procedural_articulation(door.category, door.asset.extents), angle))
        return out

    for hole, object_id in zip(holes, ids, strict=True):
        fit = _fitted(hole, object_id, swept())
        if fit[2] < _limit(fit[1]) - 1e-9:  # a door hung before may give way: hung otherwise, no worse
            for k in range(len(fits)):
                mine = _fitted(hole, object_id, swept(skip=k))
                if mine[2] < _limit(mine[1]) - 1e-9:
                    continue
                theirs = _fitted(holes[k], ids[k], swept(skip=k, extra=mine))
                if theirs[2] >= fits[k][2] - 1e-9:
                    fits[k], fit = theirs, mine
                    break
        fits.append(fit)
    out: list[RoomDoor] = []
    for hole, (side, door, angle) in zip(holes, fits, strict=True):
        parts = procedural_articulation(door.category, door.asset.extents)
        if angle < _limit(door) - 1e-9:
            log.info(
                "room_door_fitted", door=door.id, room=side.room.id, open_deg=round(math.degrees(angle), 1),
                why="furniture, a wall or another door's leaf stands where the leaf would open to its limit",
            )  # fmt: skip
        rooms = tuple(s.room.id for s in hole.sides)
        out.append(RoomDoor(side.room.id, door, {p.name: p.clamped(angle) for p in parts}, rooms))
    return out


def _limit(door: SceneObject) -> float:
    """How far the leaves of ``door`` turn: the least of their upper limits."""
    return min(p.limits[1] for p in procedural_articulation(door.category, door.asset.extents))


def _delivered(door: RoomDoor, record: Mapping[str, Any], explicit: Mapping[str, float]) -> dict[str, float]:
    """The joint value of each leaf of ``door`` as ``record`` (an ``open_state`` record, possibly
    empty) delivers it: open when no state is recorded, shut for ``closed``, a drawn fraction of
    its open angle for ``random``; a value ``explicit`` gives wins (held within the limits)."""
    state = record.get("state")
    seed = record.get("seed", 0)
    seed = seed if isinstance(seed, int) and not isinstance(seed, bool) else 0
    out: dict[str, float] = {}
    for part in procedural_articulation(door.object.category, door.object.asset.extents):
        value = door.open_values[part.name]
        if part.name in explicit:
            value = part.clamped(explicit[part.name])
        elif state == "closed":
            value = 0.0
        elif state == "random":
            value *= opening(part, "random", seed=seed, key=door.object.id) / part.limits[1]
        if value != 0.0:
            out[part.name] = value
    return out


def room_door_values(scene: Scene | House, doors: Sequence[RoomDoor]) -> dict[str, dict[str, float]]:
    """The joint value (radians) each leaf of ``doors`` (:func:`room_door_leaves` of ``scene``) is
    delivered at, by door object id and part name, as the scene's ``open_state`` record delivers
    it (open when it records none, shut for ``closed``, a drawn fraction for ``random``, a value it
    sets wins); a shut leaf is left out."""
    record = scene.metadata.get(OPEN_STATE_KEY)
    record = record if isinstance(record, Mapping) else {}
    explicit = part_openings(scene)
    return {d.object.id: _delivered(d, record, explicit.get(d.object.id, {})) for d in doors}


def _with_values(metadata: Mapping[str, Any], values: Mapping[str, dict[str, float]]) -> dict[str, Any]:
    """``metadata`` with ``values`` added to its ``open_state`` record's parts (the record made
    when there is none: the exports read the parts from there)."""
    out = dict(metadata)
    record = metadata.get(OPEN_STATE_KEY)
    record = dict(record) if isinstance(record, Mapping) else {}
    parts = record.get("parts")
    merged: dict[str, Any] = dict(parts) if isinstance(parts, Mapping) else {}
    merged.update({k: dict(v) for k, v in values.items() if v})
    record["parts"] = merged
    out[OPEN_STATE_KEY] = record
    return out


def with_room_doors(scene: Scene | House) -> Scene | House:
    """``scene`` (a room, or a whole house, whose rooms' doors then join the room each swings
    into) with the door of every doorway added as an object held in place
    (:func:`room_door_leaves`), its leaves' joint values set in the ``open_state`` record as the
    record's state delivers them. What the simulator exports write; the scene itself, its files
    and its checks never hold these objects. A scene without doors, or whose doors hang already
    (it holds an object of a room door's category), is returned as it is (the same object)."""
    if any(o.category in _DOOR_CATEGORIES for o in scene.objects):
        return scene
    doors = room_door_leaves(scene)
    if not doors:
        return scene
    values = room_door_values(scene, doors)
    if isinstance(scene, Scene):
        objects = [*scene.objects, *(d.object for d in doors)]
        return scene.model_copy(update={"objects": objects, "metadata": _with_values(scene.metadata, values)})
    rooms: list[Scene] = []
    for room in scene.rooms:
        mine = [d for d in doors if d.room_id == room.id]
        if mine:
            room = room.model_copy(
                update={
                    "objects": [*room.objects, *(d.object for d in mine)],
                    "metadata": _with_values(room.metadata, {d.object.id: values[d.object.id] for d in mine}),
                }
            )
        rooms.append(room)
    return scene.model_copy(update={"rooms": rooms, "metadata": _with_values(scene.metadata, values)})

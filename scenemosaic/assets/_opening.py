"""The pose a scene's drawers, doors and lids are delivered in (``--open-state``).

A scene delivered other than closed records, in its metadata under :data:`OPEN_STATE_KEY`, the
state asked for, the seed it was drawn from and the joint value of every part that stands open::

    "open_state": {"state": "random", "seed": 7, "parts": {"dresser_1": {"drawer_0": 0.31}}}

Every export reads the values from there (:func:`part_openings`), so they agree with each other
and with ``scene.json``; a part not listed is closed, and a value is held within the part's
limits. What stands in a drawer (an object whose base lies in the drawer's box) is moved with
the drawer when the state is applied (:func:`open_scene`), so ``scene.json`` holds it where it
is delivered. A scene in the default pose (furniture closed, the rooms' doors open) carries no
such key, nor does a closed one without doors: its files are those of a scene that never heard of
open states; ``closed`` in a room with doors is recorded, for it shuts the doors too
(``with_room_doors``).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, overload

import numpy as np
import shapely

from scenemosaic.assets._articulation import OPEN_STATES, OpenState, PartSpec, opening, usable_value
from scenemosaic.assets._objects import object_articulation
from scenemosaic.scene import FloatArray, House, Scene, SceneObject

__all__ = [
    "OPEN_STATE_KEY",
    "SWEPT_SAMPLES",
    "kept_free",
    "open_part_footprints",
    "open_scene",
    "part_blockers",
    "part_openings",
    "part_reach",
    "parts_clear_of",
    "short_parts",
    "swept_footprints",
]

OPEN_STATE_KEY = "open_state"
"""The key of a scene's (and a house's) metadata holding the delivered pose of its parts."""

CONTENT_DROP_TOLERANCE_M = 0.02
"""How far below a drawer's box an object's base may lie and still count as standing in it, m."""

OPEN_CLEARANCE_M = 0.003
"""How much deeper than in its closed pose an opening part may reach into another object's box
(or its room's wall) and still count as free, m: under validation's 5 mm contact tolerance."""

SWEEP_STEP_RAD = math.radians(5.0)
"""Steps in which a hinge's path from closed to its delivered angle is checked for free space."""

SWEEP_STEP_M = 0.02
"""Steps in which a slide's path from closed to its delivered travel is checked for free space."""


def part_openings(scene: Scene | House) -> dict[str, dict[str, float]]:
    """Object id -> part name -> joint value, for every part ``scene``'s metadata lists open
    (``{}`` for a closed scene). The values are as recorded; clamp each with
    :meth:`PartSpec.clamped`."""
    record = scene.metadata.get(OPEN_STATE_KEY)
    if not isinstance(record, Mapping):
        return {}
    parts = record.get("parts")
    if not isinstance(parts, Mapping):
        return {}
    out: dict[str, dict[str, float]] = {}
    for object_id, values in parts.items():
        if isinstance(values, Mapping):
            out[str(object_id)] = {
                str(k): float(v)
                for k, v in values.items()
                if isinstance(v, int | float) and not isinstance(v, bool)
            }
    return out


def _moved_contents(
    objects: list[SceneObject], holder: SceneObject, part: PartSpec, before: float, after: float
) -> dict[str, SceneObject]:
    """The objects standing in drawer ``part`` of ``holder`` (at joint value ``before``), shifted
    with it to ``after``."""
    m = holder.pose.matrix(with_scale=False)
    axis = np.asarray(part.axis, dtype=np.float64)
    x0, x1, y0, y1, z0, z1 = part.box
    lo = np.array([x0, y0, z0 - CONTENT_DROP_TOLERANCE_M])
    hi = np.array([x1, y1, z1])
    shift = m[:3, :3] @ (axis * (after - before))
    out: dict[str, SceneObject] = {}
    for other in objects:
        if other.id == holder.id:
            continue
        local = m[:3, :3].T @ (np.asarray(other.pose.position, dtype=np.float64) - m[:3, 3]) - axis * before
        if bool(np.all(local >= lo - 1e-6)) and bool(np.all(local <= hi + 1e-6)):
            position = tuple(float(v) for v in np.asarray(other.pose.position) + shift)
            out[other.id] = other.model_copy(
                update={"pose": other.pose.model_copy(update={"position": position})}
            )
    return out


@dataclass(frozen=True)
class _Box:
    """An oriented box in the world: centre, axes (columns of ``rotation``) and half sizes."""

    centre: FloatArray
    rotation: FloatArray
    half: FloatArray

    def corners(self) -> FloatArray:
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
        out: FloatArray = self.centre + (signs * self.half) @ self.rotation.T
        return out


def _object_box(obj: SceneObject) -> _Box:
    """``obj``'s oriented bounding box (its asset's extents at its pose)."""
    m = obj.pose.matrix(with_scale=False)
    size = np.abs(obj.size)
    return _Box(m[:3, :3] @ np.array([0.0, 0.0, size[2] / 2]) + m[:3, 3], m[:3, :3], size / 2)


def _part_box(holder: SceneObject, part: PartSpec, value: float) -> _Box:
    """The box of ``part``'s pieces with its joint at ``value``, in the world."""
    x0, x1, y0, y1, z0, z1 = part.box
    m = holder.pose.matrix(with_scale=False) @ part.transform(value)
    centre = m[:3, :3] @ np.array([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2]) + m[:3, 3]
    return _Box(centre, m[:3, :3], np.array([(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2]))


RESTING_GAP_M = 0.02
"""How far above a closed part's top an object's base may lie and still count as lying on it, m."""


def _rests_on(box: _Box, part: _Box) -> bool:
    """Whether what ``box`` bounds lies on the closed part ``part``: its base within
    :data:`RESTING_GAP_M` of the part's top, and the two overlapping seen from above."""
    lo, hi = box.corners().min(axis=0), box.corners().max(axis=0)
    plo, phi = part.corners().min(axis=0), part.corners().max(axis=0)
    if not -RESTING_GAP_M <= lo[2] - phi[2] <= RESTING_GAP_M:
        return False
    return bool(np.all(np.minimum(hi[:2], phi[:2]) - np.maximum(lo[:2], plo[:2]) > 0.0))


def _reach(holder: SceneObject, part: PartSpec, target: float) -> tuple[FloatArray, float]:
    """A ball (centre, radius) holding every pose of ``part`` from closed to ``target``."""
    closed = _part_box(holder, part, 0.0)
    if part.joint == "hinge":  # every pose turns about the hinge line: a ball about a point on it
        m = holder.pose.matrix(with_scale=False)
        centre = m[:3, :3] @ np.asarray(part.anchor, dtype=np.float64) + m[:3, 3]
        return centre, float(np.max(np.linalg.norm(closed.corners() - centre, axis=1)))
    far = _part_box(holder, part, target)
    return (closed.centre + far.centre) / 2, float(np.linalg.norm(closed.half)) + target / 2


def _depth(a: _Box, b: _Box) -> float:
    """How deep two oriented boxes overlap: the least overlap over the separating-axis candidates
    (negative: the gap between them along the best axis)."""
    u, v = a.rotation.T[:, None, :], b.rotation.T[None, :, :]  # every axis of one across every axis of the other
    cross = np.stack(
        [u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1], u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2], u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]],
        axis=-1,
    ).reshape(9, 3)
    norms = np.linalg.norm(cross, axis=1)
    axes = np.vstack([a.rotation.T, b.rotation.T, cross[norms > 1e-9] / norms[norms > 1e-9, None]])
    reach = np.abs(axes @ a.rotation) @ a.half + np.abs(axes @ b.rotation) @ b.half
    return float(np.min(reach - np.abs(axes @ (b.centre - a.centre))))


def _outside(floor: Any, box: _Box) -> float:
    """How far the box's farthest corner lies outside the room's floor polygon (a shapely polygon),
    m (0: inside, or no room)."""
    if floor is None:
        return 0.0
    corners = box.corners()
    return float(np.max(shapely.distance(floor, shapely.points(corners[:, :2]))))


class _FreeSpace:
    """What an opening part of a scene may not reach into: every other object's box and the room's
    walls (its floor polygon), plus the parts already opened; a part's closed pose sets how much
    it overlaps them to begin with (a nightstand touching a wardrobe), so only going deeper counts."""

    def __init__(self, scene: Scene) -> None:
        self.objects = {o.id: _object_box(o) for o in scene.objects}
        self.bases = {o.id: np.asarray(o.pose.position, dtype=np.float64) for o in scene.objects}
        self.floor = shapely.Polygon(scene.room.floor) if scene.room is not None else None
        self.opened: list[tuple[str, _Box]] = []

    def obstacles(self, holder: SceneObject, part: PartSpec) -> list[tuple[str, _Box]]:
        """What ``part`` of ``holder`` may not reach into, by object id: every other object's box
        (but a drawer's contents, which move with it) and the parts of other objects opened before."""
        m = holder.pose.matrix(with_scale=False)
        x0, x1, y0, y1, z0, z1 = part.box
        lo, hi = np.array([x0, y0, z0 - CONTENT_DROP_TOLERANCE_M]), np.array([x1, y1, z1])
        out = []
        for oid, box in self.objects.items():
            if oid == holder.id:
                continue
            if part.joint == "slide":  # standing in the drawer (as ``_moved_contents`` finds them)
                base = m[:3, :3].T @ (self.bases[oid] - m[:3, 3])
                if bool(np.all(base >= lo - 1e-6)) and bool(np.all(base <= hi + 1e-6)):
                    continue
            out.append((oid, box))
        return out + [(oid, b) for oid, b in self.opened if oid != holder.id]

    def _sweep(
        self, holder: SceneObject, part: PartSpec, target: float, walls_until: float | None = None
    ) -> tuple[float, set[str]]:
        """The largest free joint value up to ``target`` and what stops the part there (object ids,
        ``"wall"``; empty when nothing does). ``walls_until``: past this value the room's walls no
        longer count (a lid may lean on the wall behind once it stands open)."""
        if target <= 0.0:
            return target, set()
        closed = _part_box(holder, part, 0.0)
        obstacles = self.obstacles(holder, part)
        lying = {oid for oid, box in obstacles if _rests_on(box, closed)} if part.joint == "hinge" else set()
        if lying:
            return 0.0, lying  # a lid or door with something lying on it stays shut
        centre, radius = _reach(holder, part, target)
        obstacles = [
            (oid, b)
            for oid, b in obstacles
            if np.linalg.norm(b.centre - centre) < radius + np.linalg.norm(b.half)
        ]
        start = [max(_depth(closed, b), 0.0) for _, b in obstacles]
        wall0 = _outside(self.floor, closed)

        def hits(value: float) -> set[str]:
            box = _part_box(holder, part, value)
            walls = walls_until is None or value <= walls_until + 1e-9
            out = {"wall"} if walls and _outside(self.floor, box) > wall0 + OPEN_CLEARANCE_M else set()
            return out | {
                oid
                for (oid, b), d in zip(obstacles, start, strict=True)
                if _depth(box, b) > d + OPEN_CLEARANCE_M
            }

        step = SWEEP_STEP_RAD if part.joint == "hinge" else SWEEP_STEP_M
        samples = [*(k * step for k in range(1, int(target / step) + 1)), target]
        good = 0.0
        for value in samples:
            stoppers = hits(value)
            if stoppers:
                low, high = good, value
                for _ in range(4):  # narrowed to 1/16 of a step
                    mid = (low + high) / 2
                    low, high = (mid, high) if not hits(mid) else (low, mid)
                return low, stoppers
            good = value
        return target, set()

    def largest_free(self, holder: SceneObject, part: PartSpec, target: float) -> float:
        """The largest joint value up to ``target`` that ``part`` reaches on its path from closed
        without going deeper into anything than it was closed (0: it cannot open at all)."""
        return self._sweep(holder, part, target)[0]

    def stoppers(self, holder: SceneObject, part: PartSpec, target: float) -> set[str]:
        """What stops ``part`` before ``target``: object ids, ``"wall"`` (empty: nothing does)."""
        return self._sweep(holder, part, target)[1]

    def in_use(self, holder: SceneObject, part: PartSpec) -> set[str]:
        """What stands in the way ``part`` takes when it is used (:func:`kept_free`): object ids,
        ``"wall"`` (empty: nothing does)."""
        return self._sweep(holder, part, kept_free(part), usable_value(part))[1]

    def open(self, holder: SceneObject, part: PartSpec, value: float) -> None:
        """Count ``part`` opened to ``value`` among what later parts may not reach into."""
        if value > 0.0:
            self.opened.append((holder.id, _part_box(holder, part, value)))


def short_parts(
    scene: Scene,
    base_dir: str | Path | None = None,
    object_ids: Collection[str] | None = None,
    *,
    near: Collection[str] | None = None,
) -> dict[str, list[str]]:
    """The parts whose path from closed is not free as far as their use needs (:func:`kept_free`), by
    object id (of ``object_ids``, default every object): each part's box swept from
    closed against the room's walls and every other object's box, every other part closed (the
    model of the delivered open states, :func:`open_scene`); objects whose parts all open are left
    out. ``near`` (object ids) keeps only the parts whose path may come near one of those objects
    (the parts a move of those objects can block or free: what a layout that moves them is checked
    for)."""
    space: _FreeSpace | None = None
    out: dict[str, list[str]] = {}
    movers = [_object_box(scene.get(oid)) for oid in near or ()]
    for holder in scene.objects:
        if object_ids is not None and holder.id not in object_ids:
            continue
        parts = object_articulation(holder, base_dir)
        if not parts:
            continue
        if near is not None:
            parts = [p for p in parts if holder.id in near or _comes_near(holder, p, movers)]
            if not parts:
                continue
        space = space or _FreeSpace(scene)
        short = [p.name for p in parts if space.in_use(holder, p)]
        if short:
            out[holder.id] = sorted(short)
    return out


def kept_free(part: PartSpec) -> float:
    """How far ``part``'s path must be free of other objects for it to be used: open for use
    (:func:`usable_value`), and for a hinge whose line lies level (a lid) its whole range, for a
    lid is left open at its stop, past upright, where it would knock over what stands behind it
    (soap on a toilet's cistern); the room's walls count up to open for use only (a lid may lean
    on the wall behind)."""
    return float(part.limits[1]) if part.level else usable_value(part)


def _comes_near(holder: SceneObject, part: PartSpec, boxes: list[_Box]) -> bool:
    """Whether ``part``'s path from closed to open for use may reach one of ``boxes``."""
    centre, radius = _reach(holder, part, kept_free(part))
    return any(
        float(np.linalg.norm(b.centre - centre)) < radius + float(np.linalg.norm(b.half)) for b in boxes
    )


def part_blockers(scene: Scene, object_id: str, base_dir: str | Path | None = None) -> dict[str, list[str]]:
    """For each part of ``object_id`` that does not open as far as its use needs
    (:func:`kept_free`): what stops it (object ids, ``"wall"`` for the room's walls), by the model
    of :func:`short_parts`."""
    space = _FreeSpace(scene)
    holder = scene.get(object_id)
    out = {}
    for part in object_articulation(holder, base_dir):
        stoppers = space.in_use(holder, part)
        if stoppers:
            out[part.name] = sorted(stoppers)
    return out


def parts_clear_of(
    scene: Scene, object_id: str, other_id: str, base_dir: str | Path | None = None, margin: float = 0.0
) -> bool:
    """Whether every part of ``object_id`` passes ``other_id`` on its way open for use
    (:func:`kept_free`) with ``margin`` metres to spare sideways (the other object's box grown by it
    across, not in height): what a repair that moves ``other_id`` out of a part's way asks, with a
    margin so that the object's settling cannot bring it back."""
    holder, other = scene.get(object_id), _object_box(scene.get(other_id))
    grown = _Box(other.centre, other.rotation, other.half + np.array([margin, margin, 0.0]))
    space = _FreeSpace(scene)
    space.objects = {other_id: grown}
    space.floor = None
    return not any(space.in_use(holder, part) for part in object_articulation(holder, base_dir))


def part_reach(obj: SceneObject, base_dir: str | Path | None = None) -> tuple[float, float]:
    """How far the parts of ``obj`` reach out of its box on their way open for use (:func:`kept_free`),
    in its own frame: ``(front, side)``, metres past its front face (a door as wide as it swings
    out) and past either of its sides (a door's edge at its hinge); ``(0, 0)`` for an object
    without parts. What the space kept in front of a piece must hold."""
    half = np.abs(np.asarray(obj.size, dtype=np.float64)) / 2
    front = side = 0.0
    for part in object_articulation(obj, base_dir):
        x0, x1, y0, y1, z0, z1 = part.box
        local = np.array([[x, y, z, 1.0] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)])
        for k in range(SWEPT_SAMPLES):
            pts = (part.transform(kept_free(part) * k / (SWEPT_SAMPLES - 1)) @ local.T).T
            front = max(front, float(-pts[:, 1].min()) - half[1])
            side = max(side, float(np.abs(pts[:, 0]).max()) - half[0])
    return max(front, 0.0), max(side, 0.0)


SWEPT_SAMPLES = 7
"""Poses of a part (closed to its usable opening, evenly) whose boxes stand for its swept space."""


def swept_footprints(
    scene: Scene,
    low: float,
    high: float,
    near: tuple[float, float, float, float] | None = None,
    base_dir: str | Path | None = None,
    *,
    skip: str | None = None,
) -> list[FloatArray]:
    """Seen from above, where the parts of ``scene`` pass on their way from closed to open for use
    (:func:`kept_free`) between the heights ``low`` and ``high``: one convex footprint (its XY
    corners) per sampled pose of each part whose box reaches into that band. ``near``
    (``minx, miny, maxx, maxy``) leaves out the parts that never come near that rectangle, ``skip``
    the parts of one object (the drawer a surface lies in). What clutter keeps free on a surface (a
    microwave's door on a counter, a toilet's lid over its tank)."""
    out: list[FloatArray] = []
    for holder in scene.objects:
        if holder.id == skip:
            continue
        for part in object_articulation(holder, base_dir):
            upper = kept_free(part)
            if near is not None:
                centre, radius = _reach(holder, part, upper)
                minx, miny, maxx, maxy = near
                dx = max(minx - centre[0], 0.0, centre[0] - maxx)
                dy = max(miny - centre[1], 0.0, centre[1] - maxy)
                if math.hypot(dx, dy) > radius:
                    continue
            for k in range(SWEPT_SAMPLES):
                corners = _part_box(holder, part, upper * k / (SWEPT_SAMPLES - 1)).corners()
                if corners[:, 2].max() <= low + 0.01 or corners[:, 2].min() >= high:
                    continue
                out.append(np.asarray(shapely.MultiPoint(corners[:, :2]).convex_hull.exterior.coords)[:-1])
    return out


def open_part_footprints(scene: Scene, low: float, high: float, base_dir: str | Path | None = None) -> list[FloatArray]:
    """Seen from above, where the parts ``scene`` delivers open stand (:func:`part_openings`, each
    value held within its part's limits) between the heights ``low`` and ``high``: one convex
    footprint (its XY corners) per open part whose box reaches into that band. What a room's door
    is hung clear of besides the furniture's closed boxes (a drawer delivered open)."""
    opened = part_openings(scene)
    out: list[FloatArray] = []
    for holder in scene.objects:
        values = opened.get(holder.id)
        if not values:
            continue
        for part in object_articulation(holder, base_dir):
            if part.name not in values or part.clamped(values[part.name]) == 0.0:
                continue
            corners = _part_box(holder, part, part.clamped(values[part.name])).corners()
            if corners[:, 2].max() <= low + 0.01 or corners[:, 2].min() >= high:
                continue
            out.append(np.asarray(shapely.MultiPoint(corners[:, :2]).convex_hull.exterior.coords)[:-1])
    return out


def _hangs_doors(scene: Scene) -> bool:
    """Whether a door leaf hangs in one of the room's walls (``docs/articulation.md``)."""
    return scene.room is not None and any(op.leaf_count > 0 for w in scene.room.walls for op in w.openings)


def _recorded(state: OpenState | None, scene: Scene) -> bool:
    """Whether ``state`` is written down: ``open`` and ``random`` always, ``closed`` where the
    room's doors hang in it (they are delivered open unless told), the default (``None``) never."""
    return state is not None and (state != "closed" or _hangs_doors(scene))


@overload
def open_scene(scene: Scene, state: OpenState | None, seed: int = 0, base_dir: str | Path | None = None) -> Scene: ...


@overload
def open_scene(scene: House, state: OpenState | None, seed: int = 0, base_dir: str | Path | None = None) -> House: ...


def open_scene(
    scene: Scene | House, state: OpenState | None, seed: int = 0, base_dir: str | Path | None = None
) -> Scene | House:
    """``scene`` with its parts in ``state`` (``random`` drawn from ``seed``, see
    :func:`~scenemosaic.assets.opening`): the metadata key :data:`OPEN_STATE_KEY` set and what
    stands in each drawer moved with it, from the pose the scene held before. ``None`` is the
    default pose: the furniture closed and the key dropped, so the room's doors are delivered open
    (``with_room_doors``); ``closed`` closes those too, so it records the key in a room with doors
    and drops it elsewhere. ``base_dir`` resolves mesh assets' relative uris (their declared
    parts). A scene that is closed and stays so, its key unchanged, is returned as it is (the same
    object). A :class:`~scenemosaic.scene.House` has every room opened, its own metadata recording
    the state too (its ``parts`` every room's together) when a room records it."""
    if isinstance(scene, House):  # every room, the house recording the state too
        return _open_house(scene, state, seed, base_dir)
    if state is not None and state not in OPEN_STATES:
        raise ValueError(f"open state must be one of {', '.join(OPEN_STATES)}, not {state!r}")
    furniture: OpenState = state if state is not None else "closed"
    before = part_openings(scene)
    objects = list(scene.objects)
    values: dict[str, dict[str, float]] = {}
    space = _FreeSpace(scene) if furniture != "closed" else None
    for holder in scene.objects:
        for part in object_articulation(holder, base_dir):
            value = part.clamped(opening(part, furniture, seed=seed, key=holder.id))
            if space is not None:  # only as far as its path is free (else it stays closed)
                value = space.largest_free(holder, part, value)
                space.open(holder, part, value)
            old = part.clamped(before.get(holder.id, {}).get(part.name, 0.0))
            if value != 0.0:
                values.setdefault(holder.id, {})[part.name] = value
            if part.joint == "slide" and value != old:
                moved = _moved_contents(objects, holder, part, old, value)
                objects = [moved.get(o.id, o) for o in objects]
    metadata = {k: v for k, v in scene.metadata.items() if k != OPEN_STATE_KEY}
    if _recorded(state, scene):
        metadata[OPEN_STATE_KEY] = {"state": state, "seed": seed, "parts": values}
    if furniture == "closed" and metadata.get(OPEN_STATE_KEY) == scene.metadata.get(OPEN_STATE_KEY):
        return scene
    return scene.model_copy(update={"objects": objects, "metadata": metadata})


def _open_house(house: House, state: OpenState | None, seed: int, base_dir: str | Path | None) -> House:
    """:func:`open_scene` of a whole house."""
    rooms = [open_scene(room, state, seed, base_dir) for room in house.rooms]
    metadata: dict[str, Any] = {k: v for k, v in house.metadata.items() if k != OPEN_STATE_KEY}
    if any(_recorded(state, room) for room in house.rooms):
        parts: dict[str, dict[str, float]] = {}
        for room in rooms:
            parts.update(part_openings(room))
        metadata[OPEN_STATE_KEY] = {"state": state, "seed": seed, "parts": parts}
    if (
        (state is None or state == "closed")
        and metadata.get(OPEN_STATE_KEY) == house.metadata.get(OPEN_STATE_KEY)
        and all(r is o for r, o in zip(rooms, house.rooms, strict=True))
    ):
        return house
    return house.model_copy(update={"rooms": rooms, "metadata": metadata})

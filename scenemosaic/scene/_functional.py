"""Functional relations: what a room's pieces do for each other, read from the geometry.

A scene's support relations say what rests on what. The relations here say what a person
would notice if a variant broke them: a seat **faces** its table, a sofa its TV and the TV the
sofa; a ceiling lamp hangs **over** a group (a dining table, a bed, a seating group), and a wall
TV, picture or mirror over a piece that stands against a wall (a bed, a sofa, a TV stand, a dresser); a rug lies **under** one; a nightstand stands **beside** its bed's head, and two
nightstands **flank** the bed. They are found in a base scene by :func:`functional_relations`
and checked in a variant by :func:`functional_holds`; RelKeep per kind counts them.

The ``over`` and ``under`` relations tie pieces of different units together (a lamp of the
ceiling unit, a rug of the floor unit, a picture of a wall unit, each over or under floor
furniture). :func:`follow_leaders` moves such a piece with its group's leader, so composition
can keep it where it belongs whatever the floor's variant does.

Thresholds are named here and documented in ``docs/evolution.md``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from scenemosaic.scene._categories import is_bed, normalize_category, traits
from scenemosaic.scene._geometry import FloatArray, front_vector, quat_from_yaw, quat_multiply
from scenemosaic.scene._ids import CEILING, FLOOR
from scenemosaic.scene._model import Pose, Scene, SceneObject, Wall
from scenemosaic.scene._tree import build_structure, with_world_poses
from scenemosaic.scene._walkable import is_thin

__all__ = [
    "BEHIND_DEG",
    "FACES_DEG",
    "FACES_REACH_M",
    "FUNCTIONAL_KINDS",
    "HEADBOARD_WALL_M",
    "OPENING_CLEAR_M",
    "OVER_MARGIN_M",
    "SCREEN_REACH_M",
    "Functional",
    "FunctionalKind",
    "backing_walls",
    "faces",
    "fits_wall",
    "follow_leaders",
    "functional_holds",
    "functional_relations",
    "on_backing_wall",
    "points_at",
    "screens_behind",
]

FunctionalKind = Literal["faces", "over", "under", "beside", "flanks"]
FUNCTIONAL_KINDS: tuple[FunctionalKind, ...] = ("faces", "over", "under", "beside", "flanks")

OVER_MARGIN_M = 0.3
"""A piece hangs over (or lies under) a group when its centre is inside the group's footprints
grown by this much, metres."""
FACES_DEG = 20.0
"""A piece faces another when its front points at it: the line from its centre along its front
crosses the other's footprint, or the other's centre is within this many degrees of that line."""
FACES_REACH_M = 1.0
"""A seat faces a table, desk or coffee table only within this footprint distance, metres."""
SCREEN_REACH_M = 6.0
"""A seat and a TV (or TV stand) face each other only within this distance, metres."""
BESIDE_GAP_M = 0.35
"""A nightstand is beside its bed when its box is at most this far from the bed's side..."""
BESIDE_HEAD_M = 0.75
"""... and its centre within this distance of the bed's head end, metres."""
FOLLOW_TURN_DEG = 1.0
"""A wall piece follows its group along the wall only while the group keeps its heading."""
FOLLOW_WALL_M = 0.05
"""... and stays as far from that wall as in the base, within this many metres."""
REHANG_GAP_M = 0.3
"""A group that turned or left its wall carries its wall piece to the wall its leader now backs
onto: the wall within this many metres of the leader's back..."""
REHANG_FACING_DEG = 30.0
"""... with the leader's front within this many degrees of the wall's inward normal."""
HEADBOARD_WALL_M = 0.3
"""A bed backs onto a wall when its back is within this many metres of it and its front within
``REHANG_FACING_DEG`` of the wall's inward normal (the wall behind its head)."""
OPENING_CLEAR_M = 0.05
"""A re-hung wall piece keeps this far, metres, from the doors and windows of its new wall."""

_NIGHTSTANDS = frozenset({"nightstand"})
_SCREENS = frozenset({"tv_stand", "television"})
_HANGING = frozenset({"pendant_lamp", "ceiling_lamp", "chandelier"})
_WALL_OVER = frozenset({"painting", "picture", "mirror", "television", "wall_clock"})


@dataclass(frozen=True)
class Functional:
    """One functional relation: ``subject`` does ``kind`` to ``group`` (led by ``leader``)."""

    kind: FunctionalKind
    subject: str
    group: tuple[str, ...]
    leader: str
    """The group's main piece: the one whose motion an ``over``/``under`` subject follows, the
    one a ``faces``/``beside`` subject turns to, the bed two nightstands flank."""

    @property
    def follows(self) -> bool:
        """Whether the subject moves with its leader (``over`` and ``under``)."""
        return self.kind in ("over", "under")



def _cat(o: SceneObject) -> str:
    return normalize_category(o.category)


def _is_bed(o: SceneObject) -> bool:
    return is_bed(o.category)


def _foot(o: SceneObject) -> Polygon:
    return Polygon(o.footprint())


def _xy(o: SceneObject) -> FloatArray:
    return np.asarray(o.pose.position[:2], dtype=np.float64)


def _front(o: SceneObject) -> FloatArray:
    f = front_vector(o.pose.quaternion)[:2]
    n = float(np.linalg.norm(f))
    return f / n if n > 1e-9 else np.array([0.0, -1.0])


def _on_floor(scene: Scene, o: SceneObject) -> bool:
    r = scene.support_of(o.id)
    return r is None or r.parent == FLOOR


def _lounge(o: SceneObject) -> bool:
    """Sofas and armchairs: the seats that face a TV (a dining or desk chair does not)."""
    t = traits(o.category)
    return t.seat and (t.against_wall or t.supports)


def _leaders(scene: Scene) -> list[SceneObject]:
    """Floor furniture a piece can hang over or lie under: beds, tables, desks, seats, TV stands."""
    out = []
    for o in scene.objects:
        if not _on_floor(scene, o) or is_thin(o):
            continue
        t = traits(o.category)
        if _is_bed(o) or t.table or t.seat or _cat(o) in ("coffee_table", "tv_stand"):
            out.append(o)
    return out


def points_at(centre: FloatArray, front: FloatArray, outline: Polygon, target_centre: FloatArray) -> bool:
    """Whether a piece at ``centre`` whose front is the unit vector ``front`` points at a target
    with footprint ``outline`` and centre ``target_centre`` (any plane frame; see :data:`FACES_DEG`).
    The one definition of facing, for scenes and for the evolution's unit layouts."""
    c = np.asarray(centre, dtype=np.float64)
    f = np.asarray(front, dtype=np.float64)
    if outline.contains(Point(c)):
        return True
    if LineString([c, c + f * (SCREEN_REACH_M + 2.0)]).intersects(outline):
        return True
    d = np.asarray(target_centre, dtype=np.float64) - c
    n = float(np.linalg.norm(d))
    return n < 1e-9 or math.degrees(math.acos(max(-1.0, min(1.0, float(d @ f) / n)))) <= FACES_DEG


def faces(subject: SceneObject, target: SceneObject) -> bool:
    """Whether ``subject``'s front points at ``target`` (:func:`points_at`)."""
    return points_at(_xy(subject), _front(subject), _foot(target), _xy(target))


def _bed_frame(bed: SceneObject) -> tuple[FloatArray, FloatArray, FloatArray, float, float]:
    f = _front(bed)
    lat = np.array([f[1], -f[0]])
    poly = bed.footprint() - _xy(bed)
    return _xy(bed), f, lat, float(np.ptp(poly @ f)), float(np.ptp(poly @ lat))


def _beside(stand: SceneObject, bed: SceneObject) -> float | None:
    """The side (+1/-1 along the bed's lateral axis) a nightstand stands on beside the bed's
    head, or ``None`` when it is not there."""
    c, f, lat, depth, width = _bed_frame(bed)
    rel = _xy(stand) - c
    half = float(np.ptp((stand.footprint() - _xy(stand)) @ lat)) / 2
    gap = abs(float(rel @ lat)) - width / 2 - half
    if -0.02 <= gap <= BESIDE_GAP_M and float(rel @ -f) >= depth / 2 - BESIDE_HEAD_M:
        return 1.0 if float(rel @ lat) >= 0 else -1.0
    return None


def _under_group(piece: SceneObject, leaders: Sequence[SceneObject]) -> list[SceneObject]:
    """The leaders whose footprint, grown by ``OVER_MARGIN_M``, holds the piece's centre."""
    centre = Point(_xy(piece))
    return [o for o in leaders if o.id != piece.id and _foot(o).buffer(OVER_MARGIN_M).contains(centre)]


def _group_of(rug: SceneObject, leaders: Sequence[SceneObject]) -> list[SceneObject]:
    area = _foot(rug)
    return [o for o in leaders if area.contains(Point(_xy(o)))]


def _sorted_group(group: Iterable[SceneObject]) -> tuple[tuple[str, ...], str]:
    members = sorted(group, key=lambda o: (-float(_foot(o).area), o.id))
    return tuple(sorted(o.id for o in members)), members[0].id


def functional_relations(scene: Scene) -> list[Functional]:
    """Every functional relation that holds in ``scene`` (found from its geometry, sorted)."""
    leaders = _leaders(scene)
    wall_leaders = [
        o for o in scene.objects
        if _on_floor(scene, o) and not is_thin(o) and traits(o.category).against_wall and _cat(o) not in _NIGHTSTANDS
    ]  # fmt: skip
    out: list[Functional] = []
    for o in scene.objects:
        r = scene.support_of(o.id)
        parent = r.parent if r is not None else FLOOR
        cat = _cat(o)
        # what hangs from the ceiling (in a scene not yet structured: a lamp of a hanging kind), not a lamp on a table
        hanging = parent == CEILING or (r is None and cat in _HANGING)
        on_wall = parent not in (FLOOR, CEILING) and scene.anchor_kind(parent) == "wall" and cat in _WALL_OVER
        if hanging or on_wall:
            # a wall piece serves a piece that stands against a wall (a bed, a sofa, a TV stand, a
            # dresser), not a chair that happens to stand below it
            pool = wall_leaders if on_wall else leaders
            if on_wall and cat == "television":  # a TV serves its stand or cabinet, not a bed or a sofa it would hang behind
                pool = [g for g in wall_leaders if traits(g.category).contains]
            below = [g for g in _under_group(o, pool) if float(g.aabb()[1][2]) <= float(o.aabb()[0][2]) + 0.05]
            if below:
                group, leader = _sorted_group(below)
                out.append(Functional("over", o.id, group, leader))
        elif parent == FLOOR and is_thin(o):
            on = _group_of(o, leaders)
            if on:
                group, leader = _sorted_group(on)
                out.append(Functional("under", o.id, group, leader))
    for o in leaders:
        t = traits(o.category)
        if not (t.seat or _cat(o) in _SCREENS):
            continue
        near: list[tuple[float, str]] = []
        screens: list[tuple[float, str]] = []
        for k in scene.objects:
            if k.id == o.id or (not _on_floor(scene, k) and _cat(k) not in _SCREENS):
                continue
            kt = traits(k.category)
            d = float(_foot(o).distance(_foot(k)))
            if t.seat and (kt.table or _cat(k) == "coffee_table") and d <= FACES_REACH_M and faces(o, k):
                near.append((d, k.id))
            elif ((_lounge(o) and _cat(k) in _SCREENS) or (_cat(o) in _SCREENS and _lounge(k))) and d <= SCREEN_REACH_M and faces(o, k):
                screens.append((d, k.id))
        for found in (near, screens):
            if found:
                target = min(found)[1]
                out.append(Functional("faces", o.id, (target,), target))
    for bed in (o for o in scene.objects if _is_bed(o)):
        sides: dict[float, str] = {}
        for stand in (o for o in scene.objects if _cat(o) in _NIGHTSTANDS):
            side = _beside(stand, bed)
            if side is not None:
                out.append(Functional("beside", stand.id, (bed.id,), bed.id))
                sides.setdefault(side, stand.id)
        if len(sides) == 2:
            out.append(Functional("flanks", bed.id, tuple(sorted(sides.values())), bed.id))
    return sorted(out, key=lambda f: (FUNCTIONAL_KINDS.index(f.kind), f.subject, f.group))


BEHIND_DEG = 60.0
"""A screen stands behind a bed or a lounge seat when the direction from the piece to the screen
lies within this many degrees of the piece's back (its front turned round): the sleeper's head or
the sitter's back is to it."""


def _watchers(scene: Scene) -> list[SceneObject]:
    """The pieces one watches a screen from: beds and lounge seats (sofas, armchairs) on the floor."""
    return [o for o in scene.objects if _on_floor(scene, o) and (_is_bed(o) or _lounge(o))]


def _screens(scene: Scene) -> list[SceneObject]:
    """The room's screens: its televisions, else (a room whose TV is part of its stand) its TV stands."""
    tvs = [o for o in scene.objects if _cat(o) == "television"]
    return tvs or [o for o in scene.objects if _cat(o) == "tv_stand"]


def screens_behind(scene: Scene) -> list[tuple[str, str]]:
    """``(piece id, screen id)`` for every bed or lounge seat with a screen behind its back: the
    screen within :data:`SCREEN_REACH_M` of it, in the direction of its back (within
    :data:`BEHIND_DEG`) and turned to the piece's side of it (its front leads towards the piece):
    a TV on the wall a bed's head stands against, a sofa backed onto the TV it was grouped to
    watch. A screen at the foot of the bed, or on a side wall, is not behind; nor is one whose
    back is to the piece too (two pieces back to back)."""
    out = []
    screens = _screens(scene)
    for piece in _watchers(scene):
        centre, front, outline = _xy(piece), _front(piece), _foot(piece)
        for screen in screens:
            d = _xy(screen) - centre
            n = float(np.linalg.norm(d))
            if n < 1e-9 or float(outline.distance(_foot(screen))) > SCREEN_REACH_M:
                continue
            behind = math.degrees(math.acos(max(-1.0, min(1.0, float(d @ -front) / n)))) <= BEHIND_DEG
            if behind and float(_front(screen) @ -d) > 0.0:
                out.append((piece.id, screen.id))
    return sorted(out)


def backing_walls(scene: Scene) -> list[tuple[str, str]]:
    """``(wall id, piece id)`` for every bed and sofa backing onto a wall: its back within
    :data:`HEADBOARD_WALL_M` of it, its front within ``REHANG_FACING_DEG`` of the wall's inward normal."""
    if scene.room is None:
        return []
    out = []
    cos_max = math.cos(math.radians(REHANG_FACING_DEG))
    for piece in (o for o in scene.objects if (_is_bed(o) and "dog" not in _cat(o)) or "sofa" in _cat(o)):
        f, corners = _front(piece), piece.corners()
        for w in scene.room.walls:
            if float(f @ w.inward_normal) >= cos_max and -0.02 <= w.gap(corners) <= HEADBOARD_WALL_M:
                out.append((w.id, piece.id))
    return out


def on_backing_wall(scene: Scene, object_id: str, kind: str | None = None) -> str | None:
    """The bed or sofa (``kind``: ``"bed"`` or ``"sofa"`` only) backing onto the stretch of wall
    ``object_id`` hangs on (their spans along that wall overlap), else ``None``: a TV there faces
    the way the bed or sofa does."""
    rel = scene.support_of(object_id)
    if scene.room is None or rel is None or rel.parent in (FLOOR, CEILING) or scene.anchor_kind(rel.parent) != "wall":
        return None
    wall = scene.room.wall(rel.parent)
    start, t = np.asarray(wall.start, dtype=np.float64), wall.direction

    def span(o: SceneObject) -> tuple[float, float]:
        a = (o.corners()[:, :2] - start) @ t
        return float(a.min()), float(a.max())

    lo, hi = span(scene.get(object_id))
    for wid, piece in backing_walls(scene):
        if wid == wall.id and (kind is None or kind in _cat(scene.get(piece))):
            blo, bhi = span(scene.get(piece))
            if hi > blo and lo < bhi:
                return piece
    return None


def functional_holds(scene: Scene, rel: Functional) -> bool:
    """Whether ``rel`` (found in a base scene) still holds in ``scene``."""
    try:
        subject = scene.get(rel.subject)
        group = [scene.get(g) for g in rel.group]
    except KeyError:
        return False
    if rel.kind in ("over", "under"):
        area = unary_union([_foot(g).buffer(OVER_MARGIN_M) for g in group])
        return bool(area.contains(Point(_xy(subject))))
    if rel.kind == "faces":
        return faces(subject, group[0])
    if rel.kind == "beside":
        return _beside(subject, group[0]) is not None
    sides = {_beside(s, subject) for s in group}
    return None not in sides and len(sides) == 2


def _yaw(o: SceneObject) -> float:
    f = _front(o)
    return math.atan2(float(f[0]), float(-f[1]))


def follow_leaders(base: Scene, scene: Scene, relations: Sequence[Functional]) -> Scene | None:
    """``scene`` with every ``over``/``under`` subject moved as its leader moved from ``base``:
    a hanging lamp or a rug turns and shifts with its group; a wall piece slides along its wall
    as far as the group slid along it, or, when the group turned or left that wall, is re-hung on
    the wall the leader now backs onto (same height, same distance from the wall, the same offset
    beside the leader, else that offset mirrored, else centred on the leader (:data:`_SIDES`),
    facing into the room, clear of that wall's doors and windows; its support relation names the
    new wall). The follower keeps its offset in the leader's frame, or that
    offset mirrored across the leader's axes (a table reads the same mirrored either way, a bed
    only left to right: a mirrored variant mirrors the lamp too), or, last, its heading and world
    offset: the first that keeps it over its group and inside the room is taken. ``None``
    when a subject cannot follow (no wall behind its group's leader takes it, or no way keeps
    it in the room). A subject whose leader did not move is back at its base pose, whatever its
    own unit's variant did."""
    targets: dict[str, Pose] = {}
    walls: dict[str, str] = {}
    inside = Polygon(base.room.floor).buffer(1e-3) if base.room is not None else None
    for rel in relations:
        if not rel.follows:
            continue
        try:
            lead0, lead1 = base.get(rel.leader), scene.get(rel.leader)
            sub0 = base.get(rel.subject)
            group = [scene.get(g) for g in rel.group]
        except KeyError:
            continue
        found = _follow(base, rel, lead0, lead1, sub0, group, inside)
        if found is None:
            return None
        target, wall = found
        now = scene.get(rel.subject).pose
        if not (np.allclose(now.position, target.position, atol=1e-9) and np.allclose(now.quaternion, target.quaternion, atol=1e-9)):
            targets[rel.subject] = target
        current = scene.support_of(rel.subject)
        if wall is not None and current is not None and current.parent != wall:
            walls[rel.subject] = wall
    out = with_world_poses(scene, targets) if targets else scene
    return _rehung(out, walls) if walls else out


def _rehung(scene: Scene, walls: Mapping[str, str]) -> Scene:
    """``scene`` with the wall relations (support and ``against``) of the pieces in ``walls``
    naming their new wall, and its structure rebuilt to match."""
    relations = []
    for r in scene.relations:
        if r.child in walls and r.parent != walls[r.child] and scene.anchor_kind(r.parent) == "wall":
            r = r.model_copy(update={"parent": walls[r.child]})
        relations.append(r)
    out = scene.model_copy(update={"relations": relations})
    if scene.structure is not None:
        out = out.model_copy(update={"structure": build_structure(out)})
    return out


def _follow(
    base: Scene, rel: Functional, lead0: SceneObject, lead1: SceneObject, sub0: SceneObject, group: list[SceneObject], inside: Polygon | None
) -> tuple[Pose, str | None] | None:
    """Where the subject goes, and the wall it hangs on when it is a wall piece (``None`` else)."""
    turn = _yaw(lead1) - _yaw(lead0)
    shift = _xy(lead1) - _xy(lead0)
    r = base.support_of(rel.subject)
    parent = r.parent if r is not None else FLOOR
    pos = np.asarray(sub0.pose.position, dtype=np.float64).copy()
    if parent not in (FLOOR, CEILING) and base.anchor_kind(parent) == "wall":
        assert base.room is not None
        wall = base.room.wall(parent)
        turned = abs(math.degrees(math.atan2(math.sin(turn), math.cos(turn)))) > FOLLOW_TURN_DEG
        if turned or abs(wall.gap(lead1.corners()) - wall.gap(lead0.corners())) > FOLLOW_WALL_M:
            return _rehang(base, wall, lead0, lead1, sub0, group)
        t = np.asarray(wall.end, dtype=np.float64)[:2] - np.asarray(wall.start, dtype=np.float64)[:2]
        t = t / float(np.linalg.norm(t))
        beside = float((_xy(sub0) - _xy(lead0)) @ t)  # how far along the wall from the leader's centre
        area = unary_union([_foot(g).buffer(OVER_MARGIN_M) for g in group])
        for side in _SIDES:
            step = float(shift @ t) + (side - 1.0) * beside
            xy = pos[:2] + t * step
            slid = Pose(position=(float(xy[0]), float(xy[1]), float(pos[2])), quaternion=sub0.pose.quaternion, scale=sub0.pose.scale)
            if fits_wall(sub0.model_copy(update={"pose": slid}), wall, sub0) and (side == 1.0 or area.contains(Point(xy))):
                return slid, wall.id
        return None
    area = unary_union([_foot(g).buffer(OVER_MARGIN_M) for g in group])
    y0, y1 = _yaw(lead0), _yaw(lead1)
    offset = _rot(-y0) @ (_xy(sub0) - _xy(lead0))  # in the leader's own frame
    mirrors = [(1.0, 1.0), (-1.0, 1.0)] if _is_bed(lead0) else [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)]
    ways: list[tuple[FloatArray, tuple[float, float, float, float]]] = [
        (_rot(y1) @ (offset * np.array(m)) + _xy(lead1), _turned(sub0.pose.quaternion, turn)) for m in mirrors
    ]
    ways.append((_xy(sub0) + shift, sub0.pose.quaternion))  # keep the heading: the group only shifted
    for xy, quat in ways:
        pose = Pose(position=(float(xy[0]), float(xy[1]), float(pos[2])), quaternion=quat, scale=sub0.pose.scale)
        if not area.contains(Point(xy)):
            continue
        if inside is None or inside.covers(Polygon(sub0.model_copy(update={"pose": pose}).footprint())):
            return pose, None
    return None


def fits_wall(moved: SceneObject, wall: Wall, before: SceneObject | None) -> bool:
    """Whether a wall piece lies within its wall's length and clear (by :data:`OPENING_CLEAR_M`)
    of the wall's doors and windows; a piece that overlapped one already where it hung in the
    base (``before``) only has to stay within the wall."""
    start, t = np.asarray(wall.start, dtype=np.float64), wall.direction

    def span(o: SceneObject) -> tuple[float, float, float, float]:
        along = (o.corners()[:, :2] - start) @ t
        lo, hi = o.aabb()
        return float(along.min()), float(along.max()), float(lo[2]), float(hi[2])

    def on_opening(o: SceneObject) -> bool:
        a0, a1, z0, z1 = span(o)
        return any(
            a1 > op.center - op.width / 2 - OPENING_CLEAR_M and a0 < op.center + op.width / 2 + OPENING_CLEAR_M
            and z1 > op.bottom - OPENING_CLEAR_M and z0 < op.bottom + op.height + OPENING_CLEAR_M
            for op in wall.openings
        )  # fmt: skip

    a0, a1, _, _ = span(moved)
    if a0 < -1e-3 or a1 > wall.length + 1e-3:
        return False
    return not on_opening(moved) or (before is not None and on_opening(before))


def _rehang(
    base: Scene,
    old: Wall,
    lead0: SceneObject,
    lead1: SceneObject,
    sub0: SceneObject,
    group: list[SceneObject],
) -> tuple[Pose, str] | None:
    """A wall piece carried to the wall its leader backs onto now (:data:`REHANG_GAP_M`,
    :data:`REHANG_FACING_DEG`): as far from that wall and as high as it hung, as far beside the
    leader's centre (turned with the leader), else mirrored, else centred (:data:`_SIDES`), on the
    nearest wall behind it that takes it, facing into the room; ``None`` when no wall is behind
    the leader, or the piece would not fit on any, cover one of its openings or leave the group it
    hangs over."""
    assert base.room is not None
    front = _front(lead1)
    corners = lead1.corners()
    cos_max = math.cos(math.radians(REHANG_FACING_DEG))
    behind = [
        (w.gap(corners), w.id, w) for w in base.room.walls
        if float(front @ w.inward_normal) >= cos_max and -0.02 <= w.gap(corners) <= REHANG_GAP_M
    ]  # fmt: skip
    n0, t0 = old.inward_normal, old.direction
    p0 = _xy(sub0)
    depth = float((p0 - np.asarray(old.start)) @ n0)
    turn = _yaw(lead1) - _yaw(lead0)
    lateral = _rot(turn) @ (t0 * float((p0 - _xy(lead0)) @ t0))
    z = float(sub0.pose.position[2])
    area = unary_union([_foot(g).buffer(OVER_MARGIN_M) for g in group])
    floor = Polygon(base.room.floor).buffer(0.02)
    for _, _, wall in sorted(behind, key=lambda b: (b[0], b[1])):  # the nearest wall first (a corner has two)
        n1, t1 = wall.inward_normal, wall.direction
        start = np.asarray(wall.start, dtype=np.float64)
        spin = math.atan2(float(n1[1]), float(n1[0])) - math.atan2(float(n0[1]), float(n0[0]))
        for side in _SIDES:
            along = float((_xy(lead1) - start) @ t1) + side * float(lateral @ t1)
            xy = start + t1 * along + n1 * depth
            pose = Pose(
                position=(float(xy[0]), float(xy[1]), z),
                quaternion=_turned(sub0.pose.quaternion, spin),
                scale=sub0.pose.scale,
            )
            moved = sub0.model_copy(update={"pose": pose})
            if fits_wall(moved, wall, None) and area.contains(Point(xy)) and floor.covers(Polygon(moved.footprint())):
                return pose, wall.id
    return None


_SIDES = (1.0, -1.0, 0.0)
"""Where a wall piece goes beside its leader when it follows it: as far to the same side as it
hung, else mirrored to the other side, else centred on the leader (a picture over a sofa moved
to a shorter wall, or beside a door, that the first two would run off or onto)."""


def _rot(a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _turned(q: tuple[float, float, float, float], turn: float) -> tuple[float, float, float, float]:
    return quat_multiply(quat_from_yaw(turn), q)

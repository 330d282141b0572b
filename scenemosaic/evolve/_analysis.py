"""The rule critic's eyes: physical checks and the semantic rules of a unit's 2D layout.

:func:`physical_check` counts what physics sees (hull interpenetrations, with contact counts,
and children outside the anchor surface). :func:`find_problems` adds the semantic rules of a
room and, for each problem, the pose that would fix it; the rule critic words the problems as
notes, the rule actor turns the fixes into pose expressions. :func:`rule_violations` is the
same judgement as a plain list, for reports and tests.

Thresholds (metres and degrees) are named here and documented in ``docs/evolution.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points

from scenemosaic.evolve._context import UnitContext, WallLine, facing_degrees
from scenemosaic.exceptions import UsageError
from scenemosaic.physics import (
    OOB_MIN_INSIDE_FRACTION,
    CollisionPair,
    ObjectShape,
    collision_report_for,
    resting_footprint,
    rests_within,
)
from scenemosaic.scene import (
    ROBOT_RADIUS,
    WALK_MAX_HEIGHT,
    WALK_MIN_SHARE,
    FloatArray,
    FloorRaster,
    Scene,
    SceneObject,
    UnitLayout,
    Walkable,
    convex_hull_2d,
    edge_axes,
    minimal_containing_shift,
    normalize_degrees,
    outline_polygon,
    points_at,
    sat_overlap,
    traits,
)

__all__ = [
    "BESIDE_GAP_MAX",
    "FACING_TABLE_DEG",
    "FRONT_CLEARANCE",
    "HEAD_ZONE",
    "SEAT_GAP_MAX",
    "SEAT_SQUARE_DEG",
    "WALL_FACING_DEG",
    "WALL_GAP_MAX",
    "Finding",
    "LayoutRule",
    "PhysicalCheck",
    "SeatSlot",
    "Target",
    "find_problems",
    "front_strip",
    "front_zone",
    "merged_fixes",
    "physical_check",
    "rule_violations",
    "seat_slots",
    "seating_breaches",
]

WALL_GAP_MAX = 0.05
"""Wall furniture counts as backed against a wall when its back is at most this far from it."""
WALL_FACING_DEG = 10.0
"""... and its front is within this many degrees of the wall's inward normal."""
WALL_FLUSH_GAP = 0.005
"""The gap a snapped piece keeps to its wall."""
WALL_REACH = 2.0
"""A wall behind a piece's back within this distance is the wall it belongs against (a TV stand
left facing its sofa from the middle of the room goes back to the wall behind it, not sideways
to a nearer wall that would turn it away)."""
WALL_MIN_OVERLAP = 0.5
"""At least this fraction of a piece's width must be in front of its wall."""
NEAR_WALL = 0.3
"""An object whose front is this close to a wall, and turned toward it, faces into the wall."""
SEAT_GAP_MAX = 0.35
"""A seat whose box is further than this from its table's box is pulled up to it, metres."""
SEAT_GAP = 0.03
"""The gap a pulled-up or seated chair keeps to its table, metres."""
FACING_TABLE_DEG = 15.0
"""A seat without a table slot plan faces its table when its front is within this many degrees
of the way to the table."""
SEAT_SQUARE_DEG = 5.0
"""A seat at a table or desk faces the side it sits at squarely: its front within this many
degrees of that side's inward normal (and its centre within the side's extent)."""
SHORT_TABLE_RATIO = 1.3
"""A table whose long side is shorter than this times its short side seats on all four sides
alike; a longer one fills its long sides (evenly) before its ends."""
SLOT_SPACING = 0.05
"""Elbow room between two seats on one side, metres (a side takes as many seats as fit)."""
HEAD_ZONE = 0.75
"""A nightstand's centre must be within this distance of the bed's head end..."""
BESIDE_GAP_MAX = 0.35
"""... and its box at most this far from the bed's side (and not overlapping it by more than 2 cm)."""
BESIDE_GAP = 0.03
"""The gap a placed nightstand keeps to the bed."""
SEPARATION_MARGIN = 0.01
"""Extra distance a push-apart move adds beyond the overlap, metres."""
FRONT_CLEARANCE = 0.5
"""Depth of the space kept free in front of doors and drawers (wardrobes, cabinets, dressers,
shelves, TV stands), metres."""
PASSAGE_STEPS = (0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6)
"""How far, metres, a move that reopens a cut-off piece of floor may push one object (the
shortest that works is taken)."""
PINNED_MOVE_MAX = 0.10
PINNED_TURN_MAX = 15.0
"""Limits on how far a clause's object may drift from where the clause fixed it."""

Severity = Literal["physical", "semantic", "soft"]
_ORDER = {
    "out_of_bounds": 0, "clause": 1, "against_wall": 2, "beside_bed": 3, "faces_table": 4, "faces_wall": 5,
    "seat_distance": 4, "seating": 4, "collision": 6, "clearance": 7, "sofa_tv": 8, "faces_group": 8, "passage": 9,
}  # fmt: skip


@dataclass(frozen=True)
class Target:
    """Where a fix puts one object; ``None`` leaves that part of its pose alone."""

    u: float | None = None
    v: float | None = None
    rotation: float | None = None
    symbolic: tuple[str, ...] = ()
    """Pose expressions that express this fix exactly, when it is simplest said relative to others."""


@dataclass(frozen=True)
class Finding:
    """One problem of a layout: the objects, how bad, a note in words, and fixes per object."""

    kind: str
    objects: tuple[str, ...]
    severity: Severity
    note: str
    fixes: Mapping[str, Target] = field(default_factory=dict)


@dataclass(frozen=True)
class PhysicalCheck:
    """Collisions (deeper than the physics tolerance) and out-of-bounds children of a layout."""

    collisions: tuple[CollisionPair, ...]
    out_of_bounds: tuple[str, ...]

    @property
    def count(self) -> int:
        """Colliding pairs plus objects out of bounds: what round selection minimizes."""
        return len(self.collisions) + len(self.out_of_bounds)

    @property
    def clean(self) -> bool:
        return self.count == 0


def _posed(layout: UnitLayout, oid: str) -> SceneObject:
    return layout.object(oid).model_copy(update={"pose": layout.pose(oid)})


def physical_check(layout: UnitLayout, ctx: UnitContext, shapes: Mapping[str, ObjectShape]) -> PhysicalCheck:
    """What physics says about the layout: hull collisions of children with each other and with
    the fixed obstacles around them, and children less than 99 % inside the anchor surface."""
    kids = [_posed(layout, k) for k in layout.ids]
    near = _nearby_obstacles(layout, ctx)
    world = Scene.of_objects(kids + near)
    report = collision_report_for(world, shapes)
    own = set(layout.ids)
    pairs = tuple(p for p in report.pairs if p.a in own or p.b in own)
    region = Polygon(ctx.surface.region)
    oob: list[str] = []
    on_object = ctx.unit.anchor_kind == "object" and ctx.surface.projection != "anchor_front"
    for k in layout.ids:
        if on_object and k in shapes:  # what a child stands on must be over the top (a television's foot)
            if not rests_within(_resting_uv(layout, k, shapes[k], ctx), region)[1]:
                oob.append(k)
            continue
        poly = layout.outline(k)
        area = float(poly.area)
        inside = float(poly.intersection(region).area) / area if area > 1e-12 else 1.0
        if inside < OOB_MIN_INSIDE_FRACTION:
            oob.append(k)
    return PhysicalCheck(pairs, tuple(oob))


def _resting_uv(layout: UnitLayout, oid: str, shape: ObjectShape, ctx: UnitContext) -> Polygon:
    """What a child stands on (``physics.resting_footprint``), in the unit's (u, v) plane."""
    foot = resting_footprint(_posed(layout, oid), shape)
    surface = ctx.surface
    pts = np.asarray(foot.exterior.coords)[:, :2]
    world = np.concatenate([pts, np.zeros((len(pts), 1))], axis=1) - surface.origin * np.array([1.0, 1.0, 0.0])
    return Polygon(convex_hull_2d(np.stack([world @ surface.u_axis, world @ surface.v_axis], axis=1)))


def _nearby_obstacles(layout: UnitLayout, ctx: UnitContext) -> list[SceneObject]:
    """Obstacles whose (u, v) box comes within 0.5 m of any child: the rest cannot collide."""
    if not ctx.obstacles:
        return []
    polys = [layout.outline(k) for k in layout.ids]
    out = []
    for o, poly in obstacle_polygons(ctx):
        if any(poly.distance(p) < 0.5 for p in polys):
            out.append(o)
    return out


def follower_polygons(layout: UnitLayout, ctx: UnitContext) -> list[tuple[SceneObject, Polygon]]:
    """The followers of this unit's pieces (``ctx.followers``) where they will be once they have
    followed their leader's move in ``layout``: each outline turned and carried like its leader."""
    out = []
    for obj, leader, (u0, v0, r0) in ctx.followers:
        if leader not in layout.ids:
            continue
        poly = convex_hull_2d(ctx.surface.project(obj.corners()))
        a = math.radians(-(layout.rotation(leader) - r0))  # rotations turn clockwise in the view
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        moved = (poly - np.array([u0, v0])) @ rot.T + np.asarray(layout.center(leader))
        out.append((obj, Polygon(moved)))
    return out


def obstacle_polygons(ctx: UnitContext) -> list[tuple[SceneObject, Polygon]]:
    """The fixed obstacles around the unit with their outlines on its surface."""
    if ctx.obstacle_polygons is None:  # a benign race: two layouts of a unit may both compute it
        ctx.obstacle_polygons = [(o, Polygon(convex_hull_2d(ctx.surface.project(o.corners())))) for o in ctx.obstacles]
    return list(ctx.obstacle_polygons)


# -- geometry helpers on the layout ------------------------------------------------------------------


def _facing(rotation: float) -> FloatArray:
    r = math.radians(rotation)
    return np.array([-math.sin(r), -math.cos(r)])


def _off(a: float, b: float) -> float:
    return abs(normalize_degrees(a - b))


def _word(direction: FloatArray) -> str:
    du, dv = float(direction[0]), float(direction[1])
    if abs(du) >= abs(dv):
        return "to the right" if du > 0 else "to the left"
    return "upward in the view" if dv > 0 else "downward in the view"


def wall_status(layout: UnitLayout, ctx: UnitContext, oid: str) -> tuple[bool, WallLine | None]:
    """Whether ``oid`` is backed against a wall and facing into the room, and the wall it
    belongs against (the one behind it, else the nearest)."""
    poly = layout.polygon(oid)
    rot = layout.rotation(oid)
    for w in ctx.walls:
        if _off(rot, w.facing) <= WALL_FACING_DEG and -0.01 <= w.gap(poly) <= WALL_GAP_MAX and w.overlap(poly) >= WALL_MIN_OVERLAP:
            return True, w
    back = -_facing(rot)
    behind = [
        (w.gap(poly), w.id, w)
        for w in ctx.walls
        if float(back @ -np.asarray(w.inward)) >= math.cos(math.radians(45)) and w.gap(poly) <= WALL_REACH and w.overlap(poly) >= 0.3
    ]
    if behind:
        return False, min(behind)[2]
    near = [(abs(w.gap(poly)), w.id, w) for w in ctx.walls if w.overlap(poly) >= 0.3]
    if not near:
        c = np.asarray(layout.center(oid))
        near = [(_segment_distance(c, w), w.id, w) for w in ctx.walls]
    return False, (min(near)[2] if near else None)


def _segment_distance(p: FloatArray, w: WallLine) -> float:
    a, b = np.asarray(w.a), np.asarray(w.b)
    t = float(np.clip((p - a) @ (b - a) / max(float((b - a) @ (b - a)), 1e-12), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * (b - a))))


def snap_target(layout: UnitLayout, oid: str, wall: WallLine) -> Target:
    """Back flush against ``wall`` (``WALL_FLUSH_GAP``), front to the room, kept along the wall."""
    trial = layout.copy()
    trial.set_rotation(oid, wall.facing)
    poly = trial.polygon(oid)
    c = np.asarray(trial.center(oid))
    shift = (WALL_FLUSH_GAP - wall.gap(poly)) * np.asarray(wall.inward)
    lo, hi = wall.along(poly + shift)
    if hi - lo <= wall.length:
        if lo < 0:
            shift = shift + (-lo + WALL_FLUSH_GAP) * wall.tangent
        elif hi > wall.length:
            shift = shift - (hi - wall.length + WALL_FLUSH_GAP) * wall.tangent
    c = c + shift
    return Target(float(c[0]), float(c[1]), wall.facing)


def _bed_frame(layout: UnitLayout, bed: str) -> tuple[FloatArray, FloatArray, FloatArray, float, float]:
    """Bed centre, front direction, lateral direction, depth (head to foot) and width."""
    fb = _facing(layout.rotation(bed))
    lat = np.array([fb[1], -fb[0]])
    poly = layout.polygon(bed)
    c = np.asarray(layout.center(bed))
    depth = float(np.ptp((poly - c) @ fb))
    width = float(np.ptp((poly - c) @ lat))
    return c, fb, lat, depth, width


def beside_ok(layout: UnitLayout, stand: str, bed: str) -> bool:
    """A nightstand beside the bed's head: next to a long side, near the head end."""
    c, fb, lat, depth, width = _bed_frame(layout, bed)
    rel = np.asarray(layout.center(stand)) - c
    poly = layout.polygon(stand) - np.asarray(layout.center(stand))
    half = float(np.ptp(poly @ lat)) / 2
    gap = abs(float(rel @ lat)) - width / 2 - half
    return -0.02 <= gap <= BESIDE_GAP_MAX and float(rel @ -fb) >= depth / 2 - HEAD_ZONE


def _stand_sides(layout: UnitLayout, ctx: UnitContext) -> dict[str, float]:
    """Which side of its bed each nightstand belongs on (+1 or -1 along the bed's lateral axis):
    the side it stands on now, except that a bed's two nightstands take one side each."""
    sides: dict[str, float] = {}
    by_bed: dict[str, list[str]] = {}
    for stand, bed in sorted(ctx.nightstand_bed.items()):
        if bed in layout.ids:
            by_bed.setdefault(bed, []).append(stand)
    for bed, stands in by_bed.items():
        c, _, lat, _, _ = _bed_frame(layout, bed)
        offsets = sorted((float((np.asarray(layout.center(k)) - c) @ lat), k) for k in stands)
        for off, k in offsets:
            sides[k] = 1.0 if off >= 0 else -1.0
        if len(offsets) == 2:
            sides[offsets[0][1]], sides[offsets[1][1]] = -1.0, 1.0
    return sides


def beside_target(layout: UnitLayout, stand: str, bed: str, flip: bool = False, side: float | None = None) -> Target:
    """The nightstand at the bed's head end, against the bed's side it stands on now (or ``side``),
    facing as the bed."""
    c, fb, lat, depth, width = _bed_frame(layout, bed)
    rot = layout.rotation(bed)
    trial = layout.copy()
    trial.set_rotation(stand, rot)
    poly = trial.polygon(stand) - np.asarray(trial.center(stand))
    d_n, w_n = float(np.ptp(poly @ fb)), float(np.ptp(poly @ lat))
    if side is None:
        side = 1.0 if float((np.asarray(layout.center(stand)) - c) @ lat) >= 0 else -1.0
    if flip:
        side = -side
    p = c - fb * (depth / 2 - d_n / 2) + lat * side * (width / 2 + w_n / 2 + BESIDE_GAP)
    return Target(float(p[0]), float(p[1]), rot)


@dataclass(frozen=True)
class SeatSlot:
    """A place for a seat at its table: where, facing which way, on which side."""

    u: float
    v: float
    rotation: float
    side: str


def _table_sides(layout: UnitLayout, table: str) -> dict[str, tuple[FloatArray, float, float]]:
    """Side name -> (outward normal, half the side's length, distance of its edge from the
    table's centre); ``front`` is the way the table faces (a desk's user side)."""
    _c, f, lat, depth, width = _bed_frame(layout, table)
    return {
        "front": (f, width / 2, depth / 2),
        "back": (-f, width / 2, depth / 2),
        "right": (lat, depth / 2, width / 2),
        "left": (-lat, depth / 2, width / 2),
    }


def _seat_side(layout: UnitLayout, table: str, seat: str) -> str:
    """The side of ``table`` the seat's centre lies beyond the furthest."""
    rel = np.asarray(layout.center(seat)) - np.asarray(layout.center(table))
    sides = _table_sides(layout, table)
    return max(sides, key=lambda k: (float(rel @ sides[k][0]) - sides[k][2], k))


def _seat_size(layout: UnitLayout, seats: Sequence[str]) -> tuple[float, float]:
    return max(float(layout.object(k).size[0]) for k in seats), max(float(layout.object(k).size[1]) for k in seats)


def _open_sides(layout: UnitLayout, ctx: UnitContext, table: str, seat_d: float) -> list[str]:
    """The sides a seat can be drawn up to: a desk or dressing table only its front; other tables
    every side whose seating strip (a seat's depth out from the edge) stays on the floor: a side
    against a wall stays empty."""
    sides = _table_sides(layout, table)
    if table in ctx.against_wall:
        return ["front"]
    region = Polygon(ctx.surface.region)
    c = np.asarray(layout.center(table))
    out = []
    for name, (n, half, edge) in sides.items():
        along = np.array([n[1], -n[0]])
        mid = c + n * edge
        reach = edge + SEAT_GAP + seat_d
        strip = Polygon([mid - along * half * 0.8, mid + along * half * 0.8, c + n * reach + along * half * 0.8, c + n * reach - along * half * 0.8])
        if region.buffer(1e-6).covers(strip):
            out.append(name)
    return out


def _side_counts(n_seats: int, caps: Mapping[str, int], long_pair: tuple[str, str], short_pair: tuple[str, str], short_table: bool) -> dict[str, int]:
    """How many seats each side takes: the long sides evenly first (one each in turn), then the
    ends; on a short table all four sides in turn."""
    counts = dict.fromkeys(caps, 0)
    order = [*long_pair, *short_pair] if short_table else list(long_pair)
    placed = 0
    for turn in (order, list(short_pair)):
        while placed < n_seats and any(counts[k] < caps[k] for k in turn):
            for k in turn:
                if placed < n_seats and counts[k] < caps[k]:
                    counts[k] += 1
                    placed += 1
    return counts


def _slots_free(layout: UnitLayout, ctx: UnitContext, table: str, seats: Sequence[str], slot: SeatSlot, seat: str) -> bool:
    """A seat at ``slot`` stays on the surface, out of the space in front of a door
    (``ctx.keep_clear``) and clear of everything but its table and the table's other seats (which
    move to their own slots)."""
    trial = layout.copy()
    trial.set_rotation(seat, slot.rotation)
    trial.set_center(seat, slot.u, slot.v)
    shape = trial.outline(seat)
    if not Polygon(ctx.surface.region).buffer(1e-6).covers(shape):
        return False
    if any(shape.intersection(zone).area > 1e-4 for zone in ctx.keep_clear):
        return False  # in front of a door
    lo, hi = layout.span(seat)
    skip = {table, *seats, *ctx.thin}
    for k in layout.ids:
        if k in skip:
            continue
        klo, khi = layout.span(k)
        if klo >= hi - 1e-3 or khi <= lo + 1e-3:
            continue
        if shape.intersection(layout.outline(k)).area > 1e-4:
            return False
    return not any(o.id != table and shape.intersection(p).area > 1e-4 for o, p in obstacle_polygons(ctx))


def seat_slots(layout: UnitLayout, ctx: UnitContext, table: str, seats: Sequence[str]) -> dict[str, SeatSlot]:
    """The etiquette's places for ``seats`` at ``table``, one per seat (empty when they do not
    all fit): seats face their side squarely, ``SEAT_GAP`` from its edge (less as far as the
    seats are tucked in under the table now, :func:`_tuck`), spread evenly and
    symmetrically along it; the long sides fill evenly before the ends (all four sides alike on
    a short table, see ``SHORT_TABLE_RATIO``); a side against a wall stays empty; a desk's seats
    sit at its front, one seat centred. Each seat takes the free slot that keeps the seats'
    total travel least."""
    seats = sorted(seats)
    if not seats:
        return {}
    seat_w, seat_d = _seat_size(layout, seats)
    sides = _table_sides(layout, table)
    open_sides = _open_sides(layout, ctx, table, seat_d)
    caps = {k: (int((2 * sides[k][1] + SLOT_SPACING) // (seat_w + SLOT_SPACING)) if k in open_sides else 0) for k in sides}
    if sides["right"][1] > sides["front"][1]:
        long_pair, short_pair = ("right", "left"), ("front", "back")
    else:
        long_pair, short_pair = ("front", "back"), ("right", "left")
    ratio = sides[long_pair[0]][1] / max(sides[short_pair[0]][1], 1e-6)
    c = np.asarray(layout.center(table))
    tuck = _tuck(layout, table, seats, seat_d)
    for _ in range(8):
        if sum(caps.values()) < len(seats):
            return {}
        counts = _side_counts(len(seats), caps, long_pair, short_pair, ratio < SHORT_TABLE_RATIO)
        slots: list[SeatSlot] = []
        for name, m in counts.items():
            n, half, edge = sides[name]
            along = np.array([n[1], -n[0]])
            for j in range(m):
                p = c + n * (edge + SEAT_GAP + seat_d / 2 - tuck) + along * (j - (m - 1) / 2) * (2 * half / m)
                slots.append(SeatSlot(float(p[0]), float(p[1]), facing_degrees(-n), name))
        blocked = [sl for sl in slots if not _slots_free(layout, ctx, table, seats, sl, seats[0])]
        if not blocked:
            return _assign(layout, seats, slots)
        for sl in blocked:  # a side that cannot take its seats takes one fewer; try again
            caps[sl.side] = max(0, min(caps[sl.side], counts[sl.side]) - 1)
    return {}


def _tuck(layout: UnitLayout, table: str, seats: Sequence[str], seat_d: float) -> float:
    """How far the seats are tucked in under the table now (the median over the seats drawn up to
    it, between 0 and half a seat's depth): slots keep the room's own style, pulled out or
    tucked in."""
    sides = _table_sides(layout, table)
    c = np.asarray(layout.center(table))
    tucks = []
    for k in seats:
        side = _seat_side(layout, table, k)
        n, _half, edge = sides[side]
        d = float((np.asarray(layout.center(k)) - c) @ n)
        if d <= edge + SEAT_GAP + seat_d / 2 + SEAT_GAP_MAX:
            tucks.append(float(np.clip(edge + SEAT_GAP + seat_d / 2 - d, 0.0, seat_d / 2)))
    return float(np.median(tucks)) if tucks else 0.0


def _assign(layout: UnitLayout, seats: Sequence[str], slots: Sequence[SeatSlot]) -> dict[str, SeatSlot]:
    """Seats to slots with the least total travel (exhaustive for up to 7 seats, else greedy)."""
    here = {k: np.asarray(layout.center(k)) for k in seats}

    def cost(k: str, sl: SeatSlot) -> float:
        return math.dist(here[k], (sl.u, sl.v)) + 0.002 * _off(layout.rotation(k), sl.rotation)

    if len(seats) <= 7:
        import itertools

        best = min(itertools.permutations(range(len(slots)), len(seats)), key=lambda perm: (sum(cost(k, slots[i]) for k, i in zip(seats, perm, strict=True)), perm))
        return {k: slots[i] for k, i in zip(seats, best, strict=True)}
    free = list(slots)
    out: dict[str, SeatSlot] = {}
    for k in seats:
        sl = min(free, key=lambda s: (cost(k, s), s.u, s.v))
        free.remove(sl)
        out[k] = sl
    return out


def _square_on_side(layout: UnitLayout, table: str, seat: str) -> tuple[bool, bool, str]:
    """(faces its side squarely, centre within the side's extent, the side)."""
    side = _seat_side(layout, table, seat)
    n, half, _edge = _table_sides(layout, table)[side]
    rel = np.asarray(layout.center(seat)) - np.asarray(layout.center(table))
    along = np.array([n[1], -n[0]])
    square = _off(layout.rotation(seat), facing_degrees(-n)) <= SEAT_SQUARE_DEG
    return square, abs(float(rel @ along)) <= half + 1e-6, side


def seating_breaches(layout: UnitLayout, ctx: UnitContext, table: str, seats: Sequence[str]) -> list[str]:
    """What breaks the seating etiquette at ``table``, in words (empty when the seats are right):
    a seat too far, turned off its side, beyond its side's extent, at a side against a wall or at
    a desk's back, or long sides holding uneven counts."""
    out: list[str] = []
    if not seats:
        return out
    _w, seat_d = _seat_size(layout, seats)
    open_sides = _open_sides(layout, ctx, table, seat_d)
    counts: dict[str, int] = {}
    for k in sorted(seats):
        square, on_side, side = _square_on_side(layout, table, k)
        counts[side] = counts.get(side, 0) + 1
        gap = float(layout.outline(k).distance(layout.outline(table)))
        if gap > SEAT_GAP_MAX:
            out.append(f"{k} stands {gap:.2f} m from {table}")
        elif side not in open_sides:
            out.append(f"{k} sits at the {side} of {table}, where no seat belongs")
        elif not square:
            out.append(f"{k} is not square to the {side} side of {table}")
        elif not on_side:
            out.append(f"{k} sits past the end of the {side} side of {table}")
    sides = _table_sides(layout, table)
    long_pair = ("right", "left") if sides["right"][1] > sides["front"][1] else ("front", "back")
    if all(s in open_sides for s in long_pair) and table not in ctx.against_wall:
        a, b = counts.get(long_pair[0], 0), counts.get(long_pair[1], 0)
        if abs(a - b) > 1:
            out.append(f"the long sides of {table} hold {a} and {b} seats")
    return out


def _seat_target(layout: UnitLayout, ctx: UnitContext, seat: str, table: str) -> Target | None:
    """Pull a far seat up to its table along the way to it (used only where the table has no
    slot plan: :func:`_legacy_seat`). ``None`` when no pull-up is clean."""
    d = table_direction(layout, seat, table)
    gap = float(layout.outline(seat).distance(layout.outline(table)))
    if d is not None:
        for keep in (SEAT_GAP, 0.15, 0.25):
            moved = layout.polygon(seat) + d * (gap - keep)
            if not _blocked(layout, ctx, seat, moved, table):
                c = np.asarray(layout.center(seat)) + d * (gap - keep)
                return Target(float(c[0]), float(c[1]), facing_degrees(d))
    return None


def table_direction(layout: UnitLayout, seat: str, table: str) -> FloatArray | None:
    """The way from a seat's centre to the nearest point of its table (to the table's centre
    when the seat stands under it)."""
    c = np.asarray(layout.center(seat))
    poly = layout.outline(table)
    p = Point(c)
    if poly.contains(p):
        d = np.asarray(layout.center(table)) - c
    else:
        q = nearest_points(poly, p)[0]
        d = np.array([q.x, q.y]) - c
    n = float(np.linalg.norm(d))
    return d / n if n > 1e-6 else None


def layout_faces(layout: UnitLayout, piece: str, target: str) -> bool:
    """Whether ``piece`` faces ``target`` in the layout (``scene.points_at``, the one definition)."""
    return points_at(np.asarray(layout.center(piece)), _facing(layout.rotation(piece)), layout.outline(target), np.asarray(layout.center(target)))


def _slide_to_face(layout: UnitLayout, ctx: UnitContext, piece: str, faced: str) -> tuple[str, Target] | None:
    """Two wall pieces that no longer face each other (a sofa and its TV stand): the TV stand (or,
    failing that, the other piece) slid along its wall to where the line along the other's front
    meets that wall, when the move is clean. ``None`` when neither can go there."""
    order = sorted((piece, faced), key=lambda k: (layout.object(k).category not in ("tv_stand", "television"), k))
    for mover in order:
        other = faced if mover == piece else piece
        if mover in ctx.pinned:
            continue
        ok, wall = wall_status(layout, ctx, mover)
        if not ok or wall is None:
            continue
        c, f = np.asarray(layout.center(other)), _facing(layout.rotation(other))
        denom = float(f @ np.asarray(wall.inward))
        if abs(denom) < 1e-6:
            continue
        t = float((np.asarray(wall.a) - c) @ np.asarray(wall.inward)) / denom
        if t <= 0:
            continue
        hit = c + f * t
        here = np.asarray(layout.center(mover))
        shift = float((hit - here) @ wall.tangent) * wall.tangent
        lo, hi = wall.along(layout.polygon(mover) + shift)
        if lo < 0 or hi > wall.length:
            shift = shift - (min(lo, 0.0) + max(hi - wall.length, 0.0)) * wall.tangent
        moved = layout.polygon(mover) + shift
        if _blocked(layout, ctx, mover, moved, other):
            continue
        trial = layout.copy()
        trial.set_center(mover, float(here[0] + shift[0]), float(here[1] + shift[1]))
        if layout_faces(trial, piece, faced):
            return mover, Target(float(here[0] + shift[0]), float(here[1] + shift[1]))
    return None


def _faces_wall(layout: UnitLayout, ctx: UnitContext, oid: str) -> WallLine | None:
    poly = layout.polygon(oid)
    f = _facing(layout.rotation(oid))
    for w in ctx.walls:
        if float(f @ -np.asarray(w.inward)) >= math.cos(math.radians(45)) and w.gap(poly) <= NEAR_WALL and w.overlap(poly) > 0.3:
            return w
    return None


# -- separating colliding objects ---------------------------------------------------------------------


def _rank(ctx: UnitContext, oid: str, layout: UnitLayout) -> tuple[int, float]:
    """Who moves first in a collision: lower rank moves (free small things before wall pieces)."""
    big = 2 if oid in ctx.against_wall else (1 if oid in ctx.seat_table.values() else 0)
    poly = layout.outline(oid)
    return big, float(poly.area)


def _blocked(layout: UnitLayout, ctx: UnitContext, mover: str, poly: FloatArray, partner: str) -> bool:
    """Would ``mover`` at ``poly`` leave the surface or newly overlap another solid thing at its
    height? Boxes it overlaps already (a chair tucked under its table) do not count: physics
    found no collision there."""
    region = Polygon(ctx.surface.region)
    shape = Polygon(poly)
    if not region.buffer(1e-6).covers(shape):
        return True
    here = layout.outline(mover)
    lo, hi = layout.span(mover)
    for k in layout.ids:
        if k in (mover, partner) or k in ctx.thin:
            continue
        klo, khi = layout.span(k)
        if klo >= hi - 1e-3 or khi <= lo + 1e-3:
            continue
        other = layout.outline(k)
        if shape.intersection(other).area > 1e-4 and here.intersection(other).area <= 1e-4:
            return True
    for o, opoly in obstacle_polygons(ctx):
        if o.id != partner and shape.intersection(opoly).area > 1e-4 and here.intersection(opoly).area <= 1e-4:
            return True
    return False


def _separation(
    layout: UnitLayout, ctx: UnitContext, pair: CollisionPair, avoid: Collection[str], walls: Mapping[str, WallLine]
) -> tuple[str, Target] | None:
    own = set(layout.ids)
    movers = [k for k in (pair.a, pair.b) if k in own]
    # a table never makes way for its own seat: carried clear of one chair it would leave the
    # rest of its seats behind (the seat moves, or takes the least move below)
    movers = [k for k in movers if not any(ctx.seat_table.get(j) == k for j in (pair.a, pair.b) if j != k and j in own)]
    if not movers:
        return None
    movers.sort(key=lambda k: (k in avoid, _rank(ctx, k, layout), k))
    for mover in movers:
        other = pair.b if mover == pair.a else pair.a
        pm = layout.polygon(mover)
        po = layout.polygon(other) if other in own else _obstacle_poly(ctx, other)
        if po is None:
            continue
        axes = np.concatenate([edge_axes(pm), edge_axes(po)]) if len(pm) > 2 and len(po) > 2 else np.eye(2)
        dirs = np.concatenate([axes, -axes])
        if mover in walls:  # a piece backed against its wall slides along it only
            t = walls[mover].tangent
            dirs = np.array([t, -t])
        options = []
        for d in dirs:
            need = float((po @ d).max() - (pm @ d).min()) + SEPARATION_MARGIN
            if need > 0:
                options.append((need, tuple(np.round(d, 12)), d))
        options.sort(key=lambda x: (x[0], x[1]))
        for need, _, d in options:
            moved = pm + d * need
            if not _blocked(layout, ctx, mover, moved, other):
                c = np.asarray(layout.center(mover)) + d * need
                symbolic: tuple[str, ...] = ()
                if other in own and max(abs(d[0]), abs(d[1])) > 1 - 1e-9:
                    ax = "u" if abs(d[0]) > 0.5 else "v"
                    if (d[0] if ax == "u" else d[1]) > 0:
                        expr = f"{mover}.center.{ax} = {other}.bbox.max_{ax} + {mover}.size.{ax} / 2 + {SEPARATION_MARGIN}"
                    else:
                        expr = f"{mover}.center.{ax} = {other}.bbox.min_{ax} - {mover}.size.{ax} / 2 - {SEPARATION_MARGIN}"
                    symbolic = (expr,)
                return mover, Target(float(c[0]), float(c[1]), None, symbolic)
    # nothing clean: the least move of the first mover; physics settles the rest
    mover = movers[0]
    other = pair.b if mover == pair.a else pair.a
    po = layout.polygon(other) if other in own else _obstacle_poly(ctx, other)
    if po is None:
        return None
    depth, axis = sat_overlap(po, layout.polygon(mover))
    if depth <= 0:
        axis = np.asarray(layout.center(mover)) - np.asarray(Polygon(po).centroid.coords[0])
        axis = axis / max(float(np.linalg.norm(axis)), 1e-9)
        depth = 0.0
    c = np.asarray(layout.center(mover)) + axis * (depth + SEPARATION_MARGIN)
    return mover, Target(float(c[0]), float(c[1]))


def _obstacle_poly(ctx: UnitContext, oid: str) -> FloatArray | None:
    for o, poly in obstacle_polygons(ctx):
        if o.id == oid:
            return np.asarray(poly.exterior.coords)[:-1]
    return None


# -- room to use things -----------------------------------------------------------------------------------


def front_strip(
    poly: FloatArray, center: FloatArray, rotation: float, depth: float = FRONT_CLEARANCE, flank: float = 0.0
) -> Polygon:
    """The strip in front of an object's front: its width (and ``flank`` more on either side),
    ``depth`` deep (the object's outline ``poly``, its centre and its rotation in the view)."""
    c = np.asarray(center, dtype=np.float64)
    f = _facing(rotation)
    side = np.array([f[1], -f[0]])
    reach = float(((poly - c) @ f).max())
    half = float(np.ptp((poly - c) @ side)) / 2 + flank
    a = c + f * reach
    return outline_polygon(np.array([a - side * half, a + side * half, a + side * half + f * depth, a - side * half + f * depth]))


def front_zone(layout: UnitLayout, oid: str, ctx: UnitContext | None = None) -> Polygon:
    """The space in front of ``oid`` kept for using it: :data:`FRONT_CLEARANCE` deep, or as far as its
    parts swing out when further (``ctx.part_reach``: a wardrobe's door as wide as it is)."""
    front, flank = ctx.part_reach.get(oid, (0.0, 0.0)) if ctx is not None else (0.0, 0.0)
    depth = max(FRONT_CLEARANCE, front + SEPARATION_MARGIN)
    return front_strip(
        layout.polygon(oid), np.asarray(layout.center(oid)), layout.rotation(oid), depth, flank
    )


def _clearance(layout: UnitLayout, ctx: UnitContext) -> list[Finding]:
    """Things standing in the space in front of doors and drawers; the intruder is moved out of
    the strip when that move is clean, else the problem is only remarked."""
    out: list[Finding] = []
    fronts = sorted(
        k
        for k in ctx.against_wall
        if traits(layout.object(k).category).opening == "front" or k in ctx.part_reach
    )
    for k in fronts:
        zone = front_zone(layout, k, ctx)
        for j in layout.ids:
            if j in (k, *ctx.thin) or ctx.seat_table.get(j) == k or ctx.nightstand_bed.get(j) == k:
                continue
            poly = layout.outline(j)
            if poly.intersection(zone).area < 0.02 * max(float(zone.area), 1e-9):
                continue
            f = _facing(layout.rotation(k))
            pm = layout.polygon(j)
            zc = np.asarray(zone.exterior.coords)[:-1]
            need = float((zc @ f).max() - (pm @ f).min()) + SEPARATION_MARGIN
            fix: dict[str, Target] = {}
            if j not in ctx.against_wall and j not in ctx.pinned and not _blocked(layout, ctx, j, pm + f * need, k):
                c = np.asarray(layout.center(j)) + f * need
                fix = {j: Target(float(c[0]), float(c[1]))}
            sev: Severity = "semantic" if fix else "soft"
            out.append(Finding("clearance", (j, k), sev, f"Move ({j}) out of the space in front of ({k}) so its doors and drawers open.", fix))
    return out


def _passage(layout: UnitLayout, ctx: UnitContext, fixable: bool = True) -> list[Finding]:
    """The free floor, eroded by a robot's radius, should be one piece (``scene.Walkable``, the
    NAV raster, with the same bar the variants' NAV must reach). When it is not, the shortest
    clean move of one object next to a cut-off piece that joins the floor again is the fix, once
    the layout is otherwise right (``fixable``; until then the cut is only remarked)."""
    raster = FloorRaster(np.asarray(ctx.surface.region, dtype=np.float64))
    masks = {k: raster.mask(layout.polygon(k)) for k in layout.ids if k not in ctx.thin}
    low = [*obstacle_polygons(ctx), *follower_polygons(layout, ctx)]
    fixed = raster.blocked([poly for o, poly in low if float(o.aabb()[0][2]) < WALK_MAX_HEIGHT])
    blocked = fixed.copy()
    for m in masks.values():
        blocked |= m
    walk = raster.walkable(blocked)
    if walk.total == 0 or walk.share >= WALK_MIN_SHARE:
        return []
    pieces = len(walk.sizes)
    found = _reopen(layout, ctx, raster, masks, fixed, walk) if fixable else None
    lead = f"The walkable floor is cut into {pieces} parts (the largest holds {walk.share:.0%} of it)"
    if found is None:
        return [Finding("passage", (), "soft", f"{lead}; leave a passage of at least {2 * ROBOT_RADIUS:.1f} m between the furniture.")]
    oid, target, way = found
    note = f"{lead}: move ({oid}) {_word(way)} by {float(np.linalg.norm(way)):.2f} m to open a {2 * ROBOT_RADIUS:.1f} m passage."
    return [Finding("passage", (oid,), "semantic", note, {oid: target})]


def _still_seated(layout: UnitLayout, seat: str, table: str, shift: FloatArray) -> bool:
    """Whether ``seat`` moved by ``shift`` still stands at its table, square to the same side
    and within its extent."""
    trial = layout.copy()
    c = np.asarray(layout.center(seat)) + shift
    trial.set_center(seat, float(c[0]), float(c[1]))
    if trial.outline(seat).distance(trial.outline(table)) > SEAT_GAP_MAX:
        return False
    square, on_side, side = _square_on_side(trial, table, seat)
    return square and on_side and side == _seat_side(layout, table, seat)


def _reopen(
    layout: UnitLayout,
    ctx: UnitContext,
    raster: FloorRaster,
    masks: Mapping[str, np.ndarray],
    fixed: np.ndarray,
    walk: Walkable,
) -> tuple[str, Target, FloatArray] | None:
    """The shortest clean move of one free-standing object beside a cut-off piece of floor that
    brings the share of the largest piece up to the bar (else the move that raises it most, by
    at least two points)."""
    import shapely

    cut = (walk.labels > 0) & (walk.labels != walk.main)
    ii, jj = np.nonzero(cut)
    cells = shapely.points(np.column_stack([raster.xs[ii], raster.ys[jj]]))
    reach = 2 * ROBOT_RADIUS + 2 * raster.cell
    best: tuple[float, float, str, FloatArray] | None = None
    for k in sorted(masks):
        if k in ctx.pinned or k in ctx.nightstand_bed:
            continue
        poly = layout.outline(k)
        if float(shapely.distance(poly, cells).min()) > reach:
            continue
        backed, wall = wall_status(layout, ctx, k) if k in ctx.against_wall else (False, None)
        if k in ctx.against_wall and not (backed and wall is not None):
            continue
        dirs = [wall.tangent, -wall.tangent] if wall is not None else [np.array(d, dtype=np.float64) for d in ((1, 0), (-1, 0), (0, 1), (0, -1))]
        others = fixed.copy()
        for j, m in masks.items():
            if j != k:
                others |= m
        pm = layout.polygon(k)
        table = ctx.seat_table.get(k)
        for step in PASSAGE_STEPS:
            for d in dirs:
                moved = pm + d * step
                if table is not None and not _still_seated(layout, k, table, d * step):
                    continue
                if _blocked(layout, ctx, k, moved, ""):
                    continue
                share = raster.walkable(others | raster.mask(moved)).share
                if share >= WALK_MIN_SHARE:
                    c = np.asarray(layout.center(k)) + d * step
                    return k, Target(float(c[0]), float(c[1])), d * step
                if share >= walk.share + 0.02 and (best is None or (-share, step) < (best[0], best[1])):
                    best = (-share, step, k, d * step)
    if best is None:
        return None
    _, _, k, way = best
    c = np.asarray(layout.center(k)) + way
    return k, Target(float(c[0]), float(c[1])), way


# -- the findings ---------------------------------------------------------------------------------------


LayoutRule = Callable[[UnitLayout, UnitContext], Sequence[Finding]]
"""A plugin rule of the critic: ``rule(layout, ctx)`` returns the problems it sees, as findings
whose notes the critic writes and whose fixes the rule actor applies (``docs/plugins.md``)."""


def find_problems(
    layout: UnitLayout,
    ctx: UnitContext,
    check: PhysicalCheck,
    avoid: Collection[str] = (),
    rules: Sequence[LayoutRule] = (),
) -> list[Finding]:
    """Every problem of the layout, most important first, each with a note and its fixes.

    ``avoid``: objects the layout memory saw oscillating or hitting the boundary again and
    again; fixes then move something else, or try the other side. ``rules``: plugin rules, whose
    findings join the built-in ones (after them at equal importance; a rule returning something
    else than findings raises :class:`~scenemosaic.exceptions.UsageError`).
    """
    out: list[Finding] = []
    ids = set(layout.ids)
    for oid in check.out_of_bounds:
        shift = minimal_containing_shift(layout.polygon(oid), Polygon(ctx.surface.region), inset=0.005)
        fixes = {}
        if shift is not None:
            c = np.asarray(layout.center(oid)) + shift
            fixes[oid] = Target(float(c[0]), float(c[1]))
        out.append(
            Finding("out_of_bounds", (oid,), "physical", f"Bring ({oid}) fully back inside the {_surface_name(ctx)}; part of it sticks out.", fixes)
        )
    for oid, (kind, centre, rot) in sorted(ctx.pinned.items()):
        note = next((c.layout_note for c in ctx.clauses if oid in c.related_objects), "")
        if kind == "orientation" and _off(layout.rotation(oid), rot) > PINNED_TURN_MAX and not ctx.frozen_rotation:
            out.append(Finding("clause", (oid,), "semantic", f"Turn ({oid}) back as its cross-unit rule asks: {note}", {oid: Target(rotation=rot)}))
        elif kind == "placement" and math.dist(layout.center(oid), centre) > PINNED_MOVE_MAX:
            out.append(Finding("clause", (oid,), "semantic", f"Put ({oid}) back where its cross-unit rule needs it: {note}", {oid: Target(centre[0], centre[1])}))
    snapped: dict[str, WallLine] = {}
    if ctx.floor and ctx.walls:
        for oid in sorted(ctx.against_wall):
            if oid in ctx.nightstand_bed:
                continue
            ok, wall = wall_status(layout, ctx, oid)
            if ok and wall is not None:
                snapped[oid] = wall
            elif wall is not None and oid not in ctx.pinned:
                out.append(
                    Finding(
                        "against_wall", (oid,), "semantic",
                        f"Push ({oid}) back so its back is flush against the wall behind it ({wall.id}) and its front faces into the room.",
                        {oid: snap_target(layout, oid, wall)},
                    )
                )
        sides = _stand_sides(layout, ctx)
        pairs = {frozenset((p.a, p.b)) for p in check.collisions}
        stands_of: dict[str, int] = {}
        for b in ctx.nightstand_bed.values():
            stands_of[b] = stands_of.get(b, 0) + 1
        for stand, bed in sorted(ctx.nightstand_bed.items()):
            if bed not in ids or frozenset((stand, bed)) in pairs:
                continue  # touching its bed: the collision fix moves it a little first
            ok, wall = wall_status(layout, ctx, stand)
            if beside_ok(layout, stand, bed) and (ok or not wall_status(layout, ctx, bed)[0]):
                if ok and wall is not None:
                    snapped[stand] = wall
                continue  # beside the head, and against the wall whenever the bed is
            out.append(
                Finding(
                    "beside_bed", (stand, bed), "semantic",
                    f"Place ({stand}) right beside the head of the bed ({bed}), on its side, facing the same way as the bed.",
                    {stand: beside_target(layout, stand, bed, flip=stand in avoid and stands_of[bed] == 1, side=sides.get(stand))},
                )
            )
        by_table: dict[str, list[str]] = {}
        for seat, table in sorted(ctx.seat_table.items()):
            if table in ids and seat not in ctx.pinned:
                by_table.setdefault(table, []).append(seat)
        for table, seats in sorted(by_table.items()):
            out.extend(_seating(layout, ctx, table, seats))
        for oid in sorted(ctx.with_front - ctx.against_wall - set(ctx.seat_table)):
            wall = _faces_wall(layout, ctx, oid)
            if wall is not None:
                out.append(
                    Finding(
                        "faces_wall", (oid,), "semantic", f"Turn ({oid}) around: it faces the wall ({wall.id}) from close by.",
                        {oid: Target(rotation=normalize_degrees(layout.rotation(oid) + 180.0))},
                    )
                )
        out.extend(_clearance(layout, ctx))
        for piece, faced in sorted(ctx.keep_facing):
            if piece not in ids or faced not in ids or layout_faces(layout, piece, faced):
                continue
            if piece in ctx.against_wall or piece in ctx.pinned or ctx.frozen_rotation:
                slide = _slide_to_face(layout, ctx, piece, faced)
                if slide is None:
                    out.append(Finding("faces_group", (piece, faced), "soft", f"({piece}) no longer faces ({faced}); turn or move them to face each other again."))
                else:
                    mover, target = slide
                    out.append(
                        Finding(
                            "faces_group", (piece, faced), "semantic",
                            f"Slide ({mover}) along its wall until ({piece}) and ({faced}) face each other again.", {mover: target},
                        )
                    )  # fmt: skip
                continue
            way = np.asarray(layout.center(faced)) - np.asarray(layout.center(piece))
            out.append(
                Finding(
                    "faces_group", (piece, faced), "semantic", f"Turn ({piece}) to face ({faced}) again, as it did.",
                    {piece: Target(rotation=facing_degrees(way))},
                )
            )
        for sofa, tv in sorted(ctx.sofa_tv.items()):
            d = np.asarray(layout.center(tv)) - np.asarray(layout.center(sofa))
            if float(np.linalg.norm(d)) > 1e-6 and _off(layout.rotation(sofa), facing_degrees(d)) > 90.0:
                out.append(Finding("sofa_tv", (sofa, tv), "soft", f"The sofa ({sofa}) turns its back on the TV stand ({tv}); consider facing them to each other."))
    if ctx.floor and ctx.walls:
        out.extend(_passage(layout, ctx, fixable=check.clean and all(f.severity == "soft" for f in out)))
    for pair in check.collisions:
        sep = _separation(layout, ctx, pair, avoid, snapped)
        names = f"({pair.a}) and ({pair.b})"
        if sep is None:
            out.append(Finding("collision", (pair.a, pair.b), "physical", f"{names} interpenetrate ({pair.contacts} contacts, {pair.depth_m * 100:.0f} cm deep)."))
            continue
        mover, target = sep
        direction = np.array([target.u or 0.0, target.v or 0.0]) - np.asarray(layout.center(mover))
        out.append(
            Finding(
                "collision", (pair.a, pair.b), "physical",
                f"{names} interpenetrate ({pair.contacts} contacts, {pair.depth_m * 100:.0f} cm deep): move ({mover}) {_word(direction)} until they are clear.",
                {mover: target},
            )
        )
    for rule in rules:
        found = list(rule(layout, ctx))
        bad = [f for f in found if not isinstance(f, Finding)]
        if bad:
            name = getattr(rule, "__name__", type(rule).__name__)
            raise UsageError(f"layout rule {name} returned {type(bad[0]).__name__}, not a Finding")
        out.extend(found)
    out.sort(key=lambda f: _ORDER.get(f.kind, 99))
    return out


def _legacy_seat(layout: UnitLayout, ctx: UnitContext, seat: str, table: str) -> list[Finding]:
    """A seat at a table with no slot plan (its seats do not all fit around it): pulled up along
    the way to the table and turned to face it within ``FACING_TABLE_DEG``."""
    out: list[Finding] = []
    gap = float(layout.outline(seat).distance(layout.outline(table)))
    if gap > SEAT_GAP_MAX and seat not in ctx.pinned:
        target = _seat_target(layout, ctx, seat, table)
        out.append(
            Finding(
                "seat_distance", (seat, table), "semantic" if target else "soft",
                f"Pull ({seat}) up to its table ({table}) and face it; it stands {gap:.1f} m away.",
                {seat: target} if target else {},
            )
        )
        if target is not None:
            return out  # the pull-up turns it to the table too
    d = table_direction(layout, seat, table)
    if d is None or ctx.frozen_rotation:
        return out
    want = facing_degrees(d)
    if _off(layout.rotation(seat), want) > FACING_TABLE_DEG:
        out.append(
            Finding("faces_table", (seat, table), "semantic", f"Turn ({seat}) to face the table ({table}) squarely.", {seat: Target(rotation=want)})
        )
        return out
    square, on_side, side = _square_on_side(layout, table, seat)
    if on_side and not square and traits(layout.object(table).category).table:
        # facing the table roughly is not enough: square to the side it sits at, as the seating judge holds it
        n = _table_sides(layout, table)[side][0]
        out.append(
            Finding("faces_table", (seat, table), "semantic", f"Turn ({seat}) square to the {side} side of the table ({table}).", {seat: Target(rotation=facing_degrees(-n))})
        )
    return out


def _on_own_sides(layout: UnitLayout, ctx: UnitContext, table: str, seats: list[str], breaches: list[str]) -> dict[str, Target]:
    """The least change that seats every seat right when the sides already hold the right
    counts: each breaching seat squared up at the side it sits at, drawn up to ``SEAT_GAP`` (or
    kept as close as it is), its centre moved within the side's extent. Empty when the counts are
    wrong, a seat sits at a side that takes none, or a squared-up seat would not be clear."""
    if any("long sides" in b or "no seat belongs" in b for b in breaches):
        return {}
    sides = _table_sides(layout, table)
    c = np.asarray(layout.center(table))
    _w, seat_d = _seat_size(layout, seats)
    out: dict[str, Target] = {}
    trial = layout.copy()
    for k in sorted(seats):
        square, on_side, side = _square_on_side(layout, table, k)
        gap = float(layout.outline(k).distance(layout.outline(table)))
        if square and on_side and gap <= SEAT_GAP_MAX:
            continue
        n, half, edge = sides[side]
        along = np.array([n[1], -n[0]])
        rel = np.asarray(layout.center(k)) - c
        half_w = float(layout.object(k).size[0]) / 2
        t = float(np.clip(rel @ along, -max(half - half_w, 0.0), max(half - half_w, 0.0)))
        out_d = min(max(float(rel @ n), edge), edge + SEAT_GAP + seat_d / 2)  # a tucked-in seat stays tucked
        p = c + n * out_d + along * t
        slot = SeatSlot(float(p[0]), float(p[1]), facing_degrees(-n), side)
        if not _slots_free(trial, ctx, table, [], slot, k):
            return {}
        trial.set_rotation(k, slot.rotation)
        trial.set_center(k, slot.u, slot.v)
        out[k] = Target(slot.u, slot.v, slot.rotation)
    return out


def _seating(layout: UnitLayout, ctx: UnitContext, table: str, seats: list[str]) -> list[Finding]:
    """The seating etiquette at one table: when a seat breaks it and the sides already hold the
    right counts, the breaching seats square up where they sit (:func:`_on_own_sides`); else
    every seat that is not in its slot moves there (:func:`seat_slots`); without a slot plan,
    each seat on its own."""
    breaches = seating_breaches(layout, ctx, table, seats)
    if not breaches:
        return []
    own = _on_own_sides(layout, ctx, table, seats, breaches)
    if own:
        where = ", ".join(f"({k})" for k in sorted(own))
        note = f"Seat the chairs at ({table}) as people sit: {'; '.join(breaches)}. Turn {where} square to the side of the table it sits at and draw it up, centred within that side."
        return [Finding("seating", (table, *sorted(own)), "semantic", note, own)]
    plan = seat_slots(layout, ctx, table, seats)
    if not plan:
        return [f for k in seats for f in _legacy_seat(layout, ctx, k, table)]
    fixes = {
        k: Target(sl.u, sl.v, sl.rotation)
        for k, sl in sorted(plan.items())
        if math.dist(layout.center(k), (sl.u, sl.v)) > 0.01 or _off(layout.rotation(k), sl.rotation) > 0.5
    }
    if not fixes:
        return []
    where = ", ".join(f"({k}) at its {plan[k].side} side" for k in sorted(fixes))
    note = (
        f"Seat the chairs at ({table}) as people sit: {'; '.join(breaches)}. Put {where}, each centred in its place "
        "on that side and facing the table squarely; fill the long sides evenly before the ends."
    )
    return [Finding("seating", (table, *sorted(fixes)), "semantic", note, fixes)]


def _surface_name(ctx: UnitContext) -> str:
    kind = ctx.unit.anchor_kind
    if kind == "floor":
        return "room's floor"
    if kind == "ceiling":
        return "ceiling"
    if kind == "wall":
        return f"wall ({ctx.unit.anchor_id})"
    return f"surface of its anchor ({ctx.unit.anchor_id})"


def merged_fixes(findings: list[Finding], allowed: Collection[str] | None = None) -> dict[str, Target]:
    """One target per object: the first (most important) position fix and the first rotation fix."""
    out: dict[str, Target] = {}
    for f in findings:
        for oid, t in f.fixes.items():
            if allowed is not None and oid not in allowed:
                continue
            cur = out.get(oid)
            if cur is None:
                out[oid] = t
                continue
            pos = (cur.u, cur.v) if cur.u is not None else (t.u, t.v)
            sym = cur.symbolic if cur.u is not None else t.symbolic
            rot = cur.rotation if cur.rotation is not None else t.rotation
            out[oid] = Target(pos[0], pos[1], rot, sym)
    return out


def rule_violations(layout: UnitLayout, ctx: UnitContext, check: PhysicalCheck) -> list[str]:
    """The hard rules a finished layout must keep, as sentences (empty when all hold):
    no collisions, nothing out of bounds, wall pieces backed within 5 cm and facing in within
    10°, seats seated by the etiquette (:func:`seating_breaches`; facing their table within 15°
    where the table has no slot plan), nightstands beside their bed's head, free-standing lounge
    pieces still facing what they faced (``ctx.keep_facing``; two wall pieces that no longer face
    each other are the composition's to refuse)."""
    out = [f"collision {p.a} ~ {p.b} ({p.depth_m * 100:.1f} cm)" for p in check.collisions]
    out += [f"{k} out of bounds" for k in check.out_of_bounds]
    if ctx.floor and ctx.walls:
        for oid in sorted(ctx.against_wall):
            if oid in ctx.pinned:
                continue
            ok, _wall = wall_status(layout, ctx, oid)
            if not ok:
                out.append(f"{oid} not backed against a wall")
        for stand, bed in sorted(ctx.nightstand_bed.items()):
            if not beside_ok(layout, stand, bed):
                out.append(f"{stand} not beside the head of {bed}")
        by_table: dict[str, list[str]] = {}
        for seat, table in sorted(ctx.seat_table.items()):
            by_table.setdefault(table, []).append(seat)
        for table, seats in sorted(by_table.items()):
            if seat_slots(layout, ctx, table, seats):
                out += seating_breaches(layout, ctx, table, seats)
                continue
            for seat in seats:
                d = table_direction(layout, seat, table)
                if d is not None and _off(layout.rotation(seat), facing_degrees(d)) > FACING_TABLE_DEG:
                    out.append(f"{seat} does not face {table}")
        ids = set(layout.ids)
        for piece, target in sorted(ctx.keep_facing):
            free = piece not in ctx.against_wall and piece not in ctx.pinned
            if free and piece in ids and target in ids and not layout_faces(layout, piece, target):
                out.append(f"{piece} no longer faces {target}")
    return out

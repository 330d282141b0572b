"""Rule archetypes: structurally different arrangements of a unit, and how to instantiate them.

The offline archetype agent proposes, in this order of preference, the ones that differ from
the original (an arrangement whose every object lands within 0.3 m and 20° of an object of
the same category in the original is the same arrangement, and is skipped):

* ``plan_<k>`` — in a room with doors (a room of a house), the room plans of
  ``evolve/_plans.py``: the furniture regrouped on other walls, each plan valid for the house
  by construction (doors clear and reachable, the floor connected, fixtures in place);
* ``rotated_180`` — the whole arrangement turned half a turn about the surface centre (floor,
  ceiling and object tops);
* ``mirrored_lr`` / ``mirrored_ud`` — mirrored about the surface's vertical / horizontal centre
  line (walls and containers: centres only, so pictures stay upright and books keep their spines);
* ``swapped_<a>_<b>`` — two wall pieces of different kinds trade places along the walls, each
  taking its functional group (a bed its nightstands) along, backed against its new wall and slid
  along it to fit;
* ``seated_<table>`` — the seats of a table spread evenly along its sides, long sides first;
* ``centred_<table>`` — a free-standing table and its seats moved to the middle of the room;
* ``turned_<table>`` — a table and its seats turned a quarter turn about the table;
* ``slid_<side>_<table>`` — a free-standing table and its seats slid toward one side of the view
  as far as they fit clear of the rest (at least 1 m);
* ``moved_<piece>_<wall>`` — a wall piece and its group (a bed and its nightstands, a desk and
  its chair) carried to another wall, to the free stretch farthest from where it stood: only
  where the whole group, and the space in front of the piece, fits clear of everything else;
* ``displaced_<piece>_<wall>[a|b]`` — a wall piece's group carried to the middle (or an end) of
  a wall, the wall pieces standing there re-placed;
* ``displaced2_<wall>_<wall>`` — the two largest wall pieces each displaced to another wall.

With a limit below the number found, the ones most different in footprint are offered.
The Critic-Actor loop then makes each instantiation valid (walls, facing, collisions, bounds).
How many are offered follows the method: at most 1 for 1-5 objects, 2 for 6-10, 3 above.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from shapely.geometry import Polygon

from scenemosaic.evolve._analysis import (
    FRONT_CLEARANCE,
    SEAT_GAP_MAX,
    WALL_FLUSH_GAP,
    beside_target,
    front_strip,
    front_zone,
    layout_faces,
    obstacle_polygons,
    seat_slots,
    seating_breaches,
    wall_status,
)
from scenemosaic.evolve._context import (
    UnitContext,
    WallLine,
    parts_in_the_way,
    screens_put_behind,
    windows_in_the_way,
)
from scenemosaic.evolve._plans import (
    MAX_PLANS,
    Placement,
    doors_kept,
    fixed_children,
    flush_positions,
    move_group,
    plan_summary,
    room_plans,
)
from scenemosaic.scene import FloorRaster, UnitLayout, is_screen, mask_iou, normalize_degrees

__all__ = ["RuleArchetype", "instantiate", "max_alternatives", "rule_archetypes"]

SAME_PLACE_M = 0.3
SAME_TURN_DEG = 20.0


def max_alternatives(n_objects: int) -> int:
    """How many alternatives a unit of ``n_objects`` children may get (method: 1 / 2 / 3)."""
    if n_objects <= 0:
        return 0
    if n_objects <= 5:
        return 1
    if n_objects <= 10:
        return 2
    return 3


@dataclass(frozen=True)
class RuleArchetype:
    """One offline design pattern: its id, a name, why, and the placement it gives."""

    layout_id: str
    style_name: str
    reasoning: str
    place: Callable[[UnitLayout, UnitContext], Placement]

    def __post_init__(self) -> None:
        # the agents' schema: ids of [a-z0-9_] up to 40 characters, names up to 80, reasons up to 600
        object.__setattr__(self, "layout_id", re.sub(r"[^a-z0-9_]", "_", self.layout_id.lower())[:40])
        object.__setattr__(self, "style_name", _clip(self.style_name, 80))
        object.__setattr__(self, "reasoning", _clip(self.reasoning, 600))


def _clip(text: str, limit: int) -> str:
    return text if len(text) <= limit else text[: limit - 1].rstrip() + "…"


def _current(layout: UnitLayout) -> Placement:
    return {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids}


def _keep_rotation(ctx: UnitContext) -> bool:
    return ctx.frozen_rotation or ctx.unit.anchor_kind == "wall"


def _rotated(layout: UnitLayout, ctx: UnitContext) -> Placement:
    U, V = layout.surface.size
    return {k: (U - u, V - v, normalize_degrees(r + 180.0)) for k, (u, v, r) in _current(layout).items()}


def _mirror_lr(layout: UnitLayout, ctx: UnitContext) -> Placement:
    U, _ = layout.surface.size
    keep = _keep_rotation(ctx)
    return {k: (U - u, v, r if keep else normalize_degrees(-r)) for k, (u, v, r) in _current(layout).items()}


def _mirror_ud(layout: UnitLayout, ctx: UnitContext) -> Placement:
    _, V = layout.surface.size
    keep = _keep_rotation(ctx)
    return {k: (u, V - v, r if keep else normalize_degrees(180.0 - r)) for k, (u, v, r) in _current(layout).items()}


def _group(ctx: UnitContext, head: str) -> list[str]:
    members = [s for s, t in ctx.seat_table.items() if t == head] + [n for n, b in ctx.nightstand_bed.items() if b == head]
    return [head, *sorted(members)]


def _fit_to_wall(place: Placement, layout: UnitLayout, ctx: UnitContext, members: list[str], wall: WallLine | None) -> None:
    """Put a group placed at ``wall`` right: nightstands tucked beside their bed's head, the head
    piece's back flush against the wall, and the group slid along it until every member's span
    lies within the wall (centred on it when longer)."""
    if wall is None:
        return
    trial = layout.copy()
    for k in members:
        u, v, r = place[k]
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    for k in members[1:]:
        if ctx.nightstand_bed.get(k) == members[0]:
            t = beside_target(trial, k, members[0])
            assert t.u is not None and t.v is not None and t.rotation is not None
            place[k] = (t.u, t.v, t.rotation)
            trial.set_rotation(k, t.rotation)
            trial.set_center(k, t.u, t.v)
    move = (WALL_FLUSH_GAP - wall.gap(trial.polygon(members[0]))) * np.asarray(wall.inward)
    spans = [wall.along(trial.polygon(k) + move) for k in members]
    lo, hi = min(a for a, _ in spans), max(b for _, b in spans)
    if hi - lo > wall.length:  # longer than the wall: centred on it (the loop tucks the ends in)
        move = move + ((wall.length - hi - lo) / 2) * wall.tangent
    elif lo < 0:
        move = move + (-lo + WALL_FLUSH_GAP) * wall.tangent
    elif hi > wall.length:
        move = move - (hi - wall.length + WALL_FLUSH_GAP) * wall.tangent
    for k in members:
        u, v, r = place[k]
        place[k] = (u + float(move[0]), v + float(move[1]), r)


def _swap(a: str, b: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        ca, cb = np.asarray(layout.center(a)), np.asarray(layout.center(b))
        ra, rb = layout.rotation(a), layout.rotation(b)
        move_group(out, layout, _group(ctx, a), ca, cb, normalize_degrees(rb - ra))
        move_group(out, layout, _group(ctx, b), cb, ca, normalize_degrees(ra - rb))
        _fit_to_wall(out, layout, ctx, _group(ctx, a), wall_status(layout, ctx, b)[1])
        _fit_to_wall(out, layout, ctx, _group(ctx, b), wall_status(layout, ctx, a)[1])
        return out

    return place


def _turn(table: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        c = np.asarray(layout.center(table))
        move_group(out, layout, _group(ctx, table), c, c, 90.0)
        return out

    return place


def _centred(table: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        c = np.asarray(layout.center(table))
        middle = np.asarray(Polygon(ctx.surface.region).centroid.coords[0])
        move_group(out, layout, _group(ctx, table), c, middle, 0.0)
        return out

    return place


def _seated(table: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        seats = sorted(s for s, t in ctx.seat_table.items() if t == table)
        for s, slot in seat_slots(layout, ctx, table, seats).items():
            out[s] = (slot.u, slot.v, slot.rotation)
        return out

    return place


MOVE_STEP = 0.1
"""Spacing, metres, of the places along a wall tried for a moved group."""
MOVE_MARGIN = 0.05
"""A moved group keeps at least this far, metres, from everything it does not bring along."""
MOVE_MIN_M = 1.0
"""A place counts as another place when the piece's centre moves at least this far, metres."""


def _inner_region(ctx: UnitContext) -> Polygon:
    """The surface a moved piece must stay inside: inset by the flush gap a piece keeps from its
    wall, less a millimetre, so a piece set flush against a wall (``WALL_FLUSH_GAP``) is inside
    whatever rounding the wall's coordinates carry (a bed flush on the west wall used to fall
    0.1 micrometre outside and lose every place along that wall)."""
    return Polygon(ctx.surface.region).buffer(-(WALL_FLUSH_GAP - 0.001), join_style="mitre")


class _Room:
    """What a moved group must stay clear of: the surface (inset as :func:`_inner_region`) and every solid object it
    does not bring along, grown by ``MOVE_MARGIN``."""

    def __init__(self, layout: UnitLayout, ctx: UnitContext, members: list[str]) -> None:
        from shapely import prepare
        from shapely.ops import unary_union

        top = max(layout.span(k)[1] for k in members)
        others = [layout.outline(k) for k in layout.ids if k not in members and k not in ctx.thin]
        others += [poly for o, poly in obstacle_polygons(ctx) if float(o.aabb()[0][2]) < top]
        # where the drawers and doors of the pieces that stay swing out (a TV stand's drawers)
        others += [front_zone(layout, k, ctx) for k in layout.ids if k not in members and k in ctx.part_reach]
        self.blocked = unary_union([p.buffer(MOVE_MARGIN, join_style="mitre") for p in others]) if others else Polygon()
        self.region = _inner_region(ctx)
        prepare(self.blocked)
        prepare(self.region)
        self.layout = layout
        self.members = members

    def placed(self, here: np.ndarray, to: np.ndarray, turn: float) -> tuple[Placement, UnitLayout] | None:
        """The group turned by ``turn`` and carried from ``here`` to ``to``, with the layout of its
        members where they land, when every member lands on the surface clear of the rest."""
        place: Placement = {}
        move_group(place, self.layout, self.members, here, to, turn)
        moved = self.layout.copy(only={*self.members, *place})
        for k, (u, v, r) in place.items():
            moved.set_rotation(k, r)
            moved.set_center(k, u, v)
        for k in self.members:
            shape = moved.outline(k)
            if not self.region.covers(shape) or self.blocked.intersects(shape):
                return None
        return place, moved

    def clear(self, zone: Polygon) -> bool:
        return self.region.covers(zone) and not self.blocked.intersects(zone)


def _use_strip(layout: UnitLayout, ctx: UnitContext, piece: str, to: np.ndarray, facing: float) -> Polygon:
    """The strip kept in front of ``piece`` placed at ``to`` facing ``facing``: ``FRONT_CLEARANCE``
    deep, or as far as its parts swing out (``ctx.part_reach``)."""
    front, flank = ctx.part_reach.get(piece, (0.0, 0.0))
    return front_strip(layout.polygon(piece), to, facing, max(FRONT_CLEARANCE, front + MOVE_MARGIN), flank)


def _wall_positions(layout: UnitLayout, piece: str, wall: WallLine) -> tuple[float, list[np.ndarray]]:
    """The turn that backs ``piece`` against ``wall`` and the centres it may take along it, every
    ``MOVE_STEP``, its back flush and its span within the wall."""
    return normalize_degrees(wall.facing - layout.rotation(piece)), flush_positions(layout, piece, wall, MOVE_STEP)


def _spot(layout: UnitLayout, ctx: UnitContext, piece: str, wall: WallLine) -> Placement | None:
    """The piece backed against ``wall`` with its group carried along, at the free place farthest
    from where it stands (every member on the surface, the group and a ``FRONT_CLEARANCE`` strip
    in front of the piece clear of everything else by ``MOVE_MARGIN``); ``None`` when no place fits."""
    room = _Room(layout, ctx, _group(ctx, piece))
    here = np.asarray(layout.center(piece))
    turn, positions = _wall_positions(layout, piece, wall)
    best: tuple[float, Placement] | None = None
    for to in positions:
        dist = float(np.linalg.norm(to - here))
        if dist < MOVE_MIN_M or (best is not None and dist <= best[0]):
            continue
        found = room.placed(here, to, turn)
        if found is None or not room.clear(_use_strip(found[1], ctx, piece, to, wall.facing)):
            continue
        best = (dist, found[0])
    return None if best is None else {**_current(layout), **best[1]}


_SIDES = {"left": (-1.0, 0.0), "right": (1.0, 0.0), "top": (0.0, 1.0), "bottom": (0.0, -1.0)}


def _slide_spot(layout: UnitLayout, ctx: UnitContext, table: str, side: str) -> Placement | None:
    """A free-standing table and its seats slid toward ``side`` of the view as far as they fit
    (at least ``MOVE_MIN_M``), clear of everything else by ``MOVE_MARGIN``; ``None`` when they cannot."""
    room = _Room(layout, ctx, _group(ctx, table))
    here = np.asarray(layout.center(table))
    d = np.asarray(_SIDES[side])
    span = max(layout.surface.size)
    for t in np.arange(span, MOVE_MIN_M - 1e-9, -MOVE_STEP):
        found = room.placed(here, here + d * t, 0.0)
        if found is not None:
            return {**_current(layout), **found[0]}
    return None


def _slid(table: str, side: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        spot = _slide_spot(layout, ctx, table, side)
        return spot if spot is not None else _current(layout)

    return place


def _relocated(piece: str, wall_id: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        wall = next((w for w in ctx.walls if w.id == wall_id), None)
        spot = _spot(layout, ctx, piece, wall) if wall is not None else None
        return spot if spot is not None else _current(layout)

    return place


def _relocations(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    """Every wall piece's group carried to each other wall where it fits, the longest moves first."""
    found: list[tuple[float, str, RuleArchetype]] = []
    for piece in sorted(ctx.against_wall - set(ctx.nightstand_bed) - set(ctx.pinned)):
        if any(k in ctx.pinned for k in _group(ctx, piece)):
            continue
        _, own = wall_status(layout, ctx, piece)
        cat = layout.object(piece).category
        for wall in ctx.walls:
            if own is not None and wall.id == own.id:
                continue
            spot = _spot(layout, ctx, piece, wall)
            if spot is None:
                continue
            dist = math.dist(spot[piece][:2], layout.center(piece))
            lid = f"moved_{piece}_{wall.id}"[:40]
            found.append(
                (-dist, lid, RuleArchetype(lid, f"{cat} on another wall", f"the {cat} ({piece}) and its group carried to the wall ({wall.id}), where they fit clear of the rest", _relocated(piece, wall.id)))
            )
    found.sort(key=lambda x: (x[0], x[1]))
    return [r for _, _, r in found]


def _wall_place(
    layout: UnitLayout, ctx: UnitContext, piece: str, wall: WallLine, blocked: Any, near: np.ndarray
) -> tuple[Placement, list[Polygon]] | None:
    """``piece`` and its group backed against ``wall`` at the free place nearest ``near``: every
    member on the surface and clear of ``blocked`` (grown by ``MOVE_MARGIN``), a
    ``FRONT_CLEARANCE`` strip in front of the piece free too. Returns the members' places and
    the outlines they take (the strip included)."""
    members = _group(ctx, piece)
    region = _inner_region(ctx)
    here = np.asarray(layout.center(piece))
    turn, positions = _wall_positions(layout, piece, wall)
    best: tuple[float, Placement, list[Polygon]] | None = None
    for to in positions:
        key = float(np.linalg.norm(to - near))
        if best is not None and key >= best[0]:
            continue
        place: Placement = {}
        move_group(place, layout, members, here, to, turn)
        moved = layout.copy()
        for k, (u, v, r) in place.items():
            moved.set_rotation(k, r)
            moved.set_center(k, u, v)
        for k in members[1:]:  # nightstands tucked beside the bed's head
            if ctx.nightstand_bed.get(k) == piece:
                tk = beside_target(moved, k, piece)
                assert tk.u is not None and tk.v is not None and tk.rotation is not None
                place[k] = (tk.u, tk.v, tk.rotation)
                moved.set_rotation(k, tk.rotation)
                moved.set_center(k, tk.u, tk.v)
        shapes = [moved.outline(k) for k in members]
        strip = _use_strip(moved, ctx, piece, to, wall.facing)
        if (
            all(region.covers(sh) and not blocked.intersects(sh) for sh in shapes)
            and region.covers(strip)
            and not blocked.intersects(strip)
        ):
            best = (key, place, [*shapes, strip])
    return None if best is None else (best[1], best[2])


def _rearranged(
    layout: UnitLayout,
    ctx: UnitContext,
    piece: str,
    wall: WallLine,
    own: WallLine,
    near: np.ndarray,
    wall_pieces: list[str],
    fixed: list[Polygon],
) -> Placement | None:
    """``piece``'s group on ``wall`` nearest ``near``, the wall pieces it lands on re-placed
    (largest first: where ``piece`` stood, else on the first other wall with room); ``None``
    when one of them finds no place."""
    from shapely.ops import unary_union

    def grown(polys: list[Polygon]) -> Any:
        return unary_union([p.buffer(MOVE_MARGIN, join_style="mitre") for p in polys]) if polys else Polygon()

    first = _wall_place(layout, ctx, piece, wall, grown(fixed), near)
    if first is None:
        return None
    out = dict(first[0])
    taken = list(first[1])
    claimed = grown(taken)
    hit = [k for k in wall_pieces if k != piece and any(claimed.intersects(layout.outline(m)) for m in _group(ctx, k))]
    staying = [layout.outline(m) for k in wall_pieces if k != piece and k not in hit for m in _group(ctx, k)]
    walls = [own, *(w for w in ctx.walls if w.id not in (own.id, wall.id))]
    for k in sorted(hit, key=lambda k: (-float(layout.outline(k).area), k)):
        blocked = grown([*fixed, *staying, *taken])
        spot = None
        for w in walls:
            spot = _wall_place(layout, ctx, k, w, blocked, np.asarray(layout.center(piece) if w.id == own.id else layout.center(k)))
            if spot is not None:
                break
        if spot is None:
            return None
        out.update(spot[0])
        taken += spot[1]
    return out


def _displaced(piece: str, wall_id: str, where: str = "middle") -> Callable[[UnitLayout, UnitContext], Placement]:
    """``piece`` and its group carried to ``wall_id`` (a bed to another wall with its
    nightstands): to its middle, else to either end (``where="middle"``), or as near its end
    ``a`` or ``b`` as it fits, and every wall piece standing there re-placed (:func:`_rearranged`). Free-standing pieces and other units' objects stay
    and are never covered; when a displaced piece finds no place the arrangement is the current
    one (and is not offered)."""

    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        current = _current(layout)
        wall = next((w for w in ctx.walls if w.id == wall_id), None)
        _ok, own = wall_status(layout, ctx, piece)
        if wall is None or own is None:
            return current
        wall_pieces = sorted(ctx.against_wall - set(ctx.nightstand_bed) - set(ctx.pinned))
        grouped = {m for k in wall_pieces for m in _group(ctx, k)}
        fixed = [layout.outline(k) for k in layout.ids if k not in grouped and k not in ctx.thin]
        top = max(layout.span(m)[1] for m in grouped)
        fixed += [poly for o, poly in obstacle_polygons(ctx) if float(o.aabb()[0][2]) < top]

        middle, a, b = (np.asarray(wall.a) + np.asarray(wall.b)) / 2, np.asarray(wall.a), np.asarray(wall.b)
        tries = {"middle": (middle, a, b), "a": (a,), "b": (b,)}[where]
        for near in tries:
            found = _rearranged(layout, ctx, piece, wall, own, near, wall_pieces, fixed)
            if found is not None:
                return {**current, **found}
        return current

    return place


def _displacements(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    """Every wall piece's group carried to the middle of each other wall, the pieces there
    re-placed (:func:`_displaced`), the largest pieces first; then the same toward either end of
    every wall, its own included (a bed slid to a corner frees the middle of the room)."""
    out: list[tuple[float, int, str, RuleArchetype]] = []
    for piece in sorted(ctx.against_wall - set(ctx.nightstand_bed) - set(ctx.pinned)):
        if any(k in ctx.pinned for k in _group(ctx, piece)):
            continue
        _, own = wall_status(layout, ctx, piece)
        cat = layout.object(piece).category
        area = -float(layout.outline(piece).area)
        for wall in ctx.walls:
            if own is None:
                continue
            if wall.id != own.id:
                lid = f"displaced_{piece}_{wall.id}"[:40]
                reason = f"the {cat} ({piece}) and its group moved to the middle of the wall ({wall.id}); what stood there takes another place along the walls"
                out.append((area, 0, lid, RuleArchetype(lid, f"{cat} on the {wall.id} wall, the rest rearranged", reason, _displaced(piece, wall.id))))
            for end in ("a", "b"):
                lid = f"displaced_{piece}_{wall.id}{end}"[:40]
                reason = f"the {cat} ({piece}) and its group moved toward one end of the wall ({wall.id}), freeing the rest of the floor; what stood there takes another place along the walls"
                out.append((area, 1, lid, RuleArchetype(lid, f"{cat} toward a corner of the {wall.id} wall", reason, _displaced(piece, wall.id, end))))
    out.sort(key=lambda x: (x[1], x[0], x[2]))
    return [r for *_, r in out]


def _double_displacements(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    """The two largest wall pieces each carried to the middle of another wall (the larger first,
    then the other from where the first left it): a bed on a new wall and the wardrobe on a third,
    an arrangement no single move reaches."""
    pieces = sorted(
        (k for k in ctx.against_wall - set(ctx.nightstand_bed) - set(ctx.pinned) if not any(m in ctx.pinned for m in _group(ctx, k))),
        key=lambda k: (-float(layout.outline(k).area), k),
    )[:2]
    if len(pieces) < 2:
        return []
    first, second = pieces
    own_first, own_second = wall_status(layout, ctx, first)[1], wall_status(layout, ctx, second)[1]
    if own_first is None or own_second is None:
        return []
    out = []
    for wa in ctx.walls:
        if wa.id == own_first.id:
            continue
        for wb in ctx.walls:
            if wb.id in (wa.id, own_second.id):
                continue
            ca, cb = layout.object(first).category, layout.object(second).category
            lid = f"displaced2_{wa.id}_{wb.id}"[:40]
            reason = f"the {ca} ({first}) and its group moved to the middle of the wall ({wa.id}), then the {cb} ({second}) to the middle of the wall ({wb.id}); what stood there takes another place along the walls"
            out.append(RuleArchetype(lid, f"{ca} on the {wa.id} wall, {cb} on the {wb.id} wall", reason, _then(_displaced(first, wa.id), _displaced(second, wb.id))))
    return out


def _slides(layout: UnitLayout, ctx: UnitContext, table: str, scattered: bool) -> list[RuleArchetype]:
    """``slid_<side>_<table>`` for each side the group fits toward; seats standing away from
    their table are gathered around it first (a group spread over the room cannot slide)."""
    if table in ctx.pinned:
        return []
    cat = layout.object(table).category
    seats = sorted(s for s, t in ctx.seat_table.items() if t == table)
    gather = scattered and bool(seat_slots(layout, ctx, table, seats))
    start = layout
    if gather:
        start = layout.copy()
        for k, (u, v, r) in _seated(table)(layout, ctx).items():
            start.set_rotation(k, r)
            start.set_center(k, u, v)
    out = []
    for side in _SIDES:
        if _slide_spot(start, ctx, table, side) is None:
            continue
        place = _then(_seated(table), _slid(table, side)) if gather else _slid(table, side)
        why = f"the table ({table}) and its seats{' gathered around it and' if gather else ''} slid toward the {side} of the view as far as they fit clear of the rest"
        out.append(RuleArchetype(f"slid_{side}_{table}"[:40], f"{cat} group toward the {side} of the view", why, place))
    return out


def _plan_place(place: Placement) -> Callable[[UnitLayout, UnitContext], Placement]:
    def placed(layout: UnitLayout, ctx: UnitContext) -> Placement:
        return dict(place)

    return placed


def _plans(layout: UnitLayout, ctx: UnitContext) -> Iterator[RuleArchetype]:
    """The room plans of a floor unit with doors (``evolve/_plans.py``), as archetypes, each
    worked out when it is asked for."""
    for k in range(MAX_PLANS):
        found = room_plans(layout, ctx, k + 1)
        if len(found) <= k:
            return
        moved = plan_summary(layout, found[k])
        yield RuleArchetype(
            f"plan_{k + 1}", f"room plan {k + 1}",
            f"the furniture regrouped ({moved} moved, each group whole), doors clear and reachable, fixtures in place",
            _plan_place(found[k]),
        )  # fmt: skip


def _candidates(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    """Every rule pattern for ``layout``, preferred first; worked out once per layout of the unit
    (the archetype agent lists them, then each variant's node instantiates one)."""
    key = ("candidates", tuple((k, layout.center(k), layout.rotation(k)) for k in layout.ids))
    known = ctx.plan_cache.get(key)
    if known is None:
        known = ctx.plan_cache[key] = _all_candidates(layout, ctx)
    return list(known)


def _head(layout: UnitLayout, ctx: UnitContext) -> Iterator[RuleArchetype]:
    """What :func:`_candidates` begins with: the room plans of a room of a house (else nothing),
    each found when it is asked for."""
    if ctx.in_house:
        yield from _plans(layout, ctx)


def _in_order(layout: UnitLayout, ctx: UnitContext) -> Iterator[RuleArchetype]:
    """:func:`_candidates` one by one, worked out as they are asked for: each room plan, then the
    rest (a caller that stops once the plans are enough finds no more of them)."""
    count = 0
    for cand in _head(layout, ctx):
        count += 1
        yield cand
    yield from _candidates(layout, ctx)[count:]


def _all_candidates(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    kind = ctx.unit.anchor_kind
    out: list[RuleArchetype] = list(_head(layout, ctx))
    seated: list[RuleArchetype] = []
    if kind == "floor":
        for table in sorted(set(ctx.seat_table.values())):
            seats = sorted(s for s, t in ctx.seat_table.items() if t == table)
            if seat_slots(layout, ctx, table, seats):
                seated.append(RuleArchetype(f"seated_{table}"[:40], f"seats spread around the {layout.object(table).category}", f"the seats of ({table}) spread evenly along its sides, long sides first, each facing it", _seated(table)))
    scattered = any(
        layout.outline(s).distance(layout.outline(t)) > SEAT_GAP_MAX for s, t in ctx.seat_table.items()
    )
    if scattered:  # the seats stand away from their table: gathering them is the first alternative
        out += seated
    if kind in ("floor", "ceiling") or (kind == "object" and not ctx.frozen_rotation):
        out.append(RuleArchetype("rotated_180", "arrangement turned half a turn", "every piece moves to the opposite side of the surface and faces the other way, so the functional zones trade places", _rotated))
    out.append(RuleArchetype("mirrored_lr", "mirror image left to right", "the arrangement mirrored about the surface's vertical centre line: what stood on the left now stands on the right", _mirror_lr))
    if kind != "wall":
        out.append(RuleArchetype("mirrored_ud", "mirror image top to bottom", "the arrangement mirrored about the surface's horizontal centre line", _mirror_ud))
    if kind == "floor":
        pieces = sorted(ctx.against_wall - set(ctx.nightstand_bed))
        seen: set[frozenset[str]] = set()
        for i, a in enumerate(pieces):
            for b in pieces[i + 1 :]:
                ca, cb = layout.object(a).category, layout.object(b).category
                if ca == cb or frozenset((ca, cb)) in seen:
                    continue
                seen.add(frozenset((ca, cb)))
                out.append(RuleArchetype(f"swapped_{a}_{b}"[:40], f"{ca} and {cb} trade places", f"the {ca} ({a}) and the {cb} ({b}) swap their places along the walls, each with its group", _swap(a, b)))
        if not scattered:
            out += seated
        out += _relocations(layout, ctx)
        out += _displacements(layout, ctx)
        out += _double_displacements(layout, ctx)
        for table in sorted(set(ctx.seat_table.values())):
            if table not in ctx.against_wall:
                cat = layout.object(table).category
                out.append(RuleArchetype(f"centred_{table}"[:40], f"{cat} group in the middle", f"the table ({table}) and its seats moved to the middle of the room, the rest kept", _centred(table)))
                out += _slides(layout, ctx, table, scattered)
            out.append(RuleArchetype(f"turned_{table}"[:40], f"{layout.object(table).category} group turned a quarter", f"the table ({table}) and its seats turned a quarter turn in place, so the group runs the other way", _turn(table)))
        # last: a whole-room pattern and a group pattern together (small rooms need them for m variants)
        whole = [c for c in out if c.layout_id in ("rotated_180", "mirrored_lr", "mirrored_ud")]
        groups = [c for c in out if c.layout_id.split("_", 1)[0] in ("seated", "centred", "turned", "moved", "slid")]
        for w in whole:
            for g in groups:
                out.append(
                    RuleArchetype(
                        f"{w.layout_id}_{g.layout_id}"[:40], f"{w.style_name}, {g.style_name}",
                        f"{w.reasoning}; then {g.reasoning}", _then(w.place, g.place),
                    )
                )
    return out


def _then(
    first: Callable[[UnitLayout, UnitContext], Placement], second: Callable[[UnitLayout, UnitContext], Placement]
) -> Callable[[UnitLayout, UnitContext], Placement]:
    """``second`` applied to the layout ``first`` makes."""

    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        trial = layout.copy()
        for k, (u, v, r) in first(layout, ctx).items():
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        return second(trial, ctx)

    return place


def _same(a: Placement, b: Placement, layout: UnitLayout) -> bool:
    """True when every object of ``b`` lands near an object of the same category in ``a``."""
    for k, (u, v, r) in b.items():
        cat = layout.object(k).category
        if not any(
            layout.object(j).category == cat and math.dist((u, v), (ju, jv)) <= SAME_PLACE_M and abs(normalize_degrees(r - jr)) <= SAME_TURN_DEG
            for j, (ju, jv, jr) in a.items()
        ):
            return False
    return True


def _pinned(placed: Placement, ctx: UnitContext, layout: UnitLayout | None = None) -> Placement:
    """Objects a cross-unit clause ties down keep their place in every arrangement; on a floor,
    so do its fixtures (``evolve/_plans.fixed_children``) when ``layout`` is given."""
    out = dict(placed)
    for k, (_, (u, v), r) in ctx.pinned.items():
        if k in out:
            out[k] = (u, v, r)
    if layout is not None and ctx.floor:
        for k in fixed_children(layout, ctx):
            if k in out:
                out[k] = (*layout.center(k), layout.rotation(k))
    return out


TV_TURN_MAX = 45.0
"""A screen on a stand or cabinet is never turned further than this, degrees, from the way it faces
in the base (a TV turned to the wall behind it is no arrangement)."""
SWAP_FIT_M = 0.05
"""A swap is offered only when every piece of both groups lands inside the room within this..."""
SWAP_OVERLAP_M2 = 0.01
"""... and overlaps no other solid object it was clear of by more than this area, square metres
(the loop fixes touches, not a wardrobe standing in a bed; a chair tucked under its desk stays)."""


def _fits(layout: UnitLayout, ctx: UnitContext, placed: Placement, moved: set[str]) -> bool:
    """Whether the ``moved`` objects, placed as ``placed`` says, stay on the surface (within
    ``SWAP_FIT_M``) and clear of the other solid objects (within ``SWAP_OVERLAP_M2``)."""
    region = Polygon(ctx.surface.region).buffer(SWAP_FIT_M, join_style="mitre")
    trial = layout.copy()
    for k in moved:
        u, v, r = placed[k]
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
        if not region.covers(trial.outline(k)):
            return False
    solid = [k for k in trial.ids if k not in ctx.thin]
    polys = {k: trial.outline(k) for k in solid}
    before = {k: layout.outline(k) for k in solid}
    for k in sorted(moved - ctx.thin):
        for j in solid:
            if j == k or (j in moved and j < k) or _stacked(trial, k, j):
                continue
            if polys[k].intersection(polys[j]).area > SWAP_OVERLAP_M2 >= before[k].intersection(before[j]).area:
                return False
    return True


def _stacked(layout: UnitLayout, a: str, b: str) -> bool:
    """Whether ``a`` and ``b`` are at different heights (a chair tucked under a table top)."""
    alo, ahi = layout.span(a)
    blo, bhi = layout.span(b)
    return alo >= bhi - 1e-3 or blo >= ahi - 1e-3


def _seated_all(layout: UnitLayout, ctx: UnitContext, placed: Placement) -> Placement:
    """``placed`` with every table's seats in their etiquette slots (where the loop will put
    them), so two placements that differ only in how the seats stand compare as one."""
    trial = layout.copy()
    for k, (u, v, r) in placed.items():
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    out = dict(placed)
    tables: dict[str, list[str]] = {}
    for seat, table in ctx.seat_table.items():
        tables.setdefault(table, []).append(seat)
    for table, seats in sorted(tables.items()):
        for k, sl in seat_slots(trial, ctx, table, seats).items():
            out[k] = (sl.u, sl.v, sl.rotation)
    return out


def _blocks_use(layout: UnitLayout, ctx: UnitContext, placed: Placement) -> bool:
    """Whether a placement puts a piece in the way of a drawer, door or lid the stabilized scene lets
    open (:func:`~scenemosaic.evolve.parts_in_the_way`), furniture before a window the stabilized
    scene keeps clear (:func:`~scenemosaic.evolve.windows_in_the_way`), or a bed or sofa with its
    back to a screen (:func:`~scenemosaic.evolve.screens_put_behind`)."""
    trial = layout.copy()
    for k, (u, v, r) in placed.items():
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    return bool(parts_in_the_way(trial, ctx, floor=True) or windows_in_the_way(trial, ctx) or screens_put_behind(trial, ctx))


def _plausible(layout: UnitLayout, ctx: UnitContext, placed: Placement) -> bool:
    """Whether the loop can make a placement right, judged before it runs: wall pieces that
    faced each other (a sofa and its TV) still do (the loop does not carry wall pieces across
    the room), a screen on a stand or cabinet keeps facing the way its stand does (``TV_TURN_MAX``), and
    every table's seats have an even slot plan where the table now stands."""
    trial = layout.copy()
    for k, (u, v, r) in placed.items():
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    if ctx.unit.anchor_kind == "object":
        for k in trial.ids:
            if is_screen(layout.object(k).category) and abs(normalize_degrees(trial.rotation(k) - layout.rotation(k))) > TV_TURN_MAX:
                return False
    for piece, target in sorted(ctx.keep_facing):
        if piece in ctx.against_wall and piece in trial.ids and target in trial.ids and not layout_faces(trial, piece, target):
            return False
    tables: dict[str, list[str]] = {}
    for seat, table in ctx.seat_table.items():
        tables.setdefault(table, []).append(seat)
    for table, seats in sorted(tables.items()):
        plan = seat_slots(trial, ctx, table, seats)
        if not plan:
            continue
        seated = trial.copy()
        for k, sl in plan.items():
            seated.set_rotation(k, sl.rotation)
            seated.set_center(k, sl.u, sl.v)
        if seating_breaches(seated, ctx, table, seats):
            return False
    return True


FOOTPRINT_GRID = 32
"""Cells along the surface's longer side of the footprint raster that :func:`rule_archetypes`
compares arrangements on when it must choose among more than it may offer."""


def _footprint(layout: UnitLayout, ctx: UnitContext, placed: Placement, raster: FloorRaster) -> np.ndarray:
    """The cells the solid objects of ``placed`` cover, seen from above."""
    trial = layout.copy()
    for k, (u, v, r) in placed.items():
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    mask: np.ndarray = raster.blocked([trial.polygon(k) for k in trial.ids if k not in ctx.thin])
    return mask


def _spread(layout: UnitLayout, ctx: UnitContext, kept: list[tuple[RuleArchetype, Placement]], limit: int) -> list[RuleArchetype]:
    """``limit`` of the ``kept`` arrangements, each the one whose footprint overlaps least (the
    largest smallest ``1 - IoU``) with the original's and those already chosen; ties go to the
    earlier (preferred) one. Asked for fewer alternatives than there are, the agent offers
    arrangements that differ in where things stand, not five beds on one wall."""
    region = np.asarray(ctx.surface.region, dtype=np.float64)
    raster = FloorRaster(region, float(max(np.ptp(region, axis=0))) / FOOTPRINT_GRID)
    maps = [_footprint(layout, ctx, p, raster) for _, p in kept]
    chosen_maps = [_footprint(layout, ctx, _current(layout), raster)]
    left = list(range(len(kept)))
    out: list[RuleArchetype] = []

    while left and len(out) < limit:
        best = max(left, key=lambda i: (min(1.0 - mask_iou(maps[i], m) for m in chosen_maps), -i))
        left.remove(best)
        out.append(kept[best][0])
        chosen_maps.append(maps[best])
    return out


def rule_archetypes(layout: UnitLayout, ctx: UnitContext, limit: int | None = None) -> list[RuleArchetype]:
    """The offline archetypes that differ from the original and from each other, preferred first;
    with ``limit`` and more of them than that, the ``limit`` that differ most in footprint
    (:func:`_spread`), in the order chosen.

    A swap whose groups do not fit where they go (a bed and its nightstands on a wall too short
    for them) is not offered, nor a placement the loop could not make right (:func:`_plausible`)."""
    base = _current(layout)
    seen = [_seated_all(layout, ctx, base)]
    kept: list[tuple[RuleArchetype, Placement]] = []
    plans_kept = 0
    for cand in _in_order(layout, ctx):
        if limit is not None and plans_kept >= limit:
            break  # the room plans come first and fill the limit: what follows would not be offered
        plan = cand.layout_id.startswith("plan_")
        placed = _pinned(cand.place(layout, ctx), ctx, layout)
        if cand.layout_id.startswith("swapped_"):
            moved = {k for k in placed if math.dist(placed[k][:2], base[k][:2]) > 1e-6}
            if not _fits(layout, ctx, placed, moved):
                continue
        looks = _seated_all(layout, ctx, placed)  # compared as the loop will seat them
        if any(_same(p, looks, layout) for p in seen):
            continue
        seen.append(looks)
        if (
            not _plausible(layout, ctx, placed)
            or not doors_kept(layout, ctx, placed)
        ):
            continue
        if _blocks_use(layout, ctx, looks):  # the seats as the loop will seat them: a chair may stand before a window
            continue
        kept.append((cand, placed))
        plans_kept += plan
    plans = [c for c, _ in kept if c.layout_id.startswith("plan_")]
    if plans:  # a room of a house: its plans first, then the patterns that differ most
        rest = [(c, p) for c, p in kept if not c.layout_id.startswith("plan_")]
        if limit is None:
            return plans + [c for c, _ in rest]
        return plans[:limit] + (
            _spread(layout, ctx, rest, limit - len(plans)) if len(plans) < limit and rest else []
        )
    if limit is not None and len(kept) > limit:
        return _spread(layout, ctx, kept, limit)
    return [c for c, _ in kept]


_KEYWORDS = (
    (("rotat", "half turn", "180", "opposite"), "rotated_180"),
    (("mirror", "flip", "left", "right"), "mirrored_lr"),
    (("top", "bottom", "upside"), "mirrored_ud"),
    (("swap", "trade", "exchange"), "swapped"),
    (("turn", "quarter", "90"), "turned"),
)


def instantiate(layout: UnitLayout, ctx: UnitContext, archetype: object) -> tuple[Placement, str]:
    """Rule placement of an archetype (one of ours by id, or a model's, matched by its words).

    Returns the placement and a sentence saying which pattern was used.
    """
    layout_id = str(getattr(archetype, "layout_id", ""))
    words = f"{layout_id} {getattr(archetype, 'layout_style_name', '')}".lower()
    chosen = next((c for c in _head(layout, ctx) if c.layout_id == layout_id), None)  # a room plan: nothing more to work out
    if chosen is not None:
        return _pinned(chosen.place(layout, ctx), ctx, layout), _clip(f"rule pattern {chosen.layout_id}: {chosen.reasoning}", 300)
    cands = _candidates(layout, ctx)
    by_id = {c.layout_id: c for c in cands}
    chosen = by_id.get(layout_id)
    if chosen is None:
        for keys, prefix in _KEYWORDS:
            if any(k in words for k in keys):
                chosen = next((c for c in cands if c.layout_id.startswith(prefix)), None)
                if chosen is not None:
                    break
    if chosen is None:
        chosen = cands[0]
        return _pinned(chosen.place(layout, ctx), ctx, layout), _clip(f"no rule pattern matches {layout_id!r}; used {chosen.layout_id}", 300)
    return _pinned(chosen.place(layout, ctx), ctx, layout), _clip(f"rule pattern {chosen.layout_id}: {chosen.reasoning}", 300)

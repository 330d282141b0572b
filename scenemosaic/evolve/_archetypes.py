"""Rule archetypes: structurally different arrangements of a unit, and how to instantiate them.

The offline archetype agent proposes, in this order of preference, the ones that differ from
the original (an arrangement whose every object lands within 0.3 m and 20° of an object of
the same category in the original is the same arrangement, and is skipped):

* ``rotated_180`` — the whole arrangement turned half a turn about the surface centre (floor,
  ceiling and object tops);
* ``mirrored_lr`` / ``mirrored_ud`` — mirrored about the surface's vertical / horizontal centre
  line (walls and containers: centres only, so pictures stay upright and books keep their spines);
* ``swapped_<a>_<b>`` — two wall pieces of different kinds trade places along the walls, each
  taking its functional group (a bed its nightstands) along;
* ``seated_<table>`` — the seats of a table spread evenly along its sides, long sides first;
* ``centred_<table>`` — a free-standing table and its seats moved to the middle of the room;
* ``turned_<table>`` — a table and its seats turned a quarter turn about the table.

The Critic-Actor loop then makes each instantiation valid (walls, facing, collisions, bounds).
How many are offered follows the method: at most 1 for 1-5 objects, 2 for 6-10, 3 above.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from scenemosaic.evolve._analysis import SEAT_GAP_MAX, table_slots
from scenemosaic.evolve._context import UnitContext
from scenemosaic.scene import UnitLayout, normalize_degrees

__all__ = ["RuleArchetype", "instantiate", "max_alternatives", "rule_archetypes"]

Placement = dict[str, tuple[float, float, float]]
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


def _move_group(place: Placement, layout: UnitLayout, members: list[str], pivot: np.ndarray, to: np.ndarray, turn: float) -> None:
    """Turn ``members`` by ``turn`` degrees (clockwise in the view, like rotations) about ``pivot``
    and carry the pivot to ``to``."""
    a = math.radians(-turn)  # a clockwise in-plane turn is a negative angle in (u, v)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    for k in members:
        c = np.asarray(layout.center(k)) - pivot
        p = to + rot @ c
        place[k] = (float(p[0]), float(p[1]), normalize_degrees(layout.rotation(k) + turn))


def _swap(a: str, b: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        ca, cb = np.asarray(layout.center(a)), np.asarray(layout.center(b))
        ra, rb = layout.rotation(a), layout.rotation(b)
        _move_group(out, layout, _group(ctx, a), ca, cb, normalize_degrees(rb - ra))
        _move_group(out, layout, _group(ctx, b), cb, ca, normalize_degrees(ra - rb))
        return out

    return place


def _turn(table: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        c = np.asarray(layout.center(table))
        _move_group(out, layout, _group(ctx, table), c, c, 90.0)
        return out

    return place


def _centred(table: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        c = np.asarray(layout.center(table))
        middle = np.asarray(Polygon(ctx.surface.region).centroid.coords[0])
        _move_group(out, layout, _group(ctx, table), c, middle, 0.0)
        return out

    return place


def _seated(table: str) -> Callable[[UnitLayout, UnitContext], Placement]:
    def place(layout: UnitLayout, ctx: UnitContext) -> Placement:
        out = _current(layout)
        seats = sorted(s for s, t in ctx.seat_table.items() if t == table)
        slots = table_slots(layout, table, seats)
        free = list(slots)
        for s in seats:  # nearest free place first, seat by seat (deterministic order)
            if not free:
                break
            here = layout.center(s)
            best = min(free, key=lambda p: (math.dist(p[:2], here), p))
            free.remove(best)
            out[s] = best
        return out

    return place


def _candidates(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    kind = ctx.unit.anchor_kind
    out: list[RuleArchetype] = []
    seated: list[RuleArchetype] = []
    if kind == "floor":
        for table in sorted(set(ctx.seat_table.values())):
            seats = sorted(s for s, t in ctx.seat_table.items() if t == table)
            if table_slots(layout, table, seats):
                seated.append(RuleArchetype(f"seated_{table}"[:40], f"seats spread around the {layout.object(table).category}", f"the seats of ({table}) spread evenly along its sides, long sides first, each facing it", _seated(table)))
    scattered = any(
        Polygon(layout.polygon(s)).distance(Polygon(layout.polygon(t))) > SEAT_GAP_MAX for s, t in ctx.seat_table.items()
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
        for table in sorted(set(ctx.seat_table.values())):
            if table not in ctx.against_wall:
                out.append(RuleArchetype(f"centred_{table}"[:40], f"{layout.object(table).category} group in the middle", f"the table ({table}) and its seats moved to the middle of the room, the rest kept", _centred(table)))
            out.append(RuleArchetype(f"turned_{table}"[:40], f"{layout.object(table).category} group turned a quarter", f"the table ({table}) and its seats turned a quarter turn in place, so the group runs the other way", _turn(table)))
        # last: a whole-room pattern and a group pattern together (small rooms need them for m variants)
        whole = [c for c in out if c.layout_id in ("rotated_180", "mirrored_lr", "mirrored_ud")]
        groups = [c for c in out if c.layout_id.split("_", 1)[0] in ("seated", "centred", "turned")]
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


def _pinned(placed: Placement, ctx: UnitContext) -> Placement:
    """Objects a cross-unit clause ties down keep their place in every arrangement."""
    out = dict(placed)
    for k, (_, (u, v), r) in ctx.pinned.items():
        if k in out:
            out[k] = (u, v, r)
    return out


SWAP_FIT_M = 0.05
"""A swap is offered only when every piece of both groups lands inside the room within this."""


def _fits(layout: UnitLayout, ctx: UnitContext, placed: Placement, moved: set[str]) -> bool:
    """Whether the ``moved`` objects, placed as ``placed`` says, stay on the surface (within ``SWAP_FIT_M``)."""
    region = Polygon(ctx.surface.region).buffer(SWAP_FIT_M, join_style="mitre")
    trial = layout.copy()
    for k in moved:
        u, v, r = placed[k]
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
        if not region.covers(Polygon(trial.polygon(k))):
            return False
    return True


def rule_archetypes(layout: UnitLayout, ctx: UnitContext) -> list[RuleArchetype]:
    """The offline archetypes that differ from the original and from each other, preferred first.

    A swap whose groups do not fit where they go (a bed and its nightstands on a wall too short
    for them) is not offered: the loop could not make it valid."""
    base = _current(layout)
    kept: list[tuple[RuleArchetype, Placement]] = []
    for cand in _candidates(layout, ctx):
        placed = _pinned(cand.place(layout, ctx), ctx)
        if cand.layout_id.startswith("swapped_"):
            moved = {k for k in placed if math.dist(placed[k][:2], base[k][:2]) > 1e-6}
            if not _fits(layout, ctx, placed, moved):
                continue
        if _same(base, placed, layout) or any(_same(p, placed, layout) for _, p in kept):
            continue
        kept.append((cand, placed))
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
        return _pinned(chosen.place(layout, ctx), ctx), f"no rule pattern matches {layout_id!r}; used {chosen.layout_id}"
    return _pinned(chosen.place(layout, ctx), ctx), f"rule pattern {chosen.layout_id}: {chosen.reasoning}"

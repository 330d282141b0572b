"""Room plans: whole rearrangements of a room's floor that are valid for the house by construction.

A floor unit of a room with doors (every room of a house) gets, before the other archetypes,
up to :data:`MAX_PLANS` **room plans**. A plan moves the room's furniture the way a designer
redraws a room, group by group, and is searched for with the house's constraints in it, not
repaired after:

* **Groups move whole.** The children are joined into functional groups (a seat and its table
  or desk, a nightstand and its bed, a sofa, its coffee table and the TV stand it faces, a rug
  and what stands on it); a group moves as one rigid body, turned and carried, or mirrored
  across its main piece's axis, so every relation inside it holds wherever it goes. Pieces of
  other units that hang over a group (a wall TV over its stand, a picture over a bed) follow it
  in composition (``scene.follow_leaders``), onto the new wall when the group changes wall.
* **Fixtures stay.** Built-in categories (``scene.is_fixture``: counters, sinks, fridges,
  stoves, toilets, bathtubs, showers, ...) and pieces a cross-unit clause ties down never move;
  the table is documented in ``docs/evolution.md``.
* **Valid by construction.** A group with a piece that belongs against a wall (the TV stand,
  the bed, the desk, else the largest) is backed flush against a wall, every
  :data:`PLAN_STEP_M` along it; a free group (a dining table and its chairs) is tried on a grid
  over the floor, turned by quarter turns. A place is kept only when every member lies on the
  floor clear of the fixed pieces, of the other units' low pieces, of the **door zones**
  (``scene.door_zones``) and of the groups already placed (by :data:`PLAN_MARGIN_M`), with the
  strip in front of its main piece free. The finished plan must leave the floor's walkable
  part as connected as the base's and every door reachable from it (the robot radius and the
  door test of ``scene.cut_off_doors``).
* **Different from each other.** Groups are placed most constrained first (fewest valid places); each takes, among its valid
  places, the one farthest from where it stood in the base and in the plans made before (a
  seeded jitter breaks near ties), so successive plans spread the furniture over the walls.
  A plan in which no group of furniture (the largest, or any with :data:`PLAN_MIN_AREA_M2` of
  footprint) moved at least :data:`PLAN_MIN_MOVE_M` (or turned) is no plan.
* **A full room still varies.** When the search finds no whole regrouping (a dining room of ten
  chairs, a buffet, a sideboard and two bookcases), the groups of furniture are moved one by one
  instead, largest first, each to its best place clear of the others where they stand now and
  with nothing that rises above a window's sill before a window the base keeps clear
  (``scene.blocked_windows``), the rest staying put.

Plans are deterministic for a given layout and context (seeded by :data:`PLAN_SEED`) and cached
on the unit's context, so the archetype agent and the instantiation compute them once.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np
from shapely import prepare
from shapely.affinity import rotate, translate
from shapely.geometry import LineString, MultiPoint, Point, Polygon
from shapely.ops import unary_union

from scenemosaic._memo import Memo
from scenemosaic.evolve._context import UnitContext, WallLine
from scenemosaic.scene import (
    ROBOT_RADIUS,
    WALK_MAX_HEIGHT,
    WALK_MIN_SHARE,
    WINDOW_REACH_M,
    FloorRaster,
    UnitLayout,
    is_bed,
    is_fixture,
    is_screen,
    kept_floor_share,
    normalize_degrees,
    points_at,
)

__all__ = [
    "MAX_PLANS", "PLAN_MARGIN_M", "PLAN_MIN_MOVE_M", "PLAN_STEP_M", "Placement", "doors_kept", "fixed_children", "flush_positions", "move_group", "plan_summary", "room_plans", "walk_check",
]  # fmt: skip

Placement = dict[str, tuple[float, float, float]]

MAX_PLANS = 8
"""Most room plans one floor unit gets."""
PLAN_STEP_M = 0.2
"""Spacing, metres, of the places tried along a wall (and of the grid a free group is tried on)."""
PLAN_MARGIN_M = 0.08
"""A placed group keeps at least this far, metres, from everything it does not bring along."""
PLAN_MIN_MOVE_M = 0.8
"""A plan must carry its largest group, or another group of furniture (``PLAN_MIN_AREA_M2``), at
least this far, metres (or turn it by 45 degrees or more)."""
PLAN_MIN_AREA_M2 = 0.5
"""A group with this much solid footprint (square metres) counts as furniture for that rule."""
PLAN_FRONT_M = 0.6
"""Depth, metres, of the strip kept free in front of a group's main piece."""
PLAN_PUSH_M = 3.0
"""How far, metres, a group's second wall piece (a sofa across from its TV stand) may be pushed
straight back to stand flush against the wall behind it."""
BACK_FACING_DEG = 20.0
"""A wall is behind a piece when its inward normal is within this many degrees of the piece's front."""
PLAN_TRIES = 16
"""Seeded attempts at each plan before the planner gives up on more plans."""
PLAN_SEED = 1729
"""Seed of the plans' jitter (plans are the same for the same room on every run)."""
PLAN_CELL_M = 0.05
"""Cell of the raster the walkable check of a finished plan runs on, metres."""
PLAN_BRANCH = 4
"""Places of one group the plan search tries before it gives up on the group before it."""
PLAN_EXPANSIONS = 400
"""Places the plan search tries in all for one plan."""
PLAN_REPEATS = 4
"""Plans that repeat an earlier one (:func:`_same_plan`) after which a room's search stops."""
RIDER_REACH_M = 0.03
"""How far past the floor's edge what rests on a piece may reach, metres (:class:`_Planner`)."""
_JITTER_M = 0.6
_LEADS = ("tv_stand", "bed", "desk")


def move_group(
    place: Placement, layout: UnitLayout, members: list[str], pivot: np.ndarray, to: np.ndarray, turn: float
) -> None:
    """Turn ``members`` by ``turn`` degrees (clockwise in the view, like rotations) about ``pivot``
    and carry the pivot to ``to``, writing their new (u, v, rotation) into ``place``."""
    a = math.radians(-turn)  # a clockwise in-plane turn is a negative angle in (u, v)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    for k in members:
        c = np.asarray(layout.center(k)) - pivot
        p = to + rot @ c
        place[k] = (float(p[0]), float(p[1]), normalize_degrees(layout.rotation(k) + turn))


def _turned(vector: np.ndarray, turn: float) -> np.ndarray:
    """``vector`` (u, v) turned by ``turn`` degrees clockwise in the view (like rotations)."""
    a = math.radians(-turn)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]) @ np.asarray(vector, dtype=np.float64)


def _facing(rotation: float) -> np.ndarray:
    r = math.radians(rotation)
    return np.array([-math.sin(r), -math.cos(r)])


@dataclass
class _Group:
    lead: str
    members: list[str]
    on_wall: bool
    area: float


@dataclass
class _Option:
    place: Placement
    shapes: list[Polygon]
    """The solid members' outlines and the front strip: what later groups must stay clear of."""
    solid: list[Polygon]
    centre: np.ndarray
    turn: float
    stays: bool = False
    """The group where it stands in the base."""


def fixed_children(layout: UnitLayout, ctx: UnitContext) -> set[str]:
    """Children a variant never moves: fixtures by category (``scene.is_fixture``) and pieces a clause pins."""
    return {k for k in layout.ids if is_fixture(layout.object(k).category) or k in ctx.pinned}


def _groups(layout: UnitLayout, ctx: UnitContext, fixed: set[str], *, facing: bool = True) -> list[_Group]:
    """The unit's pieces joined into groups that move whole (module docstring); without
    ``facing`` the lounge pieces that only face each other (``ctx.keep_facing``) are not joined."""
    parent = {k: k for k in layout.ids}

    def find(k: str) -> str:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    def join(a: str, b: str) -> None:
        if a in parent and b in parent and a not in fixed and b not in fixed:
            parent[find(a)] = find(b)

    for a, b in [
        *ctx.seat_table.items(),
        *ctx.nightstand_bed.items(),
        *ctx.sofa_tv.items(),
        *(ctx.keep_facing if facing else ()),
    ]:
        join(a, b)
    solid = [k for k in layout.ids if k not in ctx.thin and k not in fixed]
    for rug in sorted(ctx.thin - fixed):  # a rug goes with what stands on it
        area = layout.outline(rug)
        on = [k for k in solid if area.contains(Point(layout.center(k)))]
        for k in on:
            join(rug, k)
    members: dict[str, list[str]] = {}
    for k in layout.ids:
        if k not in fixed:
            members.setdefault(find(k), []).append(k)
    out = []
    for ms in members.values():
        walls = [k for k in ms if k in ctx.against_wall]
        area = sum(layout.outline(k).area for k in ms if k not in ctx.thin)
        if walls:
            rank = {c: i for i, c in enumerate(_LEADS)}
            lead = min(
                walls,
                key=lambda k: (
                    _lead_rank(layout.object(k).category, rank),
                    -layout.outline(k).area,
                    k,
                ),
            )
        else:
            lead = max(
                (k for k in ms if k not in ctx.thin),
                key=lambda k: (layout.outline(k).area, k),
                default=ms[0],
            )
        out.append(_Group(lead, sorted(ms), bool(walls), area))
    return sorted(out, key=lambda g: (-g.area, g.lead))


def _seated(layout: UnitLayout, ctx: UnitContext) -> UnitLayout:
    """``layout`` with every table's seats in their etiquette slots where they all fit
    (``seat_slots``): a group moves with its seats where the loop will put them, not where the
    source or the settling left them (an armchair half a metre off its table's side would make
    the group too wide for every other place)."""
    from scenemosaic.evolve._analysis import seat_slots

    tables: dict[str, list[str]] = {}
    for seat, table in ctx.seat_table.items():
        if seat in layout.ids and table in layout.ids and seat not in ctx.pinned:
            tables.setdefault(table, []).append(seat)
    if not tables:
        return layout
    out = layout.copy()
    for table, seats in sorted(tables.items()):
        for k, slot in seat_slots(out, ctx, table, sorted(seats)).items():
            out.set_rotation(k, slot.rotation)
            out.set_center(k, slot.u, slot.v)
    return out


def _lead_rank(category: str, rank: dict[str, int]) -> int:
    for name, i in rank.items():
        if name in category:
            return i
    return len(rank)


_BOUNDS_SLACK = 1e-8
"""Metres past the region's bounds a piece's unrounded corners must reach before its outline (its
points rounded to 1e-9) surely leaves the region."""


class _Planner:
    """The static side of a room's plans: the region, what never moves, each group's valid places."""

    def __init__(self, layout: UnitLayout, ctx: UnitContext) -> None:
        self.source, self.ctx = layout, ctx
        self.layout = _seated(layout, ctx)
        layout = self.layout
        self.fixed = fixed_children(layout, ctx)
        self.groups = _groups(layout, ctx, self.fixed)
        from scenemosaic.evolve._analysis import WALL_FLUSH_GAP

        # inset by the flush gap less a millimetre: a piece backed flush against a wall is inside
        self.region = Polygon(ctx.surface.region).buffer(-(WALL_FLUSH_GAP - 0.001), join_style="mitre")
        prepare(self.region)
        self.region_bounds: tuple[float, float, float, float] = tuple(self.region.bounds)  # type: ignore[assignment]
        # what rests on a piece may reach a little past it, over the wall's skirting (a TV's back
        # flush with its stand's): checked against the floor grown by RIDER_REACH_M
        self.loose_region = Polygon(ctx.surface.region).buffer(RIDER_REACH_M, join_style="mitre")
        prepare(self.loose_region)
        fixed_polys = [layout.outline(k) for k in self.fixed if k not in ctx.thin]
        from scenemosaic.evolve._analysis import obstacle_polygons

        others = [(float(o.aabb()[0][2]), p) for o, p in obstacle_polygons(ctx) if p.area > 0]
        self.walk_obstacles = [p for z, p in others if z < WALK_MAX_HEIGHT]
        self.fixed_grown = [p.buffer(PLAN_MARGIN_M, join_style="mitre") for p in fixed_polys]
        self.fixed_solid = fixed_polys
        self.raster = FloorRaster(np.asarray(ctx.surface.region, dtype=np.float64), cell=PLAN_CELL_M)
        self.door_masks = [self.raster.mask(z.buffer(ROBOT_RADIUS)) for z in [*ctx.keep_clear, *ctx.passages]]
        self.need = WALK_MIN_SHARE
        self.nearest: dict[tuple[str, int], tuple[int, float]] = {}
        """Per group and option: how many places of the plans' history were measured, and the
        distance to the nearest of them (:func:`_farthest`)."""
        self.others = others
        self.static = self.solid_static = Polygon()
        self._turned: dict[tuple[tuple[str, float], ...], UnitLayout] = {}
        """Trial layouts of a few pieces turned as an option turns them, by ``(piece, rotation)``:
        the thousands of places tried for a group share a handful of turns (:meth:`_placed`)."""
        self._riders: dict[tuple[str, float], list[np.ndarray]] = {}
        """What rests on a piece, turned with it, about its centre, by ``(piece, rotation)``."""
        self.windows, self.tops = self._windows()
        self.options = {g.lead: self._options(g) for g in self.groups}
        self.facing: list[tuple[str, str]] = [
            (a, b)
            for a, b in sorted(ctx.keep_facing)
            if a in ctx.against_wall and a in layout.ids and b in layout.ids and (a in self.fixed) != (b in self.fixed)
        ]
        """Facing pairs a plan keeps facing: a wall piece that never moves and what it faces (a
        pinned TV stand and the armchair across from it), and pairs split across groups
        (:meth:`_split_stuck`)."""
        if self.facing:  # a group facing a piece that never moves keeps only the places that face it
            for g in self.groups:
                self.options[g.lead] = [o for o in self.options[g.lead] if self.facing_kept(o.place, set(g.members))]
        self._split_stuck(layout)

    def _moves(self, g: _Group, opt: _Option) -> bool:
        far = float(np.linalg.norm(opt.centre - np.asarray(self.layout.center(g.lead))))
        return far >= PLAN_MIN_MOVE_M or abs(normalize_degrees(opt.turn)) >= 45.0

    def _split_stuck(self, layout: UnitLayout) -> None:
        """A group that has no other place as a whole (a TV stand facing an armchair that sits
        at a table across a narrow room) is split where its pieces only face each other: the
        parts are placed apart, and a plan keeps the facing pieces facing (checked as it goes)."""
        stuck = [g for g in self.groups if len(g.members) > 1 and not any(self._moves(g, o) for o in self.options[g.lead])]
        if not stuck or not self.ctx.keep_facing:
            return
        loose = _groups(layout, self.ctx, self.fixed, facing=False)
        for g in stuck:
            parts = [h for h in loose if set(h.members) <= set(g.members)]
            if len(parts) < 2:
                continue
            part_of = {k: h.lead for h in parts for k in h.members}
            self.groups = [x for x in self.groups if x is not g] + parts
            del self.options[g.lead]
            for h in parts:
                self.options[h.lead] = self._options(h)
            self.facing += [(a, b) for a, b in sorted(self.ctx.keep_facing) if a in part_of and b in part_of and part_of[a] != part_of[b]]
        self.groups.sort(key=lambda x: (-x.area, x.lead))

    def facing_kept(self, place: Placement, done: set[str]) -> bool:
        """Whether every facing pair of :attr:`facing` whose two pieces are placed (in ``done``, or
        never moving) still faces."""
        placed = done | self.fixed
        pairs = [(a, b) for a, b in self.facing if a in placed and b in placed]
        if not pairs:
            return True
        from scenemosaic.evolve._analysis import layout_faces

        trial = self.layout.copy()
        for k in done:
            u, v, r = place[k]
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        return all(layout_faces(trial, a, b) for a, b in pairs)

    def _static_for(self, g: _Group) -> None:
        """What never moves and stands in ``g``'s way: the fixtures, the door zones and the other
        units' pieces that hang lower than the group's top (a picture above a sofa does not)."""
        top = max(self.layout.span(k)[1] for k in g.members)
        low = [p.buffer(PLAN_MARGIN_M, join_style="mitre") for z, p in self.others if z < top]
        parts = [*self.fixed_grown, *low]
        self.solid_static = unary_union(parts) if parts else Polygon()
        prepare(self.solid_static)
        parts += self.ctx.keep_clear
        self.static = unary_union(parts) if parts else Polygon()
        prepare(self.static)

    def _turned_trial(self, place: Placement) -> UnitLayout:
        """A layout of the pieces of ``place`` turned to their rotations there (worked out once per
        set of rotations: a turn costs a matrix product and the projected corners); the caller
        sets their centres. Kept and reused: good until the next call."""
        key = tuple((k, r) for k, (_, _, r) in place.items())
        trial = self._turned.get(key)
        if trial is None:
            trial = self._turned[key] = self.layout.copy(only=set(place))
            for k, (_, _, r) in place.items():
                trial.set_rotation(k, r)
        return trial

    def _placed(self, g: _Group, place: Placement) -> tuple[list[Polygon], list[Polygon]] | None:
        trial = self._turned_trial(place)
        for k, (u, v, _) in place.items():
            trial.set_center(k, u, v)
        x0, y0, x1, y1 = self.region_bounds
        for k in g.members:  # a piece reaching past the region's bounds is not covered by it: no outline needed
            u0, v0, u1, v1 = trial.reach(k)
            if u0 < x0 - _BOUNDS_SLACK or v0 < y0 - _BOUNDS_SLACK or u1 > x1 + _BOUNDS_SLACK or v1 > y1 + _BOUNDS_SLACK:
                return None
        solid = []
        for k in g.members:
            own = trial.outline(k)
            shape = self._with_riders(k, trial) if self.ctx.riders.get(k) else own
            if not self.region.covers(own) or not self.loose_region.covers(shape):
                return None
            if k not in self.ctx.thin:
                if self.static.intersects(shape):
                    return None
                solid.append(shape)
        lu, lv, lr = place[g.lead]
        extra = []
        if g.lead not in self.ctx.thin and (g.lead in self.ctx.with_front):
            from scenemosaic.evolve._analysis import front_strip

            strip = front_strip(trial.polygon(g.lead), np.array([lu, lv]), lr, PLAN_FRONT_M)
            # the floor in front of a piece may be a door's way in (both stay free); not a fixture
            if not self.region.covers(strip) or self.solid_static.intersects(strip):
                return None
            extra.append(strip)
        return solid, [*solid, *extra]

    def _with_riders(self, k: str, trial: UnitLayout) -> Polygon:
        """``k``'s outline where ``trial`` puts it, with what rests on it carried along (the
        convex hull of both: a TV wider than its stand reaches past the stand's ends)."""
        riders = self.ctx.riders.get(k)
        if not riders:
            return trial.outline(k)
        c1, r1 = np.asarray(trial.center(k)), trial.rotation(k)
        turned = self._riders.get((k, r1))
        if turned is None:
            c0, r0 = np.asarray(self.source.center(k)), self.source.rotation(k)
            a = math.radians(-(r1 - r0))
            rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
            turned = self._riders[(k, r1)] = [(np.asarray(p)[:, :2] - c0) @ rot.T for p in riders]
        pts = [np.asarray(trial.polygon(k))] + [c1 + t for t in turned]
        return MultiPoint(np.vstack(pts)).convex_hull

    def _option(
        self, g: _Group, pivot: np.ndarray, to: np.ndarray, turn: float, mirror: bool, wall: WallLine | None = None
    ) -> _Option | None:
        layout = self.layout
        place: Placement = {}
        if mirror:  # the group mirrored across its main piece's front axis
            f = _facing(layout.rotation(g.lead))
            side = np.array([f[1], -f[0]])
            mirrored = layout.copy()
            for k in g.members:
                c = np.asarray(layout.center(k)) - pivot
                c = c - 2 * float(c @ side) * side
                fk = _facing(layout.rotation(k))
                fk = fk - 2 * float(fk @ side) * side
                rot = math.degrees(math.atan2(-fk[0], -fk[1]))
                mirrored.set_rotation(k, rot)
                mirrored.set_center(k, *(pivot + c))
            move_group(place, mirrored, g.members, pivot, to, turn)
        else:
            move_group(place, layout, g.members, pivot, to, turn)
        if not self._backed(g, place) or not self._faces_kept(g, place):
            return None
        found = self._placed(g, place)
        if found is None or not self._followers_fit(g, place, turn, wall):
            return None
        return _Option(place, found[1], found[0], to, turn)

    def _windows(self) -> tuple[list[tuple[LineString, float]], dict[str, float]]:
        """The windows a plan keeps clear (those the base keeps clear: ``ctx.windows_blocked``
        names the others), each as its stretch of wall in the unit's plane and its sill height;
        and how high each piece of the unit rises with what it carries."""
        scene = self.ctx.scene
        if scene is None or scene.room is None:
            return [], {}
        out = []
        for wall in scene.room.walls:
            start, direction = np.asarray(wall.start, dtype=np.float64), np.asarray(wall.direction, dtype=np.float64)
            for k, op in enumerate(wall.openings):
                if op.kind != "window" or f"{wall.id}/window_{k}" in self.ctx.windows_blocked:
                    continue
                lo, hi = wall.span(op)
                ends = np.array([[*(start + direction * lo)[:2], 0.0], [*(start + direction * hi)[:2], 0.0]])
                out.append((LineString(self.ctx.surface.project(ends)), float(op.bottom)))
        tops: dict[str, float] = {}
        if out:
            for o in scene.objects:
                root = scene.floor_root(o.id)
                if root is not None:
                    tops[root] = max(tops.get(root, 0.0), float(o.aabb()[1][2]))
        return out, tops

    def _before_window(self, g: _Group, place: Placement) -> bool:
        """Whether a piece of ``g`` placed as ``place`` says, or what it carries, rises above a
        window's sill within ``WINDOW_REACH_M`` of its stretch of wall (``scene.blocked_windows``,
        the definition the scene's checks use): a bookcase or a wardrobe is never put before a
        window the base keeps clear."""
        if not self.windows:
            return False
        layout = self.layout
        for k in g.members:
            top = self.tops.get(k, 0.0)
            near = [line for line, sill in self.windows if top > sill + 1e-3]
            if not near or k not in place:
                continue
            u, v, r = place[k]
            cu, cv = layout.center(k)
            outline = translate(rotate(layout.outline(k), -(r - layout.rotation(k)), origin=(cu, cv)), u - cu, v - cv)
            if any(outline.distance(line) <= WINDOW_REACH_M for line in near):
                return True
        return False

    def _wall_behind(self, outline: np.ndarray, rotation: float, reach: float) -> tuple[WallLine, float] | None:
        """The wall a piece facing ``rotation`` has behind it (its inward normal within
        ``BACK_FACING_DEG`` of the piece's front, the piece's span mostly in front of it) and how
        far the piece must move back to stand flush against it; the nearest within ``reach``."""
        from scenemosaic.evolve._analysis import WALL_FLUSH_GAP

        f = _facing(rotation)
        found = []
        for w in self.ctx.walls:
            if float(np.asarray(w.inward) @ f) < math.cos(math.radians(BACK_FACING_DEG)) or w.overlap(outline) < 0.5:
                continue
            back = w.gap(outline) - WALL_FLUSH_GAP
            if -0.01 <= back <= reach:
                found.append((back, w.id, w))
        if not found:
            return None
        back, _, w = min(found, key=lambda x: (x[0], x[1]))
        return w, max(back, 0.0)

    def _backed(self, g: _Group, place: Placement) -> bool:
        """Push every piece of ``g`` that belongs against a wall, other than its main piece (a sofa
        facing the TV stand that was backed onto the new wall), straight back along its own axis
        until it stands flush against the wall behind it, so it keeps facing what it faced; a
        group with such a piece and no wall behind it within :data:`PLAN_PUSH_M` is no option
        (the loop would turn it to a wall). Nightstands and seats at tables go with their bed
        or table as they are."""
        trial = None
        for k in g.members:
            if k == g.lead or k not in self.ctx.against_wall or k in self.ctx.nightstand_bed or k in self.ctx.seat_table:
                continue
            if trial is None:
                trial = self.layout.copy()
            u, v, r = place[k]
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
            behind = self._wall_behind(trial.polygon(k), r, PLAN_PUSH_M)
            if behind is None:
                return False
            _, back = behind
            c = np.array([u, v]) - _facing(r) * back
            place[k] = (float(c[0]), float(c[1]), r)
        return True

    def _faces_kept(self, g: _Group, place: Placement) -> bool:
        """Whether the wall pieces of ``g`` that faced another of its pieces still do once the
        group is placed (a sofa pushed back to a nearer wall sees its TV stand at a wider angle:
        the loop does not carry wall pieces across the room to put that right)."""
        pairs = [(a, b) for a, b in sorted(self.ctx.keep_facing) if a in self.ctx.against_wall and a in g.members and b in g.members]
        outside = [(a, outline, c) for a, outline, c in self.ctx.faces_outside if a in g.members]
        if not pairs and not outside:
            return True
        from scenemosaic.evolve._analysis import layout_faces

        trial = self.layout.copy()
        for k in g.members:
            u, v, r = place[k]
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        if not all(points_at(np.asarray(trial.center(a)), _facing(trial.rotation(a)), outline, np.asarray(c)) for a, outline, c in outside):
            return False  # a sofa turned away from the TV on the wall across the room
        return all(layout_faces(trial, a, b) for a, b in pairs)

    def _followers_fit(self, g: _Group, place: Placement, turn: float, wall: WallLine | None) -> bool:
        """Whether the wall pieces hanging over ``g``'s members (``ctx.followers``) can hang where
        composition will carry them (``scene.follow_leaders``): on the wall their leader backs onto
        (``wall`` for the main piece), within its length and clear of its doors and windows. A
        piece whose leader backs onto no wall cannot follow it."""
        for piece, leader, _ in self.ctx.followers:
            if leader not in g.members:
                continue
            corners = self.ctx.surface.project(piece.corners())
            own = min(self.ctx.walls, key=lambda w: abs(w.gap(corners)), default=None)
            if own is None or abs(own.gap(corners)) > 0.05:
                continue  # not a wall piece (a ceiling lamp, a rug): it follows anywhere
            u, v, r = place[leader]
            target = wall if leader == g.lead else None
            if target is None:
                trial = self.layout.copy()
                trial.set_rotation(leader, r)
                trial.set_center(leader, u, v)
                behind = self._wall_behind(trial.polygon(leader), r, 0.3)
                target = behind[0] if behind is not None else None
            if target is None:
                return False
            lead0 = np.asarray(self.layout.center(leader))
            lead1 = np.array([u, v])
            lo0, hi0 = own.along(corners)
            lateral = _turned(own.tangent * ((lo0 + hi0) / 2 - float((lead0 - np.asarray(own.a)) @ own.tangent)), turn)
            mid = float((lead1 - np.asarray(target.a)) @ target.tangent) + float(lateral @ target.tangent)
            lo, hi = mid - (hi0 - lo0) / 2, mid + (hi0 - lo0) / 2
            if lo < 0 or hi > target.length:
                return False
            zlo, zhi = (float(v[2]) for v in piece.aabb())
            if any(hi > a - 0.05 and lo < b + 0.05 and zhi > z0 - 0.05 and zlo < z1 + 0.05 for a, b, z0, z1 in target.openings):
                return False
        return True

    def _lead_outline(self, g: _Group, opt: _Option) -> np.ndarray:
        trial = self.layout.copy()
        u, v, r = opt.place[g.lead]
        trial.set_rotation(g.lead, r)
        trial.set_center(g.lead, u, v)
        return trial.polygon(g.lead)

    def _options(self, g: _Group) -> list[_Option]:
        self._static_for(g)
        layout = self.layout
        pivot = np.asarray(layout.center(g.lead))
        out: list[_Option] = []
        stay = self._option(g, pivot, pivot, 0.0, False)  # where it stands: a group may keep its place
        if stay is not None:
            stay.stays = True
            out.append(stay)
        mirrors = (False, True) if len(g.members) > 1 else (False,)
        screens = [self.ctx.surface.project(o.corners()) for o in self.ctx.obstacles if is_screen(o.category)]
        bed = is_bed(layout.object(g.lead).category)
        if g.on_wall:
            for wall in self.ctx.walls:
                if wall.length < 0.5:
                    continue
                # a bed never backs onto the stretch of wall a TV hangs on (nobody watches the wall they lie against)
                hung = [wall.along(c) for c in screens if abs(wall.gap(c)) < 0.05] if bed else []
                turn = normalize_degrees(wall.facing - layout.rotation(g.lead))
                for to in flush_positions(layout, g.lead, wall, corners=True):
                    for mirror in mirrors:
                        opt = self._option(g, pivot, to, turn, mirror, wall)
                        if opt is None:
                            continue
                        if hung:
                            lo, hi = wall.along(self._lead_outline(g, opt))
                            if any(hi > a and lo < b for a, b in hung):
                                continue
                        out.append(opt)
        else:
            x0, y0, x1, y1 = self.region.bounds
            for u in np.arange(x0 + PLAN_STEP_M, x1, PLAN_STEP_M):
                for v in np.arange(y0 + PLAN_STEP_M, y1, PLAN_STEP_M):
                    for turn in (0.0, 90.0, 180.0, -90.0):
                        opt = self._option(g, pivot, np.array([u, v]), turn, False)
                        if opt is not None:
                            out.append(opt)
        return out

    def open_floor(self, solid: list[Polygon]) -> bool:
        """Whether the groups placed so far (their solid outlines), the fixtures and the other
        units' low pieces leave the floor as connected as the plan needs (``need``) with every door
        and passage reachable: checked after each group, so a search drops a place that cuts the
        room early instead of at the end."""
        raster = self.raster
        walk = raster.walkable(raster.blocked([*self.fixed_solid, *self.walk_obstacles, *solid]), ROBOT_RADIUS)
        if not walk.total or walk.share < self.need:
            return False
        main = walk.labels == walk.main
        return all(bool((main & m).any()) for m in self.door_masks)

    def walkable(self, place: Placement) -> tuple[float, bool]:
        """The plan's walkable share and whether every door zone reaches its main piece."""
        return walk_check(self.layout, self.ctx, place, self.walk_obstacles)


def walk_check(
    layout: UnitLayout, ctx: UnitContext, place: Placement, obstacles: list[Polygon] | None = None
) -> tuple[float, bool]:
    """How a placement of a floor unit leaves the floor for a robot: the walkable share (largest
    piece over all, ``ROBOT_RADIUS`` erosion on a :data:`PLAN_CELL_M` raster, the other units' low
    pieces standing) and whether every door zone (and open passage) touches the largest piece."""
    floor = _FLOOR_CHECKS.get(id(ctx), lambda: _FloorCheck.of(ctx))
    if obstacles is None:
        obstacles = floor.obstacles
    trial = layout.copy()
    for k, (u, v, r) in place.items():
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    feet = [
        trial.outline(k)
        for k in trial.ids
        if k not in ctx.thin and trial.span(k)[0] < WALK_MAX_HEIGHT
    ]
    raster = floor.raster
    walk = raster.walkable(raster.blocked([*feet, *obstacles]), ROBOT_RADIUS)
    if not walk.total:
        return 0.0, False
    main = walk.labels == walk.main
    doors = all(bool((main & m).any()) for m in floor.door_masks)
    return walk.share, doors


@dataclass(frozen=True)
class _FloorCheck:
    """What :func:`walk_check` needs of a unit's context, made once per context (it is fixed for
    the whole evolution, and a room's archetypes are checked against it by the hundred)."""

    ctx: UnitContext
    raster: FloorRaster
    door_masks: list[np.ndarray]
    """The cells of each door zone and open passage, grown by ``ROBOT_RADIUS``."""
    obstacles: list[Polygon]
    """The other units' low pieces (below ``WALK_MAX_HEIGHT``)."""

    @classmethod
    def of(cls, ctx: UnitContext) -> _FloorCheck:
        from scenemosaic.evolve._analysis import obstacle_polygons

        raster = FloorRaster(np.asarray(ctx.surface.region, dtype=np.float64), cell=PLAN_CELL_M)
        masks = [raster.mask(z.buffer(ROBOT_RADIUS)) for z in [*ctx.keep_clear, *ctx.passages]]
        low = [p for o, p in obstacle_polygons(ctx) if float(o.aabb()[0][2]) < WALK_MAX_HEIGHT and p.area > 0]
        return cls(ctx, raster, masks, low)


_FLOOR_CHECKS: Memo[int, _FloorCheck] = Memo(256)
"""Per unit context, by identity: an entry holds its context, so no other context can have its
id while the entry is kept."""


def doors_kept(layout: UnitLayout, ctx: UnitContext, place: Placement) -> bool:
    """Whether a placement is valid for the house as the base is. A floor unit with doors: no
    solid piece in a door zone that the base kept clear, the floor as connected
    (``scene.kept_floor_share`` of the base's) and every door reachable
    where the base's is. A wall unit: no piece newly across one of its doors or windows."""
    if not ctx.keep_clear and not ctx.in_house:
        return True
    base = {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids}
    trial = layout.copy()
    for k, (u, v, r) in place.items():
        trial.set_rotation(k, r)
        trial.set_center(k, u, v)
    for k in trial.ids:
        if k in ctx.thin and ctx.floor:
            continue
        now, before = trial.outline(k), layout.outline(k)
        for zone in ctx.keep_clear:
            if now.intersection(zone).area > 1e-3 and before.intersection(zone).area <= 1e-3:
                return False
    if not ctx.in_house:
        return True  # a wall unit: its doors and windows are all it must keep
    base_share, base_doors = _BASE_WALKS.get((id(ctx), tuple(sorted(base.items()))), lambda: (ctx, *walk_check(layout, ctx, base)))[1:]
    share, doors = walk_check(layout, ctx, place)
    return share >= kept_floor_share(base_share) and (doors or not base_doors)


_BASE_WALKS: Memo[tuple[int, tuple[tuple[str, tuple[float, float, float]], ...]], tuple[UnitContext, float, bool]] = Memo(256)
""":func:`walk_check` of a unit's base placement (its context, by identity, and every piece's
place): each of a room's archetypes is compared with the same base."""


def flush_positions(
    layout: UnitLayout, piece: str, wall: WallLine, step: float = PLAN_STEP_M, *, corners: bool = False
) -> list[np.ndarray]:
    """The centres ``piece`` may take turned to face away from ``wall``, its back flush against it
    and its span within it, every ``step`` metres along it (the plans' and the archetypes' one
    definition of a place on a wall). With ``corners`` the places keep the flush gap to the
    wall's two ends too, and the place pushed into the far corner is one of them (a room plan's
    piece may stand in either corner; the steps alone start exactly at the wall's start, where
    the side wall leaves no gap, and may stop short of its end)."""
    from scenemosaic.evolve._analysis import WALL_FLUSH_GAP

    trial = layout.copy()
    trial.set_rotation(piece, wall.facing)
    poly = trial.polygon(piece)
    back = (WALL_FLUSH_GAP - wall.gap(poly)) * np.asarray(wall.inward)
    lo, hi = wall.along(poly + back)
    start = np.asarray(trial.center(piece)) + back
    if not corners:
        return [start + t * wall.tangent for t in np.arange(-lo, wall.length - hi + 1e-9, step)]
    first, last = -lo + WALL_FLUSH_GAP, wall.length - hi - WALL_FLUSH_GAP
    if last < first - 1e-9:
        return []
    steps = [float(t) for t in np.arange(first, last + 1e-9, step)]
    if last - steps[-1] > 0.01:
        steps.append(last)
    return [start + t * wall.tangent for t in steps]


def _plan(
    planner: _Planner, rng: np.random.Generator, history: dict[str, list[np.ndarray]]
) -> tuple[Placement, dict[str, _Option]] | None:
    """One plan: the groups placed most constrained first (fewest valid places), each at its
    best-scored place clear of those already placed; a group left without a place sends the
    search back to the previous group's next best (:data:`PLAN_BRANCH` each, at most
    :data:`PLAN_EXPANSIONS` places tried in all)."""
    layout = planner.layout
    order = sorted(planner.groups, key=lambda g: (len(planner.options[g.lead]), -g.area, g.lead))
    jitter = {g.lead: rng.random(len(planner.options[g.lead])) * _JITTER_M for g in order}
    budget = [PLAN_EXPANSIONS]
    scores: dict[tuple[str, int], float] = {}

    placed: Placement = {}

    def search(i: int, taken: list[Polygon], solid: list[Polygon]) -> list[_Option] | None:
        if i == len(order):
            return []
        g = order[i]
        done = {k for h in order[: i + 1] for k in h.members}
        blocked = unary_union([p.buffer(PLAN_MARGIN_M, join_style="mitre") for p in taken]) if taken else Polygon()
        scored = []
        for j, opt in enumerate(planner.options[g.lead]):
            if taken and any(blocked.intersects(s) for s in opt.shapes):
                continue
            score = scores.get((g.lead, j))
            if score is None:  # the history and the jitter hold for the whole plan: scored once
                score = scores[(g.lead, j)] = _farthest(planner, g.lead, j, opt, history[g.lead]) + float(jitter[g.lead][j])
            scored.append((-score, j, opt))
        scored.sort(key=lambda x: (x[0], x[1]))
        tried = scored[:PLAN_BRANCH]
        tried += [x for x in scored[PLAN_BRANCH:] if x[2].stays]  # keeping its place is always tried too
        for _, _, opt in tried:
            if budget[0] <= 0:
                return None
            budget[0] -= 1
            now = [*solid, *opt.solid]
            placed.update(opt.place)
            if planner.facing and not planner.facing_kept(placed, done):
                continue  # two pieces split apart no longer face each other
            if not planner.open_floor(now):
                continue  # what is placed so far already cuts the floor or a door off
            rest = search(i + 1, [*taken, *opt.shapes], now)
            if rest is not None:
                return [opt, *rest]
        return None

    found = search(0, [], [])
    if found is None:
        found = _groups_moved_one_by_one(planner, order, scores, jitter, history)
    if found is None:
        return None
    place: Placement = {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids}
    chosen: dict[str, _Option] = {}
    for g, opt in zip(order, found, strict=True):
        chosen[g.lead] = opt
        place.update(opt.place)
    def moved(g: _Group) -> bool:
        return planner._moves(g, chosen[g.lead])

    if not any(moved(g) for g in planner.groups if g.area >= PLAN_MIN_AREA_M2 or g is planner.groups[0]):
        return None  # only small pieces moved: no new arrangement of the room
    return place, chosen


def _groups_moved_one_by_one(
    planner: _Planner,
    order: list[_Group],
    scores: dict[tuple[str, int], float],
    jitter: dict[str, np.ndarray],
    history: dict[str, list[np.ndarray]],
) -> list[_Option] | None:
    """A plan for a room too full for the search to regroup it whole (a dining room of eight
    chairs, a buffet, a sideboard and two bookcases): every group where it stands, then the groups
    of furniture, largest first, each moved in turn to its best-scored place that clears the
    others where they are now, keeps the floor open and the doors reachable, or left where it
    stands when it has none (:data:`PLAN_EXPANSIONS` places tried in all). ``None`` when no group
    moved, or a group has no place where it stands."""
    now: dict[str, _Option] = {}
    for g in order:
        stay = next((o for o in planner.options[g.lead] if o.stays), None)
        if stay is None:
            return None
        now[g.lead] = stay
    budget = PLAN_EXPANSIONS
    movers = sorted((g for g in order if g.area >= PLAN_MIN_AREA_M2 or g is planner.groups[0]), key=lambda g: (-g.area, g.lead))
    everyone = {k for h in order for k in h.members}
    moved = False
    for g in movers:
        rest = [now[h.lead] for h in order if h is not g]
        blocked = unary_union([p.buffer(PLAN_MARGIN_M, join_style="mitre") for o in rest for p in o.shapes])
        solid = [p for o in rest for p in o.solid]
        kept: Placement = {k: v for o in rest for k, v in o.place.items()}
        scored = []
        for j, opt in enumerate(planner.options[g.lead]):
            if opt.stays or not planner._moves(g, opt) or any(blocked.intersects(p) for p in opt.shapes):
                continue
            if planner._before_window(g, opt.place):  # the patterns' check of use, asked up front here
                continue
            score = scores.get((g.lead, j))
            if score is None:
                score = scores[(g.lead, j)] = _farthest(planner, g.lead, j, opt, history[g.lead]) + float(jitter[g.lead][j])
            scored.append((-score, j, opt))
        for _, _, opt in sorted(scored, key=lambda x: (x[0], x[1])):
            if budget <= 0:
                break
            budget -= 1
            if planner.facing and not planner.facing_kept({**kept, **opt.place}, everyone):
                continue
            if planner.open_floor([*solid, *opt.solid]):
                now[g.lead], moved = opt, True
                break
    return [now[h.lead] for h in order] if moved else None


def _farthest(planner: _Planner, lead: str, j: int, opt: _Option, history: list[np.ndarray]) -> float:
    """How far option ``j`` of ``lead``'s group stands from the nearest place the group took
    before (``history``, which only grows from plan to plan): the distance to the entries seen
    so far is kept on the planner and only the new ones are measured."""
    seen, nearest = planner.nearest.get((lead, j), (0, math.inf))
    for c in history[seen:]:
        nearest = min(nearest, float(np.linalg.norm(opt.centre - c)))
    planner.nearest[(lead, j)] = (len(history), nearest)
    return nearest


def _same_plan(planner: _Planner, a: Placement, b: Placement) -> bool:
    """Whether two plans put every group of furniture (the largest, and every one with
    :data:`PLAN_MIN_AREA_M2` of footprint) at the same place: main pieces within half of
    :data:`PLAN_MIN_MOVE_M` and turned alike."""
    for g in planner.groups:
        if g.area < PLAN_MIN_AREA_M2 and g is not planner.groups[0]:
            continue
        (ua, va, ra), (ub, vb, rb) = a[g.lead], b[g.lead]
        if math.dist((ua, va), (ub, vb)) > PLAN_MIN_MOVE_M / 2 or abs(normalize_degrees(ra - rb)) > 20.0:
            return False
    return True


def room_plans(layout: UnitLayout, ctx: UnitContext, limit: int = MAX_PLANS) -> list[Placement]:
    """Up to ``limit`` room plans of a floor unit with doors (module docstring), most different
    first; none for other units or when nothing can move. The plans come one after another (each
    steered away from those before it), so a search is kept per layout and goes on when more are
    asked for: the first ``k`` plans are the same whatever the limit."""
    key = tuple(
        (k, round(layout.center(k)[0], 4), round(layout.center(k)[1], 4), round(layout.rotation(k), 2)) for k in layout.ids
    )
    search: _PlanSearch | None = ctx.plan_cache.get(key)
    if search is None:
        search = ctx.plan_cache.setdefault(key, _PlanSearch(layout, ctx))
    assert search is not None
    return search.first(limit)


class _PlanSearch:
    """One layout's room plans, found as they are asked for (:func:`room_plans`)."""

    def __init__(self, layout: UnitLayout, ctx: UnitContext) -> None:
        self.layout, self.ctx = layout, ctx
        self.plans: list[Placement] = []
        self.done = not ctx.in_house
        self.planner: _Planner | None = None
        self.need = WALK_MIN_SHARE
        self.history: dict[str, list[np.ndarray]] = {}
        self.rng = np.random.default_rng(PLAN_SEED)
        self.fails = self.repeats = 0
        self.lock = threading.Lock()  # a unit's variant nodes ask from their own threads

    def first(self, n: int) -> list[Placement]:
        """The first ``n`` plans (fewer when the search ends before)."""
        with self.lock:
            if n > 0 and self.planner is None and not self.done:
                self._start()
            while not self.done and len(self.plans) < n:
                self._step()
            return list(self.plans[:n])

    def _start(self) -> None:
        layout = self.layout
        planner = self.planner = _Planner(layout, self.ctx)
        if not planner.groups or not any(planner.options.values()):
            self.done = True
            return
        base_share, _ = planner.walkable({k: (*layout.center(k), layout.rotation(k)) for k in layout.ids})
        self.need = planner.need = kept_floor_share(base_share)
        self.history = {g.lead: [np.asarray(layout.center(g.lead))] for g in planner.groups}

    def _step(self) -> None:
        """One attempt at the next plan."""
        planner, history = self.planner, self.history
        assert planner is not None
        if self.fails >= PLAN_TRIES:
            self.done = True
            return
        found = _plan(planner, self.rng, history)
        if found is None:
            self.fails += 1
            return
        place, chosen = found
        share, doors = planner.walkable(place)
        if share < self.need or not doors:
            self.fails += 1
            for lead, opt in chosen.items():  # steer the next attempt elsewhere
                history[lead].append(opt.centre)
            return
        if any(_same_plan(planner, place, other) for other in self.plans):
            self.fails += 1  # the furniture where an earlier plan put it: steer elsewhere
            self.repeats += 1
            if self.repeats >= PLAN_REPEATS:
                self.done = True  # the room holds no other arrangement the search can find
                return
        else:
            self.plans.append(place)
        for lead, opt in chosen.items():
            history[lead].append(opt.centre)


def plan_summary(layout: UnitLayout, place: Placement) -> str:
    """Which pieces a plan moves, in words (for the archetype's reasoning)."""
    moved = [
        k for k, (u, v, r) in place.items()
        if math.dist((u, v), layout.center(k)) > 0.3 or abs(normalize_degrees(r - layout.rotation(k))) > 20
    ]  # fmt: skip
    cats = sorted({layout.object(k).category for k in moved})
    return ", ".join(cats[:6]) or "nothing"

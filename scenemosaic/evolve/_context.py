"""What an evolving unit knows besides its own layout: walls, roles, clauses and fixed obstacles."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scenemosaic.assets import part_blockers, part_reach, short_parts
from scenemosaic.scene import (
    ConstraintClause,
    LocalUnit,
    Scene,
    SceneObject,
    UnitLayout,
    UnitSurface,
    blocked_windows,
    convex_hull_2d,
    descendants,
    door_zones,
    functional_relations,
    screens_behind,
    surface_for,
    traits,
)

__all__ = ["UnitContext", "WallLine", "facing_degrees", "parts_in_the_way", "unit_context", "windows_in_the_way"]

TABLE_REACH = 0.8
"""A seat with no ``faces`` relation belongs to a table or desk whose box is this close, metres..."""
CHAIR_REACH = 1.5
"""... and a chair (not an armchair or a sofa) to one this close: a dining chair left 1.2 m from
the only dining table belongs to it."""
CHAIRS = frozenset({"chair", "dining_chair", "office_chair", "chinese_chair", "dressing_chair", "stool", "barstool"})
BED_REACH = 1.0
"""A nightstand with no ``beside`` relation belongs to a bed whose box is this close, metres."""
NIGHTSTANDS = frozenset({"nightstand"})
BEDS = frozenset({"bed", "double_bed", "single_bed", "kids_bed", "bunk_bed", "king_bed"})


def facing_degrees(direction: tuple[float, float] | np.ndarray) -> float:
    """The in-plane rotation (0 down, 90 left, 180 up, -90 right) of a facing direction (u, v)."""
    a, b = float(direction[0]), float(direction[1])
    return math.degrees(math.atan2(-a, -b))


@dataclass(frozen=True)
class WallLine:
    """A wall seen in a floor unit's plane: its inner face from ``a`` to ``b`` and inward normal."""

    id: str
    a: tuple[float, float]
    b: tuple[float, float]
    inward: tuple[float, float]
    openings: tuple[tuple[float, float, float, float], ...] = ()
    """The wall's doors, windows and open stretches: (from, to) along the wall from ``a``, and
    (bottom, top) heights, metres."""

    @property
    def length(self) -> float:
        return math.hypot(self.b[0] - self.a[0], self.b[1] - self.a[1])

    @property
    def tangent(self) -> np.ndarray:
        d = np.array([self.b[0] - self.a[0], self.b[1] - self.a[1]])
        return d / max(float(np.linalg.norm(d)), 1e-12)

    def gap(self, polygon: np.ndarray) -> float:
        """Distance from the wall face to the polygon's nearest point (negative: through the wall)."""
        return float(((polygon - np.asarray(self.a)) @ np.asarray(self.inward)).min())

    def along(self, polygon: np.ndarray) -> tuple[float, float]:
        """The polygon's span along the wall, from ``a``."""
        t = (polygon - np.asarray(self.a)) @ self.tangent
        return float(t.min()), float(t.max())

    def overlap(self, polygon: np.ndarray) -> float:
        """Fraction of the polygon's span along the wall that lies in front of the wall."""
        lo, hi = self.along(polygon)
        if hi - lo < 1e-9:
            return 1.0 if 0 <= lo <= self.length else 0.0
        return max(0.0, min(hi, self.length) - max(lo, 0.0)) / (hi - lo)

    @property
    def facing(self) -> float:
        """The rotation of an object facing away from this wall into the room."""
        return facing_degrees(self.inward)


@dataclass
class UnitContext:
    """A unit's surroundings and its children's roles, fixed for the whole evolution."""

    unit: LocalUnit
    surface: UnitSurface
    walls: list[WallLine] = field(default_factory=list)
    """Walls in the plane (floor units only)."""
    obstacles: list[SceneObject] = field(default_factory=list)
    """Objects of other units, fixed, checked for collisions with the children."""
    against_wall: set[str] = field(default_factory=set)
    """Children that belong with their back to a wall and their front to the room."""
    seat_table: dict[str, str] = field(default_factory=dict)
    """Seat -> the table or desk it faces."""
    nightstand_bed: dict[str, str] = field(default_factory=dict)
    """Nightstand -> the bed whose head it stands beside."""
    sofa_tv: dict[str, str] = field(default_factory=dict)
    """Sofa -> the TV stand it faces."""
    keep_facing: set[tuple[str, str]] = field(default_factory=set)
    """(piece, target) pairs of lounge pieces that face each other in the stabilized scene and
    must go on doing so: a sofa or armchair and its coffee table, a sofa and its TV, the TV and
    the sofa (``scene.functional_relations``, ``faces``, seats at tables left to the etiquette)."""
    with_front: set[str] = field(default_factory=set)
    """Children whose front matters (seats, storage, tables against walls...): they must not face a wall."""
    followers: list[tuple[SceneObject, str, tuple[float, float, float]]] = field(default_factory=list)
    """Other units' pieces that follow one of this unit's (a low lamp over a table: composition
    moves it with the table): (the piece, its leader, the leader's (u, v, rotation) when the
    context was made). They are not obstacles; the passage rule sees them where they will hang."""
    keep_clear: list[Any] = field(default_factory=list)
    """What a variant must not newly put a piece in, as (u, v) shapely polygons: on a floor unit
    the clearance zone in front of each door, as deep as the door is wide (``scene.door_zones``
    with ``depth=None``: where its leaves swing, and what SceneEval's Opening Clearance looks at;
    no seat slot, no plan, no archetype takes it); on a wall unit the stretch of each door and
    window in the wall, from the floor to the opening's top (a picture hung there blocks the door
    or covers the window)."""
    faces_outside: list[tuple[str, Any, tuple[float, float]]] = field(default_factory=list)
    """Floor units: children that face a piece of another unit which stays put for them (a sofa
    facing the TV hung on the wall across the room; not a TV standing on one of the unit's own
    pieces, which moves with it): (child, the piece's outline as a (u, v) shapely polygon, its
    centre); a room plan keeps each facing it."""
    riders: dict[str, list[Any]] = field(default_factory=dict)
    """Floor units: the outlines, (u, v) points, of what rests on each child (a TV on its stand),
    in the stabilized scene; they move with the child, so a place for the child must hold them too."""
    passages: list[Any] = field(default_factory=list)
    """The same zones in front of the room's open stretches of wall (open-plan rooms of a house):
    a variant keeps them reachable (floor units)."""
    part_reach: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Children whose drawers, doors or lids reach out of their box on the way open for use: id ->
    (metres past the front face, past either side) (``assets.part_reach``); the space kept in front
    of them holds it."""
    scene: Scene | None = field(default=None, repr=False)
    """The stabilized scene the unit stands in (what a layout's parts are checked in)."""
    base_dir: Path | None = None
    """Resolves the scene's mesh assets and their part declarations."""
    windows_blocked: Mapping[str, list[str]] = field(default_factory=dict)
    """The windows furniture stands before in the stabilized scene (``scene.blocked_windows``): a
    floor layout may leave these as they are, and must not add to them (:func:`windows_in_the_way`)."""
    screens_behind: list[tuple[str, str]] = field(default_factory=list)
    """The beds and lounge seats with a screen behind their backs in the stabilized scene
    (``scene.screens_behind``): a floor layout may leave these as they are, and must not add to
    them (:func:`screens_put_behind`)."""
    short_parts: Mapping[str, list[str]] = field(default_factory=dict)
    """The drawers, doors and lids that cannot open as far as their use needs in the stabilized
    scene, by object id (``assets.short_parts``): a layout may leave these as they are, and must
    not add to them (:func:`~scenemosaic.evolve.parts_in_the_way`)."""
    clauses: list[ConstraintClause] = field(default_factory=list)
    pinned: dict[str, tuple[str, tuple[float, float], float]] = field(default_factory=dict)
    """Children a cross-unit clause ties down: id -> (constraint kind, centre, rotation) to keep."""
    thin: set[str] = field(default_factory=set)
    obstacle_polygons: list[tuple[SceneObject, Any]] | None = field(default=None, repr=False)
    """The obstacles' outlines on the surface (shapely polygons), computed on first use."""
    plan_cache: dict[Any, Any] = field(default_factory=dict, repr=False)
    """What was worked out for a layout of this unit, by layout: its room plans
    (``evolve/_plans.py``) and its rule patterns (``evolve/_archetypes.py``)."""

    @property
    def frozen_rotation(self) -> bool:
        """Containment units keep their children's rotations (only centres change)."""
        return self.surface.projection == "anchor_front"

    @property
    def floor(self) -> bool:
        return self.unit.anchor_kind == "floor"

    @property
    def in_house(self) -> bool:
        """A floor unit of a room with doors or open passages to other rooms (a room of a house)."""
        return self.floor and bool(self.keep_clear or self.passages)


def _opening_zones(scene: Scene, wall_id: str, surface: UnitSurface) -> list[Any]:
    """The doors and windows of wall ``wall_id`` on its surface, as (u, v) polygons: each
    opening's width, from below the floor to its top (a door: a piece hung anywhere lower than
    its top stands in its way) or from its sill to its top (a window)."""
    from shapely.geometry import Polygon

    wall = next((w for w in scene.room.walls if w.id == wall_id), None) if scene.room is not None else None
    if wall is None:
        return []
    start, direction = np.asarray(wall.start, dtype=np.float64), np.asarray(wall.direction, dtype=np.float64)
    out = []
    for op in wall.openings:
        if op.kind == "opening":
            continue
        lo, hi = wall.span(op)
        bottom = -1.0 if op.kind == "door" else op.bottom
        top = op.bottom + op.height
        corners = []
        for t, z in ((lo, bottom), (hi, bottom), (hi, top), (lo, top)):
            x, y = start + direction * t
            corners.append(surface.to_uv(np.array([x, y, z])))
        out.append(Polygon(corners))
    return out


def _box_distance(a: SceneObject, b: SceneObject) -> float:
    from shapely.geometry import Polygon

    return float(Polygon(a.footprint()).distance(Polygon(b.footprint())))


def unit_context(
    scene: Scene,
    unit: LocalUnit,
    obstacles: list[SceneObject],
    thin: set[str],
    short: Mapping[str, list[str]] | None = None,
    base_dir: Path | None = None,
) -> UnitContext:
    """The context of ``unit`` in ``scene`` (its stabilized state); ``short``: the scene's parts that
    cannot open as far as their use needs (``assets.short_parts``; default: worked out here);
    ``base_dir`` resolves mesh assets' part declarations."""
    surface = surface_for(scene, unit.anchor_id)
    ctx = UnitContext(unit=unit, surface=surface, obstacles=obstacles, thin=set(thin) & set(unit.children))
    ctx.scene, ctx.base_dir = scene, base_dir
    if unit.anchor_kind == "floor":
        ctx.windows_blocked = blocked_windows(scene)
        ctx.screens_behind = screens_behind(scene)
    ctx.short_parts = dict(short_parts(scene, base_dir) if short is None else short)
    for oid in unit.children:
        swing = part_reach(scene.get(oid), base_dir)
        if swing != (0.0, 0.0):
            ctx.part_reach[oid] = swing
    ctx.clauses = list(unit.clauses)
    kids = [scene.get(c) for c in unit.children]
    faces = {(r.child, r.parent) for r in scene.relations if r.kind == "faces"}
    by_id = {o.id: o for o in kids}
    if unit.anchor_kind == "floor" and scene.room is not None:
        for w in scene.room.walls:
            a = surface.to_uv(np.array([w.start[0], w.start[1], 0.0]))
            b = surface.to_uv(np.array([w.end[0], w.end[1], 0.0]))
            n = np.array([w.inward_normal[0], w.inward_normal[1], 0.0])
            inward = (float(n @ surface.u_axis), float(n @ surface.v_axis))
            cuts = tuple((*w.span(o), o.bottom, o.bottom + o.height) for o in w.openings)
            ctx.walls.append(WallLine(w.id, a, b, inward, cuts))
        for o in kids:
            t = traits(o.category)
            if t.against_wall and t.placement == "floor":
                ctx.against_wall.add(o.id)
            if t.seat or t.against_wall or t.table:
                ctx.with_front.add(o.id)
        beside = {(r.child, r.parent) for r in scene.relations if r.kind == "beside"}
        for o in kids:
            t = traits(o.category)
            if t.seat and not t.against_wall:
                targets = [p for c, p in faces if c == o.id and p in by_id]
                if not targets:
                    reach = CHAIR_REACH if o.category in CHAIRS else TABLE_REACH
                    tables = sorted(
                        (d, k.id) for k in kids if traits(k.category).table and (d := _box_distance(o, k)) <= reach
                    )
                    targets = [tables[0][1]] if tables else []
                if targets:
                    ctx.seat_table[o.id] = sorted(targets)[0]
            if t.seat and t.against_wall:
                tv = sorted(p for c, p in faces if c == o.id and p in by_id and by_id[p].category == "tv_stand")
                if tv:
                    ctx.sofa_tv[o.id] = tv[0]
            if o.category in NIGHTSTANDS:
                beds = sorted(p for c, p in beside if c == o.id and p in by_id and by_id[p].category in BEDS)
                if not beds:
                    near = sorted(
                        (d, k.id) for k in kids if k.category in BEDS and (d := _box_distance(o, k)) <= BED_REACH
                    )
                    beds = [near[0][1]] if near else []
                if beds:
                    ctx.nightstand_bed[o.id] = beds[0]
    constraints = {c.id: c for c in scene.constraints}
    layout = UnitLayout.from_scene(scene, unit)
    if unit.anchor_kind == "wall" and scene.room is not None:
        ctx.keep_clear = _opening_zones(scene, unit.anchor_id, surface)
    if unit.anchor_kind == "floor":
        from shapely.geometry import Polygon

        for zone in door_zones(scene, depth=None):  # as deep as each door is wide: where its leaves swing
            for piece in getattr(zone.polygon, "geoms", [zone.polygon]):
                if piece.geom_type == "Polygon":
                    pts = np.asarray(piece.exterior.coords)[:, :2]
                    ctx.keep_clear.append(Polygon([surface.to_uv(np.array([x, y, 0.0])) for x, y in pts]))
        for o in kids:
            ctx.riders[o.id] = [ctx.surface.project(scene.get(d).corners()) for d in sorted(descendants(scene, o.id))]
        for zone in door_zones(scene, kinds=("opening",)):
            if zone.polygon.geom_type != "Polygon":
                continue
            pts = np.asarray(zone.polygon.exterior.coords)[:, :2]
            ctx.passages.append(Polygon([surface.to_uv(np.array([x, y, 0.0])) for x, y in pts]))
        carried = {d for o in kids for d in descendants(scene, o.id)}  # what moves with a child (a TV on its stand)
        for rel in functional_relations(scene):
            if rel.kind == "faces" and rel.subject in by_id and rel.leader in by_id and rel.subject not in ctx.seat_table:
                ctx.keep_facing.add((rel.subject, rel.leader))
            if rel.kind == "faces" and rel.subject in by_id and rel.leader not in by_id and rel.leader not in carried and not rel.follows:
                target = scene.get(rel.leader)
                outline = Polygon(convex_hull_2d(surface.project(target.corners())))
                ctx.faces_outside.append((rel.subject, outline, surface.to_uv(np.asarray(target.pose.position))))
            if rel.follows and rel.leader in by_id and rel.subject not in by_id:
                lead = layout.center(rel.leader)
                ctx.followers.append((scene.get(rel.subject), rel.leader, (lead[0], lead[1], layout.rotation(rel.leader))))
    # clauses the semantic rules already enforce (seats at tables, nightstands at beds, sofas
    # facing) are kept by those rules wherever the group goes; the others pin their objects
    covered = set(ctx.seat_table) | set(ctx.seat_table.values()) | set(ctx.nightstand_bed)
    covered |= set(ctx.nightstand_bed.values()) | set(ctx.sofa_tv) | set(ctx.sofa_tv.values())
    covered |= {c for c, p in faces if c in by_id and p in by_id} | {p for c, p in faces if c in by_id and p in by_id}
    for clause in ctx.clauses:
        kind = next(
            (
                c.kind
                for c in constraints.values()
                if clause in (c.anchor_a, c.anchor_b)
            ),
            "placement",
        )
        for oid in clause.related_objects:
            if oid in by_id and oid not in covered:
                ctx.pinned[oid] = (kind, layout.center(oid), layout.rotation(oid))
    return ctx


def parts_in_the_way(layout: UnitLayout, ctx: UnitContext, *, floor: bool = False) -> list[str]:
    """The drawers, doors and lids that the unit's pieces, posed as ``layout`` says in the unit's
    stabilized scene (``ctx.scene``), newly keep from opening as far as their use needs, as
    sentences (empty when none): a part the stabilized scene lets open (``ctx.short_parts``) that
    the layout blocks (a dresser moved before a wardrobe's door, soap stood in a toilet lid's
    path). The model is ``assets.short_parts``, each part's box swept from closed against the other
    objects' boxes and the walls; only the parts whose path comes near a piece of the unit are
    swept. A seat at its own table or desk (``ctx.seat_table``) is not in the way of that table's
    drawers: it is pulled back first, as a person does. An object with no more parts blocked than
    in the stabilized scene counts as kept (a mirrored room blocks the door on the other side).

    A finished layout is held to it for the units of what stands on furniture (a toilet's, a
    counter's); ``floor=True`` holds a floor unit too, as the rule patterns are held before their
    loop runs (``evolve/_archetypes.py``): refusing finished floor layouts left two PhyScene rooms
    with too few different variants (``docs/articulation.md``)."""
    if ctx.scene is None or (ctx.unit.anchor_kind != "object" and not floor):
        return []
    from scenemosaic.evolve._views import scene_with

    posed = scene_with(ctx.scene, layout)
    moved = set(layout.ids) | {d for k in layout.ids for d in descendants(posed, k)}
    now = short_parts(posed, ctx.base_dir, near=moved)
    out = []
    for oid, names in sorted(now.items()):
        before = ctx.short_parts.get(oid, ())
        new = [n for n in names if n not in before]
        if not new or len(names) <= len(before):  # as many blocked as before (a mirrored room's other door)
            continue
        stoppers = part_blockers(posed, oid, ctx.base_dir)
        for name in new:
            found = stoppers.get(name, ["something"])
            if all(ctx.seat_table.get(b) == oid for b in found):
                continue  # a chair at its own desk: pulled back before a drawer is opened
            out.append(f"{oid}'s {name} cannot open: {', '.join(found)} in its way")
    return out


def windows_in_the_way(layout: UnitLayout, ctx: UnitContext) -> list[str]:
    """The windows a floor unit's pieces, posed as ``layout`` says in its stabilized scene, newly stand
    before (``scene.blocked_windows``: a tall piece backed against a window's stretch of wall, or a
    low one carrying something that rises above the sill), as sentences (empty when none): a window
    the stabilized scene keeps clear stays clear, whatever the layout clears elsewhere (SceneEval's
    Opening Clearance compares window by window)."""
    if ctx.scene is None or not ctx.floor:
        return []
    from scenemosaic.evolve._views import scene_with

    now = blocked_windows(scene_with(ctx.scene, layout))
    return [f"{', '.join(ids)} before window {w}" for w, ids in sorted(now.items()) if w not in ctx.windows_blocked]


def screens_put_behind(layout: UnitLayout, ctx: UnitContext) -> list[str]:
    """The beds and lounge seats a floor unit's pieces, posed as ``layout`` says in its stabilized
    scene, newly turn their backs on a screen (``scene.screens_behind``: a bed's head against the
    TV's wall, a sofa backed onto its TV), as sentences (empty when none). A seat of a table or
    desk (``ctx.seat_table``: an armchair at the dining table) faces its table, not the screen."""
    if ctx.scene is None or not ctx.floor:
        return []
    from scenemosaic.evolve._views import scene_with

    now = screens_behind(scene_with(ctx.scene, layout))
    return [
        f"{piece} turns its back on {screen}"
        for piece, screen in now
        if (piece, screen) not in ctx.screens_behind and piece not in ctx.seat_table
    ]

"""Room and walls: a canonical floor polygon, wall primitives and a ceiling height.

Rule solver: when the scene already has a room it is kept (walls are completed from the
polygon edges if missing) and *repaired* where the objects disagree with it: an object poking
through a wall by up to ``MAX_PULL_IN`` is pulled back into the room, one hanging through the
ceiling is lowered under it; an object further out means the input room is too small, and the
room is grown to the rectangle around everything. Every change is listed in the output. Otherwise the room is the tightest rectangle around every object
footprint, tried axis-aligned and at the scene's dominant heading, with a margin on each side;
a side whose outermost object is a wall-type piece of furniture (wardrobe, bed, sofa...) with
its back to that side is snapped to the object with only a hairline gap.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from shapely.affinity import translate
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent
from scenemosaic.scene import (
    MAX_FLOOR_POINTS,
    ROOM_MARGIN,
    WALL_SNAP_GAP,
    FootprintItem,
    Room,
    Wall,
    dominant_orientation,
    recovered_ceiling,
    room_rectangle,
    traits,
)
from scenemosaic.structure._facts import (
    ObjectFacts,
    RoomFacts,
    object_facts,
    replace_scene,
    room_facts,
    translate_objects,
)
from scenemosaic.structure._views import FloorPlanImages

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = ["MIN_WALL_LENGTH", "ObjectShift", "RoomAgent", "RoomEvidence", "RoomOutput", "WallSpec"]

CONTAIN_TOLERANCE = 0.02
"""How far (metres) a footprint may poke out of the floor polygon and still count as inside."""


class WallSpec(AgentOutput):
    """One wall of the recovered room (interior on the left of start -> end)."""

    id: str = Field(max_length=64, pattern=r"^[A-Za-z0-9_.\-]+$")
    start: tuple[float, float]
    end: tuple[float, float]
    height: float = Field(gt=0, le=20)


MAX_PULL_IN = 0.5
"""Largest distance (metres) an object poking through a kept room's wall is moved back in; an
object further out grows the room instead (the input room was too small, not the object misplaced)."""
CEILING_GAP = 0.01
"""Gap (metres) kept under the ceiling by an object lowered because it poked through it."""


class ObjectShift(AgentOutput):
    """A translation of one object (what it carries moves with it), and why: into a kept room,
    out of the ceiling, out of another piece of furniture."""

    object_id: str = Field(max_length=64)
    dx: float = Field(ge=-MAX_PULL_IN - 0.01, le=MAX_PULL_IN + 0.01)
    dy: float = Field(ge=-MAX_PULL_IN - 0.01, le=MAX_PULL_IN + 0.01)
    dz: float = Field(default=0.0, ge=-20, le=0.0, description="Only downward: out of the ceiling.")
    reason: str = Field(default="", max_length=200)


class RoomOutput(AgentOutput):
    """The room boundary the agent settled on."""

    floor: list[tuple[float, float]] = Field(
        min_length=3, max_length=MAX_FLOOR_POINTS, description="Counter-clockwise polygon."
    )
    walls: list[WallSpec] = Field(default_factory=list, max_length=MAX_FLOOR_POINTS)
    ceiling_height: float = Field(gt=0, le=20)
    kept_input: bool = Field(default=False, description="True when the input room was kept.")
    yaw_deg: float = Field(default=0.0, description="Heading of the fitted rectangle.")
    shifts: list[ObjectShift] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects moved to lie inside a kept room."
    )
    note: str = Field(default="", max_length=400)


class RoomEvidence(BaseModel):
    """Objects and the input room, if any."""

    model_config = ConfigDict(extra="forbid")
    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    room: RoomFacts | None = None


def _items(objects: list[ObjectFacts]) -> list[FootprintItem]:
    return [
        FootprintItem(
            points=np.asarray(o.footprint, dtype=np.float64),
            yaw=math.radians(o.yaw_deg),
            category=o.category,
            top=o.top,
            area=o.area,
        )
        for o in objects
    ]


def _fit(items: list[FootprintItem], yaw: float) -> tuple[list[tuple[float, float]], float]:
    """The scene layer's room rectangle with the agent's settings: a margin on free sides, wall
    furniture snapped to its wall; corners rounded to 0.1 mm for a stable answer."""
    floor, area = room_rectangle(items, yaw, margin=ROOM_MARGIN, snap_gap=WALL_SNAP_GAP)
    return [(round(x, 4), round(y, 4)) for x, y in floor], area


def _walls_for(floor: list[tuple[float, float]], height: float) -> list[WallSpec]:
    n = len(floor)
    return [WallSpec(id=f"wall_{i}", start=floor[i], end=floor[(i + 1) % n], height=height) for i in range(n)]


def _pull_in(poly: Polygon, footprint: Polygon) -> tuple[float, float] | None:
    """The smallest translation (a few steps toward the nearest inside point) that puts
    ``footprint`` inside ``poly``; ``None`` when none within ``MAX_PULL_IN`` does."""
    inner = poly.buffer(-1e-4)
    dx = dy = 0.0
    for _ in range(8):
        moved = translate(footprint, dx, dy)
        outside = moved.difference(inner)
        if outside.area < 1e-8:
            return (dx, dy)
        # push away from the part that pokes out, by its extent along the push direction
        cx, cy = outside.centroid.x, outside.centroid.y
        near = nearest_points(poly.exterior, Point(cx, cy))[0]
        mx, my = moved.centroid.x, moved.centroid.y
        vx, vy = mx - cx, my - cy
        n = math.hypot(vx, vy)
        if n < 1e-9:
            vx, vy, n = mx - near.x, my - near.y, math.hypot(mx - near.x, my - near.y) or 1.0
        ux, uy = vx / n, vy / n
        depth = max(
            0.0,
            max((ux * (near.x - x) + uy * (near.y - y)) for x, y in outside.exterior.coords)
            if isinstance(outside, Polygon)
            else 0.0,
        )
        step = max(depth, 0.005) + 0.002
        dx, dy = dx + ux * step, dy + uy * step
        if math.hypot(dx, dy) > MAX_PULL_IN:
            return None
    moved = translate(footprint, dx, dy)
    return (dx, dy) if moved.difference(inner).area < 1e-6 else None


def _repair_room(evidence: RoomEvidence) -> RoomOutput:
    """Keep the input room; pull objects poking through it back in, or grow it (see the module docstring)."""
    r = evidence.room
    assert r is not None
    floor = list(r.floor)
    walls = (
        [WallSpec(id=w.id, start=w.start, end=w.end, height=w.height) for w in r.walls]
        if r.walls
        else _walls_for(floor, r.ceiling_height)
    )
    poly = Polygon(floor)
    grown = poly.buffer(CONTAIN_TOLERANCE)
    shifts: list[ObjectShift] = []
    too_far: list[str] = []
    for o in evidence.objects:
        dz = 0.0
        if o.top > r.ceiling_height + CONTAIN_TOLERANCE and traits(o.category).placement != "floor":
            dz = r.ceiling_height - CEILING_GAP - o.top
        fp = o.polygon()
        dxy: tuple[float, float] = (0.0, 0.0)
        if not grown.contains(fp):
            found = _pull_in(poly, fp)
            if found is None:
                too_far.append(o.id)
                continue
            dxy = found
        if dxy != (0.0, 0.0) or dz < 0:
            what = []
            if dxy != (0.0, 0.0):
                what.append(f"{math.hypot(*dxy):.2f} m back inside the walls")
            if dz < 0:
                what.append(f"{-dz:.2f} m down, under the ceiling")
            shifts.append(
                ObjectShift(
                    object_id=o.id,
                    dx=round(dxy[0], 4),
                    dy=round(dxy[1], 4),
                    dz=round(dz, 4),
                    reason="moved " + " and ".join(what),
                )
            )
    note = "input room kept" + ("" if r.walls else "; walls completed from the floor polygon")
    ceiling = r.ceiling_height
    tallest_floor = max(
        (o.top for o in evidence.objects if traits(o.category).placement == "floor"), default=0.0
    )
    if tallest_floor > ceiling:
        ceiling = round(tallest_floor + 0.1, 3)
        note += f"; ceiling raised to {ceiling:.2f} m above the tallest furniture"
    if too_far:  # the input room is too small: grow it around everything (walls recomputed)
        items = _items(list(evidence.objects))
        grown_floor, _ = _fit(items, 0.0)
        union = Polygon(grown_floor).union(poly).envelope
        floor = [(round(x, 4), round(y, 4)) for x, y in list(union.exterior.coords)[:-1]]
        if Polygon(floor).exterior.is_ccw is False:
            floor.reverse()
        walls = _walls_for(floor, ceiling)
        note += "; room grown to enclose " + ", ".join(too_far[:8]) + (" ..." if len(too_far) > 8 else "")
    if shifts:
        note += f"; {len(shifts)} object(s) moved inside"
    return RoomOutput(
        floor=floor,
        walls=[w.model_copy(update={"height": ceiling}) if w.height < ceiling else w for w in walls],
        ceiling_height=ceiling,
        kept_input=not too_far,
        shifts=shifts,
        note=note[:400],
    )


def solve_room(evidence: RoomEvidence) -> RoomOutput:
    """The room rule solver (see the module docstring)."""
    if evidence.room is not None:
        return _repair_room(evidence)
    objs = evidence.objects
    items = _items(objs)
    ceiling = round(recovered_ceiling(items), 3)
    if not objs:
        floor = [(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)]
        return RoomOutput(
            floor=floor, walls=_walls_for(floor, ceiling), ceiling_height=ceiling, note="empty scene"
        )
    axis_floor, axis_area = _fit(items, 0.0)
    floor, yaw = axis_floor, 0.0
    dom = dominant_orientation(items)
    if abs(dom) > 1e-6:
        rot_floor, rot_area = _fit(items, dom)
        if rot_area < axis_area * 0.97:  # rotate only when clearly tighter
            floor, yaw = rot_floor, dom
    return RoomOutput(
        floor=floor,
        walls=_walls_for(floor, ceiling),
        ceiling_height=ceiling,
        yaw_deg=round(math.degrees(yaw), 3),
        note="rectangle fitted around the object footprints",
    )


def _wall_from(out: WallSpec, before: Wall | None) -> Wall:
    """The room agent's wall; one that stands where the input's wall of that id stood keeps the
    input's thickness and its doors and windows."""
    wall = Wall(id=out.id, start=out.start, end=out.end, height=out.height)
    if before is not None and math.dist(before.start, out.start) < 1e-3 and math.dist(before.end, out.end) < 1e-3:
        wall.thickness, wall.openings = before.thickness, list(before.openings)
    return wall


MIN_WALL_LENGTH = 0.3
"""Shortest wall (metres) a room may have; anything shorter is a degenerate reply."""
RING_GAP = 0.05
"""How far (metres) one wall's end may be from the next wall's start, and a wall from the floor's edge."""


Edge = tuple[tuple[float, float], tuple[float, float]]
"""A wall or floor edge: start and end (x, y), metres."""


def _given_edges(room: Room | None) -> list[Edge]:
    """The input room's walls and floor edges: a kept room may have walls shorter than
    :data:`MIN_WALL_LENGTH` (a 10 cm jog round a column, an edge drawn in short pieces)."""
    if room is None:
        return []
    floor = [(float(x), float(y)) for x, y in room.floor]
    edges = [(floor[i], floor[(i + 1) % len(floor)]) for i in range(len(floor))]
    return edges + [((float(w.start[0]), float(w.start[1])), (float(w.end[0]), float(w.end[1]))) for w in room.walls]


def _wall_ring_problems(output: RoomOutput, poly: Polygon, given: Sequence[Edge] = ()) -> list[str]:
    """The walls must form a closed, non-degenerate ring along the floor polygon's edge, with the
    room on each wall's left. No walls at all is fine: they are then built from the polygon.
    ``given``: the input room's edges (:func:`_given_edges`), which may be short."""
    walls = output.walls
    if not walls:
        return []
    problems: list[str] = []
    edge = poly.exterior
    seen: list[tuple[tuple[float, float], tuple[float, float]]] = []
    for w in walls:
        length = math.dist(w.start, w.end)
        if length < MIN_WALL_LENGTH and not any(
            math.dist(w.start, a) + math.dist(w.end, b) < RING_GAP for a, b in given
        ):
            problems.append(
                f"wall {w.id!r} is {length:.2f} m long; every wall runs along one edge of the floor "
                f"polygon, from one corner to the next (at least {MIN_WALL_LENGTH:g} m)"
            )
            continue
        if any(math.dist(w.start, a) + math.dist(w.end, b) < RING_GAP for a, b in seen):
            problems.append(f"wall {w.id!r} repeats another wall; give each edge of the floor polygon one wall")
        seen.append((w.start, w.end))
        off = max(edge.distance(Point(w.start)), edge.distance(Point(w.end)))
        if off > RING_GAP:
            problems.append(
                f"wall {w.id!r} lies {off:.2f} m off the floor polygon's edge; walls run along the polygon's edges"
            )
            continue
        mx, my = (w.start[0] + w.end[0]) / 2, (w.start[1] + w.end[1]) / 2
        nx, ny = -(w.end[1] - w.start[1]) / length, (w.end[0] - w.start[0]) / length
        if not poly.contains(Point(mx + 0.05 * nx, my + 0.05 * ny)):
            problems.append(
                f"wall {w.id!r} runs the wrong way; go from start to end with the room on the left "
                "(counter-clockwise around the floor)"
            )
    if problems:
        return problems
    covered = sum(math.dist(w.start, w.end) for w in walls)
    if covered < 0.95 * edge.length:
        problems.append(
            f"the walls cover {covered:.2f} m of the floor polygon's {edge.length:.2f} m edge; "
            "give every edge of the polygon a wall"
        )
    starts = [w.start for w in walls]
    for w in walls:
        if min(math.dist(w.end, s) for s in starts) > RING_GAP:
            problems.append(f"wall {w.id!r} ends where no wall starts; the walls must close a ring")
    return problems


def _extent_problems(output: RoomOutput, poly: Polygon, state: SceneState) -> list[str]:
    """A kept input room may grow but not shrink or move; a recovered one hugs the furniture."""
    scene = state.scene
    if scene.room is not None:
        given = Polygon(scene.room.floor)
        kept = given.intersection(poly).area / max(given.area, 1e-9)
        if kept < 0.95:
            return [
                f"the floor polygon covers only {kept:.0%} of the input room's floor; keep the input room "
                "(and only grow it to enclose objects that stand outside it)"
            ]
        return []
    facts = object_facts(scene)
    if not facts:
        return []
    fitted = Polygon(_fit(_items(facts), 0.0)[0]).area
    if poly.area > 3.0 * fitted + 4.0:
        return [
            f"the floor polygon ({poly.area:.1f} m²) is far larger than the furniture needs (about "
            f"{fitted:.1f} m²); put the walls just behind the furniture that stands against them"
        ]
    return []


class RoomAgent(FloorPlanImages, TaskAgent[SceneState, RoomEvidence, RoomOutput]):
    """Recovers (or completes) the room boundary, the walls and the ceiling height."""

    name: ClassVar[str] = "room"
    depends_on: ClassVar[tuple[str, ...]] = ()
    prompt: ClassVar[str] = "room"
    reply_tokens: ClassVar[tuple[int, int] | None] = (700, 25)
    prompt_omit: ClassVar[frozenset[str]] = frozenset({"center", "size", "parent", "relation", "bottom"})
    prompt_extra: ClassVar[frozenset[str]] = frozenset({"extent"})
    object_id_fields: ClassVar[tuple[str, ...]] = ("shifts.object_id",)

    def needed(self, summary: SceneSummary) -> Need:
        """Always, and every plan must have it: a tree needs a room."""
        return Need(True, "complete the input room's walls" if summary.has_room else "recover the room boundary", required=True)

    def gather(self, state: SceneState) -> RoomEvidence:
        return RoomEvidence(objects=object_facts(state.scene), room=room_facts(state.scene))

    def solve(self, evidence: RoomEvidence) -> RoomOutput:
        return solve_room(evidence)

    def answer_without_model(self, evidence: RoomEvidence) -> RoomOutput | None:
        """The kept input room when it already holds every object and has its walls and a ceiling
        above everything: there is nothing to decide, and copying a polygon is no model's job."""
        r = evidence.room
        if r is None or not r.walls:
            return None
        answer = solve_room(evidence)
        unchanged = answer.kept_input and not answer.shifts and answer.ceiling_height == r.ceiling_height
        return answer if unchanged else None

    def check(self, output: RoomOutput, state: SceneState) -> list[str]:
        problems: list[str] = []
        poly = Polygon(output.floor)
        if not poly.is_valid or poly.area < 0.5:
            return [f"the floor polygon is degenerate or self-intersecting (area {poly.area:.2f} m²)"]
        if not poly.exterior.is_ccw:
            problems.append(
                "the floor corners run clockwise; list them counter-clockwise seen from above (x right, y up)"
            )
        problems += _wall_ring_problems(output, poly, _given_edges(state.scene.room))
        problems += _extent_problems(output, poly, state)
        grown = poly.buffer(CONTAIN_TOLERANCE)
        shifts = {s.object_id: s for s in output.shifts}
        facts = object_facts(state.scene)
        for o in facts:
            sh = shifts.get(o.id)
            fp = translate(o.polygon(), sh.dx, sh.dy) if sh else o.polygon()
            if not grown.contains(fp):
                problems.append(
                    f"object {o.id!r} ({o.category}) lies partly outside the floor polygon; move it inside "
                    "with a shift (at most 0.5 m) or enlarge the floor polygon"
                )
            top = o.top + (sh.dz if sh else 0.0)
            if traits(o.category).placement != "floor" and top > output.ceiling_height + CONTAIN_TOLERANCE:
                problems.append(
                    f"object {o.id!r} ({o.category}) reaches {top:.2f} m, above the ceiling; lower it with a shift dz"
                )
        ids = [w.id for w in output.walls]
        if len(set(ids)) != len(ids):
            problems.append("wall ids must be unique")
        object_ids = {o.id for o in state.scene.objects}
        for wid in ids:
            if wid in object_ids or wid in ("floor", "ceiling"):
                problems.append(f"wall id {wid!r} collides with an object or anchor id")
        used = {r.parent for r in state.scene.relations} | {
            c.anchor_id for k in state.scene.constraints for c in (k.anchor_a, k.anchor_b)
        }
        old_walls = {w.id for w in state.scene.room.walls} if state.scene.room else set()
        for wid in sorted((used & old_walls) - set(ids)):
            problems.append(f"wall {wid!r} is referenced by the scene and must be kept")
        tallest = max(
            (
                o.top + (shifts[o.id].dz if o.id in shifts else 0.0)
                for o in facts
                if traits(o.category).placement != "ceiling"
            ),
            default=0.0,
        )
        if output.ceiling_height < tallest - 0.05:
            problems.append(
                f"ceiling height {output.ceiling_height:.2f} m is below the tallest object ({tallest:.2f} m)"
            )
        return problems

    def apply(self, output: RoomOutput, state: SceneState) -> None:
        before = state.scene.room
        room_id = before.id if before is not None else "room"
        kept = {w.id: w for w in before.walls} if before is not None else {}
        room = Room(id=room_id, floor=list(output.floor), ceiling_height=output.ceiling_height)
        room.walls = [_wall_from(w, kept.get(w.id)) for w in output.walls]
        if not room.walls:
            room = Room.from_polygon(room.floor, ceiling_height=output.ceiling_height, room_id=room_id)
        scene = replace_scene(state.scene, room=room)
        if output.shifts:
            translate_objects(scene, {sh.object_id: (sh.dx, sh.dy, sh.dz) for sh in output.shifts})
            for sh in output.shifts:
                scene.provenance.notes.append(f"room: {sh.object_id} {sh.reason}")
        if not output.kept_input and state.scene.room is not None:
            scene.provenance.notes.append(f"room: {output.note}")
        state.scene = scene

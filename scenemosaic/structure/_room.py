"""Room and walls: a canonical floor polygon, wall primitives and a ceiling height.

Rule solver: when the scene already has a room it is kept (walls are completed from the
polygon edges if missing). Otherwise the room is the tightest rectangle around every object
footprint, tried axis-aligned and at the scene's dominant heading, with a margin on each side;
a side whose outermost object is a wall-type piece of furniture (wardrobe, bed, sofa...) with
its back to that side is snapped to the object with only a hairline gap.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import Polygon

from scenemosaic.agents import MAX_ITEMS, AgentOutput, SceneState, TaskAgent
from scenemosaic.scene import Room, Wall, traits
from scenemosaic.structure._facts import ObjectFacts, RoomFacts, object_facts, replace_scene, room_facts
from scenemosaic.structure._views import FloorPlanImages

__all__ = ["ROOM_MARGIN", "RoomAgent", "RoomEvidence", "RoomOutput", "WallSpec"]

ROOM_MARGIN = 0.25
"""Free space (metres) left between the outermost footprint and a wall no furniture backs onto."""
SNAP_GAP = 0.02
"""Gap (metres) left between a wall-backed piece of furniture and the wall it is snapped to."""
DEFAULT_CEILING = 2.8
"""Ceiling height (metres) used when no object reaches higher."""
CONTAIN_TOLERANCE = 0.02
"""How far (metres) a footprint may poke out of the floor polygon and still count as inside."""


class WallSpec(AgentOutput):
    """One wall of the recovered room (interior on the left of start -> end)."""

    id: str = Field(max_length=64, pattern=r"^[A-Za-z0-9_.\-]+$")
    start: tuple[float, float]
    end: tuple[float, float]
    height: float = Field(gt=0, le=20)


class RoomOutput(AgentOutput):
    """The room boundary the agent settled on."""

    floor: list[tuple[float, float]] = Field(
        min_length=3, max_length=64, description="Counter-clockwise polygon."
    )
    walls: list[WallSpec] = Field(default_factory=list, max_length=64)
    ceiling_height: float = Field(gt=0, le=20)
    kept_input: bool = Field(default=False, description="True when the input room was kept.")
    yaw_deg: float = Field(default=0.0, description="Heading of the fitted rectangle.")
    note: str = Field(default="", max_length=400)


class RoomEvidence(BaseModel):
    """Objects and the input room, if any."""

    model_config = ConfigDict(extra="forbid")
    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    room: RoomFacts | None = None


def _dominant_yaw(objects: list[ObjectFacts]) -> float:
    """Heading modulo 90 degrees carrying the most footprint area (radians in [0, pi/2))."""
    votes: dict[int, float] = {}
    for o in objects:
        bucket = round(o.yaw_deg % 90.0) % 90
        votes[bucket] = votes.get(bucket, 0.0) + max(o.area, 1e-3)
    if not votes:
        return 0.0
    best = max(sorted(votes), key=lambda b: votes[b])
    return math.radians(best)


def _fit(objects: list[ObjectFacts], yaw: float, ceiling: float) -> tuple[list[tuple[float, float]], float]:
    """Rectangle (CCW corners) around the footprints in a frame rotated by ``yaw``; also its area."""
    c, s = math.cos(yaw), math.sin(yaw)
    to_local = np.array([[c, s], [-s, c]])  # world -> rotated frame
    lo = np.array([np.inf, np.inf])
    hi = -lo
    per_obj: list[tuple[ObjectFacts, np.ndarray, np.ndarray]] = []
    for o in objects:
        pts = np.asarray(o.footprint) @ to_local.T
        a, b = pts.min(axis=0), pts.max(axis=0)
        per_obj.append((o, a, b))
        lo, hi = np.minimum(lo, a), np.maximum(hi, b)
    sides = [lo[0], lo[1], hi[0], hi[1]]  # -x, -y, +x, +y
    outward_dirs = [np.array([-1.0, 0]), np.array([0, -1.0]), np.array([1.0, 0]), np.array([0, 1.0])]
    for k in range(4):
        axis, sign = k % 2, (-1.0 if k < 2 else 1.0)
        extreme = sides[k]
        margin = ROOM_MARGIN
        for o, a, b in per_obj:
            edge = a[axis] if sign < 0 else b[axis]
            if abs(edge - extreme) > 0.05 or not traits(o.category).against_wall:
                continue
            yaw_o = math.radians(o.yaw_deg)
            back_world = -np.array([math.sin(yaw_o), -math.cos(yaw_o)])
            back_local = to_local @ back_world
            if float(back_local @ outward_dirs[k]) > math.cos(math.radians(30)):
                margin = SNAP_GAP
                break
        sides[k] = extreme + sign * margin
    x0, y0, x1, y1 = sides
    local = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    to_world = to_local.T
    corners = [tuple(float(round(v, 4)) for v in to_world @ np.array(p)) for p in local]
    return [(p[0], p[1]) for p in corners], float((x1 - x0) * (y1 - y0))


def _walls_for(floor: list[tuple[float, float]], height: float) -> list[WallSpec]:
    n = len(floor)
    return [WallSpec(id=f"wall_{i}", start=floor[i], end=floor[(i + 1) % n], height=height) for i in range(n)]


def solve_room(evidence: RoomEvidence) -> RoomOutput:
    """The room rule solver (see the module docstring)."""
    if evidence.room is not None:
        r = evidence.room
        walls = (
            [WallSpec(id=w.id, start=w.start, end=w.end, height=w.height) for w in r.walls]
            if r.walls
            else _walls_for(list(r.floor), r.ceiling_height)
        )
        return RoomOutput(
            floor=list(r.floor),
            walls=walls,
            ceiling_height=r.ceiling_height,
            kept_input=True,
            note="input room kept" + ("" if r.walls else "; walls completed from the floor polygon"),
        )
    objs = evidence.objects
    top = max((o.top for o in objs), default=0.0)
    ceiling = max(DEFAULT_CEILING, round(top, 3))
    if not objs:
        floor = [(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)]
        return RoomOutput(
            floor=floor, walls=_walls_for(floor, ceiling), ceiling_height=ceiling, note="empty scene"
        )
    axis_floor, axis_area = _fit(objs, 0.0, ceiling)
    floor, yaw = axis_floor, 0.0
    dom = _dominant_yaw(objs)
    if dom > 1e-6:
        rot_floor, rot_area = _fit(objs, dom, ceiling)
        if rot_area < axis_area * 0.97:  # rotate only when clearly tighter
            floor, yaw = rot_floor, dom
    return RoomOutput(
        floor=floor,
        walls=_walls_for(floor, ceiling),
        ceiling_height=ceiling,
        yaw_deg=round(math.degrees(yaw), 3),
        note="rectangle fitted around the object footprints",
    )


class RoomAgent(FloorPlanImages, TaskAgent[RoomEvidence, RoomOutput]):
    """Recovers (or completes) the room boundary, the walls and the ceiling height."""

    name: ClassVar[str] = "room"
    depends_on: ClassVar[tuple[str, ...]] = ()
    prompt: ClassVar[str] = "room"
    output_type: ClassVar[type[BaseModel]] = RoomOutput

    def gather(self, state: SceneState) -> RoomEvidence:
        return RoomEvidence(objects=object_facts(state.scene), room=room_facts(state.scene))

    def solve(self, evidence: RoomEvidence) -> RoomOutput:
        return solve_room(evidence)

    def check(self, output: RoomOutput, state: SceneState) -> list[str]:
        problems: list[str] = []
        poly = Polygon(output.floor)
        if not poly.is_valid or poly.area < 0.5:
            return [f"the floor polygon is degenerate or self-intersecting (area {poly.area:.2f} m²)"]
        grown = poly.buffer(CONTAIN_TOLERANCE)
        for o in object_facts(state.scene):
            if not grown.contains(o.polygon()):
                problems.append(f"object {o.id!r} ({o.category}) lies partly outside the floor polygon")
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
            (o.top for o in object_facts(state.scene) if traits(o.category).placement != "ceiling"),
            default=0.0,
        )
        if output.ceiling_height < tallest - 0.05:
            problems.append(
                f"ceiling height {output.ceiling_height:.2f} m is below the tallest object ({tallest:.2f} m)"
            )
        return problems

    def apply(self, output: RoomOutput, state: SceneState) -> None:
        room = Room(floor=list(output.floor), ceiling_height=output.ceiling_height)
        room.walls = [Wall(id=w.id, start=w.start, end=w.end, height=w.height) for w in output.walls]
        if not room.walls:
            room = Room.from_polygon(room.floor, ceiling_height=output.ceiling_height)
        state.scene = replace_scene(state.scene, room=room)

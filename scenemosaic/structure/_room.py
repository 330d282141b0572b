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
from scenemosaic.scene import (
    ROOM_MARGIN,
    FootprintItem,
    Room,
    Wall,
    dominant_orientation,
    recovered_ceiling,
    room_rectangle,
    traits,
)
from scenemosaic.structure._facts import ObjectFacts, RoomFacts, object_facts, replace_scene, room_facts
from scenemosaic.structure._views import FloorPlanImages

__all__ = ["RoomAgent", "RoomEvidence", "RoomOutput", "WallSpec"]

SNAP_GAP = 0.02
"""Gap (metres) left between a wall-backed piece of furniture and the wall it is snapped to."""
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
    floor, area = room_rectangle(items, yaw, margin=ROOM_MARGIN, snap_gap=SNAP_GAP)
    return [(round(x, 4), round(y, 4)) for x, y in floor], area


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

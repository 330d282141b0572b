"""Wall attachment: which objects stand flush against which wall, which are wall-mounted, and how far.

Rule solver: for every object within :data:`WALL_REACH` of a wall (measured from the wall
line to the nearest footprint corner, only walls whose span the object faces), report the
nearest wall, the gap, and which side of the object faces it (back, front or side, within
30°). A floor object is *flush* when its back faces the wall and the gap is under
:data:`FLUSH_GAP`, or under :data:`WALL_FURNITURE_GAP` for furniture that belongs against a
wall (beds, wardrobes, shelves: a prior often leaves them a few decimetres off it); an object
is *mounted* when its support parent already is that wall.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar, Literal

import numpy as np
from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent
from scenemosaic.scene import FLOOR, Relation, traits
from scenemosaic.structure._facts import (
    CHUNK_OBJECTS,
    ObjectFacts,
    RoomFacts,
    along_wall,
    chunk_ids,
    object_facts,
    outward,
    replace_scene,
    room_facts,
    wall_gap,
    wall_length,
)
from scenemosaic.structure._views import FloorPlanImages

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = [
    "FLUSH_GAP",
    "WALL_FURNITURE_GAP",
    "WallAttachmentAgent",
    "WallEvidence",
    "WallItem",
    "WallOutput",
    "facing_side",
]

FLUSH_GAP = 0.15
"""Largest gap (metres) between an object's back and a wall for it to count as flush."""
WALL_FURNITURE_GAP = 0.3
"""Largest gap (metres) behind furniture that belongs against a wall (``traits().against_wall``)
for it to be marked as standing against that wall; physics then slides it flush."""
WALL_REACH = 0.6
"""Objects farther than this (metres) from every wall are not reported."""
FACING_COS = math.cos(math.radians(30))
"""An object side 'faces' a wall when its normal is within 30° of the wall's outward normal."""


class WallItem(AgentOutput):
    """One object's relation to its nearest wall."""

    object_id: str = Field(max_length=64)
    wall_id: str = Field(max_length=64)
    distance: float = Field(ge=0, le=50, description="Gap between the wall and the footprint, metres.")
    facing: Literal["back", "front", "side"] = Field(description="Which side of the object faces the wall.")
    flush: bool = False
    mounted: bool = False


class WallOutput(AgentOutput):
    """Wall relations of the objects near walls."""

    items: list[WallItem] = Field(default_factory=list, max_length=MAX_ITEMS)


class WallEvidence(AgentOutput):
    """Objects (with their current parents) and the room's walls."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    room: RoomFacts | None = None


def facing_side(o: ObjectFacts, wall_out: np.ndarray) -> Literal["back", "front", "side"]:  # type: ignore[type-arg]
    """Which side of ``o`` faces a wall with outward normal ``wall_out``."""
    f = float(o.front @ wall_out)
    if f > FACING_COS:
        return "front"
    if -f > FACING_COS:
        return "back"
    return "side"


def wall_item(o: ObjectFacts, room: RoomFacts) -> WallItem | None:
    """``o``'s relation to its nearest wall (see the module docstring), or ``None`` when it is
    out of reach of every wall or hangs from the ceiling."""
    if not room.walls or traits(o.category).placement == "ceiling" or o.parent == "ceiling":
        return None
    facing = [w for w in room.walls if -0.2 <= along_wall(w, o.center) <= wall_length(w) + 0.2] or list(room.walls)
    # nearest wall; within 0.1 m of a tie, prefer the wall the object's back is turned to
    w = min(facing, key=lambda w: abs(wall_gap(w, o)) - (0.1 if facing_side(o, outward(w)) == "back" else 0.0))
    gap = wall_gap(w, o)
    if gap > WALL_REACH:
        return None
    side = facing_side(o, outward(w))
    mounted = o.parent == w.id
    reach = WALL_FURNITURE_GAP if traits(o.category).against_wall else FLUSH_GAP
    flush = (not mounted) and o.parent in (FLOOR, None) and gap < reach and side == "back"
    return WallItem(
        object_id=o.id, wall_id=w.id, distance=round(max(gap, 0.0), 3), facing=side, flush=flush, mounted=mounted
    )


def flush_walls(objects: list[ObjectFacts], room: RoomFacts | None) -> dict[str, str]:
    """Object id -> the wall it stands flush against, by the rule of :func:`wall_item` (agents that
    run beside the walls agent read it from the geometry instead of waiting for its relations)."""
    if room is None:
        return {}
    out: dict[str, str] = {}
    for o in objects:
        item = wall_item(o, room)
        if item is not None and item.flush:
            out[o.id] = item.wall_id
    return out


def solve_walls(evidence: WallEvidence) -> WallOutput:
    """The wall-attachment rule solver (see the module docstring)."""
    room = evidence.room
    if room is None or not room.walls:
        return WallOutput()
    items = [item for o in evidence.objects if (item := wall_item(o, room)) is not None]
    return WallOutput(items=items)


class WallAttachmentAgent(FloorPlanImages, TaskAgent[SceneState, WallEvidence, WallOutput]):
    """Reports which objects are flush against or mounted on which wall, with their distances."""

    name: ClassVar[str] = "walls"
    depends_on: ClassVar[tuple[str, ...]] = ("room", "support")
    prompt: ClassVar[str] = "walls"
    reply_tokens: ClassVar[tuple[int, int] | None] = (200, 40)
    chunk_size: ClassVar[int | None] = CHUNK_OBJECTS
    items_field: ClassVar[str | None] = "items"
    object_id_fields: ClassVar[tuple[str, ...]] = ("items.object_id",)
    prompt_omit: ClassVar[frozenset[str]] = frozenset({"bottom", "top", "relation"})

    def needed(self, summary: SceneSummary) -> Need:
        """When something could stand against or hang on a wall, or the input has walls."""
        run = bool(summary.wall_candidates) or summary.has_walls
        why = "wall-type furniture or input walls present" if run else "nothing stands against or hangs on a wall"
        return Need(run, why, evidence=tuple(summary.wall_candidates), insist="wall furniture is present")

    def gather(self, state: SceneState) -> WallEvidence:
        return WallEvidence(objects=object_facts(state.scene), room=room_facts(state.scene))

    def solve(self, evidence: WallEvidence) -> WallOutput:
        return solve_walls(evidence)

    def split(self, evidence: WallEvidence, size: int) -> list[tuple[list[str], WallEvidence]]:
        """Chunks of objects, each with the room's walls."""
        return [
            (ids, WallEvidence(objects=[o for o in evidence.objects if o.id in set(ids)], room=evidence.room))
            for ids in chunk_ids(evidence.objects, size)
        ]

    def check(self, output: WallOutput, state: SceneState) -> list[str]:
        scene = state.scene
        objects = {o.id for o in scene.objects}
        walls = {w.id for w in scene.room.walls} if scene.room else set()
        problems: list[str] = []
        for i in output.items:
            if i.wall_id not in walls:
                problems.append(
                    f"wall id {i.wall_id!r} does not exist (walls: {', '.join(sorted(walls)) or 'none'})"
                )
            if i.flush and i.mounted:
                problems.append(f"object {i.object_id!r} cannot be both flush on the floor and wall-mounted")
            if (
                i.mounted
                and i.object_id in objects
                and traits(scene.get(i.object_id).category).placement == "floor"
            ):
                problems.append(f"object {i.object_id!r} is floor furniture and cannot be wall-mounted")
            elif i.mounted and i.object_id in objects:
                rel = scene.support_of(i.object_id)
                if rel is None or rel.parent != i.wall_id:
                    problems.append(
                        f"object {i.object_id!r} hangs from {rel.parent if rel else 'nothing'!r}, not {i.wall_id!r}: "
                        "mark it mounted only on the wall that is already its parent"
                    )
        return problems

    def apply(self, output: WallOutput, state: SceneState) -> None:
        listed = {i.object_id for i in output.items}
        mounted = {i.object_id: i for i in output.items if i.mounted}
        rels: list[Relation] = []
        for r in state.scene.relations:
            if r.kind == "against" and r.child in listed:
                continue
            if r.is_support and r.child in mounted:
                continue
            rels.append(r)
        for i in output.items:
            if i.mounted or i.flush:  # mounted: the wall supports it; flush: it only stands against it
                rels.append(
                    Relation(
                        kind="attach" if i.mounted else "against",
                        child=i.object_id,
                        parent=i.wall_id,
                        distance=i.distance,
                        source=self.name,
                    )
                )
        state.scene = replace_scene(state.scene, relations=rels)

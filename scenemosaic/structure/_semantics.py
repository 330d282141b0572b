"""Semantic refinement: consistent categories, short descriptions, and a front-direction check.

Rule solver:

* categories are normalized (``"Dining Chair 2"`` -> ``dining_chair``);
* a description names the category, its size and where it stands;
* a piece of furniture that belongs against a wall (wardrobe, TV stand, bookshelf, bed...)
  whose *front* faces the nearest wall from close by is turned 180° so it faces the room;
* a chair next to a table or desk should face it: a chair whose front is turned more than
  90° away from the way to the table (its back, not its seat, toward the table) is turned to
  face the table's nearest edge squarely; a chair turned less than that is left alone, since a
  chair pulled out at an angle is often deliberate.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from pydantic import Field
from shapely.geometry import Point

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent
from scenemosaic.scene import (
    Pose,
    Scene,
    SceneObject,
    normalize_category,
    quat_from_yaw,
    quat_multiply,
    traits,
)
from scenemosaic.structure._facts import (
    CHUNK_OBJECTS,
    ObjectFacts,
    chunk_ids,
    object_facts,
    outward,
    replace_scene,
    room_facts,
    wall_gap,
)
from scenemosaic.structure._views import FloorPlanImages
from scenemosaic.structure._walls import facing_side, flush_walls

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = [
    "SemanticItem",
    "SemanticsAgent",
    "SemanticsEvidence",
    "SemanticsOutput",
    "front_problem",
    "rotate_subtree",
    "same_kind",
]

WALL_FACING_REACH = 0.3
"""A wall-type object whose front is this close (metres) to a wall is facing the wall."""
TABLE_REACH = 0.8
"""A chair this close (metres) to a table or desk footprint belongs to it."""
AWAY_DEG = 90.0
"""A chair whose front is more than this many degrees off the way to its table is turned to face it."""


class SemanticItem(AgentOutput):
    """One object's normalized category, description and front check."""

    object_id: str = Field(max_length=64)
    category: str = Field(min_length=1, max_length=64, pattern=r"^[a-z0-9_]+$")
    description: str = Field(default="", max_length=300)
    front_ok: bool = True
    yaw_fix_deg: float = Field(
        default=0.0,
        ge=-180.0,
        le=180.0,
        description="Turn to apply about the object's centre, degrees counter-clockwise; 0 when front_ok.",
    )
    note: str = Field(default="", max_length=200)


class SemanticsOutput(AgentOutput):
    """Per-object semantics."""

    objects: list[SemanticItem] = Field(max_length=MAX_ITEMS)


class FrontFacts(AgentOutput):
    """Facts behind one object's front check."""

    id: str
    wall_id: str | None = None
    wall_gap: float | None = None
    wall_facing: Literal["back", "front", "side"] | None = None
    table_id: str | None = None
    table_distance: float | None = None
    table_angle_deg: float | None = Field(
        default=None, description="Angle between the front and the way to the table."
    )
    table_turn_deg: float | None = Field(
        default=None,
        description="Counter-clockwise turn that makes the front face the table's nearest edge squarely.",
    )
    against_wall: bool | None = None


class SemanticsEvidence(AgentOutput):
    """Objects plus the facts of each front check."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    fronts: list[FrontFacts] = Field(max_length=MAX_ITEMS)


def _front_facts(scene: Scene, objs: list[ObjectFacts]) -> list[FrontFacts]:
    room = room_facts(scene)
    against = set(flush_walls(objs, room))  # from the geometry: this agent runs beside the walls agent
    tables = [o for o in objs if traits(o.category).table]
    out: list[FrontFacts] = []
    for o in objs:
        f: dict[str, object] = {"id": o.id, "against_wall": o.id in against}
        if room is not None and room.walls:
            w = min(
                room.walls,
                key=lambda w: abs(wall_gap(w, o)) - (0.1 if facing_side(o, outward(w)) != "side" else 0.0),
            )
            f.update(wall_id=w.id, wall_gap=round(wall_gap(w, o), 3), wall_facing=facing_side(o, outward(w)))
        if traits(o.category).seat and tables:
            t = min(tables, key=lambda t: t.polygon().distance(Point(o.center)))
            dist = float(t.polygon().distance(Point(o.center)))
            near = t.polygon().exterior.interpolate(t.polygon().exterior.project(Point(o.center)))
            way = np.array([near.x - o.center[0], near.y - o.center[1]])
            if (
                dist < 1e-6 or float(np.linalg.norm(way)) < 1e-6
            ):  # chair centre over the table: aim at its centre
                way = np.subtract(t.center, o.center)
            norm = float(np.linalg.norm(way))
            angle = (
                math.degrees(math.acos(max(-1.0, min(1.0, float(o.front @ way) / norm))))
                if norm > 1e-6
                else 0.0
            )
            f.update(
                table_id=t.id,
                table_distance=round(dist, 3),
                table_angle_deg=round(angle, 1),
                table_turn_deg=round(_turn_to_edge(o, t), 1),
            )
        out.append(FrontFacts.model_validate(f))
    return out


def _turn_to_edge(seat: ObjectFacts, table: ObjectFacts) -> float:
    """Signed turn (degrees, counter-clockwise) that points ``seat``'s front squarely at the
    edge of ``table``'s footprint nearest to it (against that edge's outward normal)."""
    corners = np.asarray(table.footprint, dtype=np.float64)
    centre = np.asarray(seat.center, dtype=np.float64)
    best: tuple[float, np.ndarray[Any, np.dtype[np.float64]]] | None = None
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        edge = b - a
        length = float(np.linalg.norm(edge))
        if length < 1e-9:
            continue
        t = float(np.clip((centre - a) @ edge / length**2, 0.0, 1.0))
        dist = float(np.linalg.norm(centre - (a + t * edge)))
        if best is None or dist < best[0]:
            best = (dist, np.array([edge[1], -edge[0]]) / length)  # outward normal of a CCW polygon
    if best is None:
        return 0.0
    want = -best[1]
    f = seat.front
    return math.degrees(math.atan2(float(f[0] * want[1] - f[1] * want[0]), float(f @ want)))


def _describe(o: ObjectFacts) -> str:
    w, d, h = o.size
    where = {None: "", "floor": " on the floor", "ceiling": " hanging from the ceiling"}.get(o.parent, "")
    if o.parent and o.parent.startswith("wall"):
        where = f" mounted on {o.parent}"
    elif o.parent not in (None, "floor", "ceiling"):
        where = f" {'inside' if o.relation == 'contain' else 'on'} {o.parent}"
    return f"{normalize_category(o.category).replace('_', ' ')}, {w:.2f} x {d:.2f} x {h:.2f} m{where}"


def same_kind(old: str, new: str) -> bool:
    """Whether ``new`` names the same kind of thing as ``old``: the same normalized category, or a
    more general or more specific name sharing a word (``work_desk`` -> ``desk``), never another
    thing (``pendant_lamp`` -> ``double_bed``)."""
    a, b = normalize_category(old), normalize_category(new)
    return a == b or bool(set(a.split("_")) & set(b.split("_")))


def front_problem(category: str, f: FrontFacts | None) -> Literal["faces_wall", "seat_away"] | None:
    """What is wrong with an object's front by the evidence, if anything: wall furniture whose
    front is turned to the wall right behind it, or a seat with its back to its table."""
    if f is None:
        return None
    t = traits(category)
    if t.against_wall and f.wall_facing == "front" and (f.wall_gap or 0.0) < WALL_FACING_REACH:
        return "faces_wall"
    if (
        t.seat
        and f.table_angle_deg is not None
        and f.table_angle_deg > AWAY_DEG
        and (f.table_distance or 0.0) < TABLE_REACH
    ):
        return "seat_away"
    return None


def solve_semantics(evidence: SemanticsEvidence) -> SemanticsOutput:
    """The semantics rule solver (see the module docstring)."""
    fronts = {f.id: f for f in evidence.fronts}
    items: list[SemanticItem] = []
    for o in evidence.objects:
        f = fronts.get(o.id)
        ok, fix, note = True, 0.0, ""
        problem = front_problem(o.category, f)
        if problem == "faces_wall" and f is not None:
            ok, fix, note = False, 180.0, f"front faced {f.wall_id}; turned to face the room"
        elif problem == "seat_away" and f is not None:
            ok, note = False, f"faces away from {f.table_id} by {f.table_angle_deg:.0f}°"
            if not f.against_wall and f.table_turn_deg is not None:
                fix = f.table_turn_deg
                note += f"; turned {fix:+.0f}° to face it"
        items.append(
            SemanticItem(
                object_id=o.id,
                category=normalize_category(o.category),
                description=_describe(o),
                front_ok=ok,
                yaw_fix_deg=fix,
                note=note,
            )
        )
    return SemanticsOutput(objects=items)


def rotate_subtree(scene: Scene, object_id: str, yaw_deg: float) -> list[SceneObject]:
    """Objects with ``object_id`` and everything it carries turned ``yaw_deg`` about its centre."""
    if yaw_deg == 0:
        return list(scene.objects)
    root = scene.get(object_id)
    moved = {object_id}
    frontier = [object_id]
    while frontier:
        kids = scene.children_of(frontier.pop())
        frontier.extend(k for k in kids if k not in moved)
        moved |= set(kids)
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    cx, cy = root.pose.position[0], root.pose.position[1]
    q = quat_from_yaw(math.radians(yaw_deg))
    out: list[SceneObject] = []
    for o in scene.objects:
        if o.id not in moved:
            out.append(o)
            continue
        x, y, z = o.pose.position
        dx, dy = x - cx, y - cy
        pos = (cx + c * dx - s * dy, cy + s * dx + c * dy, z)
        pose = Pose(position=pos, quaternion=quat_multiply(q, o.pose.quaternion), scale=o.pose.scale)
        out.append(o.model_copy(update={"pose": pose}))
    return out


class SemanticsAgent(FloorPlanImages, TaskAgent[SceneState, SemanticsEvidence, SemanticsOutput]):
    """Normalizes categories, writes descriptions and checks each object's front direction."""

    name: ClassVar[str] = "semantics"
    depends_on: ClassVar[tuple[str, ...]] = ("room", "support")
    prompt: ClassVar[str] = "semantics"
    reply_tokens: ClassVar[tuple[int, int] | None] = (200, 70)
    chunk_size: ClassVar[int | None] = CHUNK_OBJECTS
    items_field: ClassVar[str | None] = "objects"
    object_id_fields: ClassVar[tuple[str, ...]] = ("objects.object_id",)
    prompt_omit: ClassVar[frozenset[str]] = frozenset({"bottom", "top", "relation"})

    def needed(self, summary: SceneSummary) -> Need:
        """Always (a plan may leave it out)."""
        del summary
        return Need(True, "normalize categories and check fronts")

    def gather(self, state: SceneState) -> SemanticsEvidence:
        objs = object_facts(state.scene)
        return SemanticsEvidence(objects=objs, fronts=_front_facts(state.scene, objs))

    def solve(self, evidence: SemanticsEvidence) -> SemanticsOutput:
        return solve_semantics(evidence)

    def split(self, evidence: SemanticsEvidence, size: int) -> list[tuple[list[str], SemanticsEvidence]]:
        """Chunks of objects with their front facts, each shown with the tables its seats face."""
        out: list[tuple[list[str], SemanticsEvidence]] = []
        for ids in chunk_ids(evidence.objects, size):
            mine = set(ids)
            fronts = [f for f in evidence.fronts if f.id in mine]
            shown = mine | {f.table_id for f in fronts if f.table_id}
            out.append(
                (ids, SemanticsEvidence(objects=[o for o in evidence.objects if o.id in shown], fronts=fronts))
            )
        return out

    def check(self, output: SemanticsOutput, state: SceneState) -> list[str]:
        cats = {o.id: o.category for o in state.scene.objects}
        problems: list[str] = []
        for item in output.objects:
            current = cats.get(item.object_id)
            if current is not None and not same_kind(current, item.category):
                problems.append(
                    f"{item.object_id!r} is a {normalize_category(current)}, not a {item.category}: keep its "
                    f"category (a spelling or a more general name of the same thing, e.g. {normalize_category(current)!r})"
                )
            if item.front_ok and abs(item.yaw_fix_deg) > 1e-9:
                problems.append(
                    f"{item.object_id!r}: front_ok is true but yaw_fix_deg is {item.yaw_fix_deg:g}; "
                    "a turn is only given for a front that is wrong (set yaw_fix_deg to 0 or front_ok to false)"
                )
        problems += self._turn_problems(output, state)
        return problems

    def _turn_problems(self, output: SemanticsOutput, state: SceneState) -> list[str]:
        """Turns only where the evidence shows a wrong front, and none that faces wall furniture into a wall."""
        scene = state.scene
        objs = {o.id: o for o in object_facts(scene)}
        fronts = {f.id: f for f in _front_facts(scene, list(objs.values()))}
        problems: list[str] = []
        for item in output.objects:
            if abs(item.yaw_fix_deg) < 1e-9 or item.object_id not in objs:
                continue
            o = objs[item.object_id]
            if front_problem(o.category, fronts.get(o.id)) is None:
                problems.append(
                    f"{item.object_id!r}: the evidence shows nothing wrong with its front (not wall furniture "
                    "facing its wall, not a seat with its back to its table); set yaw_fix_deg to 0"
                )
                continue
            turned = o.model_copy(update={"yaw_deg": o.yaw_deg + item.yaw_fix_deg})
            after = _front_facts(scene, [turned, *(v for k, v in objs.items() if k != o.id)])[0]
            if traits(o.category).against_wall and front_problem(o.category, after) == "faces_wall":
                problems.append(
                    f"{item.object_id!r}: turning it {item.yaw_fix_deg:g}° points its front into {after.wall_id}; "
                    "wall furniture faces into the room"
                )
        return problems

    def apply(self, output: SemanticsOutput, state: SceneState) -> None:
        scene = state.scene
        for item in output.objects:
            if item.yaw_fix_deg:
                scene = replace_scene(
                    scene, objects=rotate_subtree(scene, item.object_id, float(item.yaw_fix_deg))
                )
        by_id = {i.object_id: i for i in output.objects}
        objects = [
            o.model_copy(update={"category": by_id[o.id].category, "description": by_id[o.id].description})
            if o.id in by_id
            else o
            for o in scene.objects
        ]
        notes = [f"semantics: {i.object_id}: {i.note}" for i in output.objects if i.note]
        prov = scene.provenance.model_copy(update={"notes": [*scene.provenance.notes, *notes]})
        state.scene = replace_scene(scene, objects=objects, provenance=prov)

"""Structured evidence shared by the structuring agents, and small scene helpers.

Every agent's evidence is built from :class:`ObjectFacts` (one per object: category, box,
heading, current parent) and :class:`RoomFacts`. Rule solvers read only these facts, never
the prose prompt, so the offline path and the VLM path see the same information.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import Point, Polygon

from scenemosaic.agents import MAX_ITEMS, AgentOutput
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    Pose,
    Relation,
    Scene,
    SceneObject,
    normalize_category,
    rigid_moves,
)

__all__ = [
    "CHUNK_OBJECTS",
    "MAX_ITEMS",
    "AgentOutput",
    "ObjectFacts",
    "RoomFacts",
    "WallFacts",
    "chunk_ids",
    "object_facts",
    "parent_cycles",
    "replace_scene",
    "room_facts",
    "translate_objects",
]

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]


class _Facts(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd)


class ObjectFacts(_Facts):
    """One object as the agents see it (metres, degrees, world Z-up)."""

    id: str = Field(description="Object id; answers refer to objects only by these ids.")
    category: str = Field(description="Normalized category.")
    label: str | None = Field(
        default=None, description="Category as the input spelled it, when it differs from category."
    )
    center: Vec2 = Field(description="Centre of the object's box seen from above: x,y (world, Z up).")
    yaw_deg: float = Field(
        description="Heading about Z: 0 = the object's front faces -y, 90 = +x, 180 = +y, -90 = -x (counter-clockwise)."
    )
    size: Vec3 = Field(
        description="Box size in the object's own frame: width (left-right), depth (back-front), height."
    )
    bottom: float = Field(description="Lowest point of the box, z.")
    top: float = Field(description="Highest point of the box, z.")
    footprint: list[Vec2] = Field(
        description="Box corners seen from above, counter-clockwise (follows from center, size, yaw_deg).",
        json_schema_extra={"prompt": False},
    )
    extent: tuple[float, float, float, float] = Field(
        default=(0.0, 0.0, 0.0, 0.0),
        description="What the box covers seen from above: x_min,y_min,x_max,y_max.",
        json_schema_extra={"prompt": False},
    )
    parent: str | None = Field(
        default=None, description="What currently supports it: floor, ceiling, a wall id or an object id."
    )
    relation: str | None = Field(
        default=None, description="How it is supported: attach (rests on, hangs from) or contain (inside)."
    )

    @property
    def area(self) -> float:
        return self.size[0] * self.size[1]

    @property
    def front(self) -> np.ndarray[Any, np.dtype[np.float64]]:
        """World XY unit vector the object's front points to."""
        yaw = math.radians(self.yaw_deg)
        return np.array([math.sin(yaw), -math.cos(yaw)])

    def polygon(self) -> Polygon:
        return Polygon(self.footprint)

    def contains_point(self, xy: Vec2, margin: float = 0.0) -> bool:
        """Whether a point lies inside the footprint grown by ``margin`` metres."""
        poly = self.polygon()
        return bool(poly.buffer(margin).contains(Point(xy))) if margin else bool(poly.contains(Point(xy)))

    def overlap_fraction(self, other: ObjectFacts) -> float:
        """Fraction of this footprint's area covered by ``other``'s footprint."""
        a = self.polygon()
        if a.area <= 0:
            return 0.0
        return float(a.intersection(other.polygon()).area / a.area)


class WallFacts(_Facts):
    """A wall segment; the room's interior lies left of start -> end."""

    id: str
    start: Vec2 = Field(description="Wall start x,y; the room lies on the left walking from start to end.")
    end: Vec2 = Field(description="Wall end x,y.")
    height: float


class RoomFacts(_Facts):
    """The room as the agents see it (absent before the room agent ran)."""

    floor: list[Vec2] = Field(description="Floor polygon corners x,y, counter-clockwise seen from above.")
    walls: list[WallFacts]
    ceiling_height: float = Field(description="Ceiling height above the floor (z = 0).")


def object_facts(scene: Scene) -> list[ObjectFacts]:
    """Facts for every object, in scene order."""
    out: list[ObjectFacts] = []
    for o in scene.objects:
        out.append(_one(scene, o))
    return out


def _one(scene: Scene, o: SceneObject) -> ObjectFacts:
    lo, hi = o.aabb()
    size = o.size
    fp = o.footprint()
    sup = scene.support_of(o.id)
    return ObjectFacts(
        id=o.id,
        category=normalize_category(o.category),
        label=o.category if o.category != normalize_category(o.category) else None,
        center=(_r(o.pose.position[0]), _r(o.pose.position[1])),
        yaw_deg=_r(math.degrees(o.pose.yaw), 2),
        size=(_r(size[0]), _r(size[1]), _r(size[2])),
        bottom=_r(lo[2]),
        top=_r(hi[2]),
        footprint=[(_r(p[0]), _r(p[1])) for p in fp],
        extent=(_r(fp[:, 0].min()), _r(fp[:, 1].min()), _r(fp[:, 0].max()), _r(fp[:, 1].max())),
        parent=sup.parent if sup else None,
        relation=sup.kind if sup else None,
    )


def room_facts(scene: Scene) -> RoomFacts | None:
    """Facts of the scene's room, or None when it has none."""
    if scene.room is None:
        return None
    r = scene.room
    return RoomFacts(
        floor=[(_r(x), _r(y)) for x, y in r.floor],
        walls=[WallFacts(id=w.id, start=w.start, end=w.end, height=w.height) for w in r.walls],
        ceiling_height=r.ceiling_height,
    )


def wall_gap(wall: WallFacts, obj: ObjectFacts) -> float:
    """Smallest distance (metres, along the inward normal) from the wall line to the object's footprint.

    Negative when the footprint pokes through the wall.
    """
    d = np.subtract(wall.end, wall.start)
    d = d / max(float(np.linalg.norm(d)), 1e-12)
    inward = np.array([-d[1], d[0]])
    pts = np.asarray(obj.footprint) - np.asarray(wall.start)
    return float((pts @ inward).min())


def along_wall(wall: WallFacts, xy: Vec2) -> float:
    """Position of a point's projection along the wall (0 at start), metres."""
    d = np.subtract(wall.end, wall.start)
    length = max(float(np.linalg.norm(d)), 1e-12)
    return float(np.dot(np.subtract(xy, wall.start), d / length))


def wall_length(wall: WallFacts) -> float:
    return float(math.dist(wall.start, wall.end))


def outward(wall: WallFacts) -> np.ndarray[Any, np.dtype[np.float64]]:
    """Unit outward normal of a wall (pointing out of the room)."""
    d = np.subtract(wall.end, wall.start)
    d = d / max(float(np.linalg.norm(d)), 1e-12)
    return np.array([d[1], -d[0]])


def parent_cycles(parents: dict[str, str]) -> list[list[str]]:
    """Cycles in a child -> parent map (each cycle listed once, starting at its smallest id)."""
    cycles: list[list[str]] = []
    seen: set[str] = set()
    for start in sorted(parents):
        path: list[str] = []
        on_path: set[str] = set()
        node: str | None = start
        while node is not None and node in parents and node not in seen:
            if node in on_path:
                cyc = path[path.index(node) :]
                k = cyc.index(min(cyc))
                cycles.append(cyc[k:] + cyc[:k])
                break
            on_path.add(node)
            path.append(node)
            node = parents.get(node)
        seen |= on_path
    return cycles


def support_map(scene: Scene) -> dict[str, str]:
    """Child -> support parent for every supported object."""
    return {r.child: r.parent for r in scene.relations if r.is_support}


def replace_scene(scene: Scene, **fields: Any) -> Scene:
    """A validated copy of ``scene`` with some top-level fields replaced.

    Goes through a full validation so an apply that would break the scene's invariants
    raises instead of leaving a half-written scene behind.
    """
    data = scene.model_dump()
    for key, value in fields.items():
        data[key] = (
            value.model_dump()
            if isinstance(value, BaseModel)
            else (
                [v.model_dump() if isinstance(v, BaseModel) else v for v in value]
                if isinstance(value, list)
                else value
            )
        )
    return Scene.model_validate(data)


CHUNK_OBJECTS = 24
"""Objects one structuring request answers for, at most; a larger scene is asked in chunks."""


def chunk_ids(objects: list[ObjectFacts], size: int) -> list[list[str]]:
    """Object ids in scene order, cut into runs of at most ``size`` (one run when they fit)."""
    ids = [o.id for o in objects]
    return [ids[i : i + size] for i in range(0, len(ids), size)] or [[]]


def translate_objects(scene: Scene, moves: dict[str, Vec3]) -> None:
    """Translate objects in place by ``(dx, dy, dz)``; what each carries moves with it
    (``scenemosaic.scene.rigid_moves``)."""
    poses: dict[str, Pose] = {}
    for oid, (dx, dy, dz) in moves.items():
        pose = scene.get(oid).pose
        x, y, z = pose.position
        poses[oid] = pose.model_copy(update={"position": (x + dx, y + dy, z + dz)})
    for oid, pose in rigid_moves(scene, poses).items():
        scene.get(oid).pose = pose


def with_support(relations: list[Relation], child: str, new: Relation) -> list[Relation]:
    """Relations with ``child``'s support relation replaced by ``new`` (other relations kept)."""
    return [r for r in relations if not (r.child == child and r.is_support)] + [new]


ANCHORS = (FLOOR, CEILING)

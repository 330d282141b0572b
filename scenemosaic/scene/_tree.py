"""The scene tree: local units, their frames and projections, and per-unit layouts.

The tree's root is the room; its first-level anchors are the floor, each wall and the
ceiling; below them, every object that supports or contains others is an anchor too. A
:class:`~scenemosaic.scene.LocalUnit` is one anchor with its immediate children.

Unit frames (row-major 4x4, anchor frame -> world):

* **floor** — the world frame (origin at the world origin, z = 0 the floor).
* **ceiling** — the world frame lifted to the ceiling (z = ceiling height); axes unchanged.
* **wall** — origin at the wall's *end* point at floor level; x runs along the wall back
  toward its start, y is the wall's outward normal, z is up. This is a proper right-handed
  frame (x = y × z) in which x is the "right" direction of a view looking at the wall from
  inside the room (along the outward normal) and z is "up"; an object mounted flush with
  its front toward the room has yaw 0 in this frame.
* **object** — the anchor object's pose without scale (origin at its bottom centre, front -Y).

Projections: floor ``top_down``; ceiling ``bottom_up``; wall ``wall_normal``; object anchors
``top_down``, or ``anchor_front`` when every child is contained in the anchor.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from scenemosaic.scene._geometry import FloatArray, quat_from_matrix
from scenemosaic.scene._house import House
from scenemosaic.scene._model import (
    CEILING,
    FLOOR,
    ConstraintClause,
    LocalUnit,
    Pose,
    Scene,
    SceneStructure,
)

__all__ = [
    "build_structure",
    "descendants",
    "format_tree",
    "rigid_moves",
    "unit_frame",
    "unit_layout",
    "with_unit_layout",
    "with_world_poses",
]


def unit_frame(scene: Scene, anchor_id: str) -> FloatArray:
    """The 4x4 anchor frame (anchor -> world) of ``anchor_id`` in the scene as it is now."""
    m = np.eye(4)
    kind = scene.anchor_kind(anchor_id)
    if kind == "floor":
        return m
    if kind == "ceiling":
        m[2, 3] = scene.room.ceiling_height if scene.room is not None else 0.0
        return m
    if kind == "wall":
        assert scene.room is not None
        w = scene.room.wall(anchor_id)
        d = w.direction
        x = np.array([-d[0], -d[1], 0.0])
        y = np.array([w.outward_normal[0], w.outward_normal[1], 0.0])
        m[:3, 0], m[:3, 1], m[:3, 2] = x, y, (0.0, 0.0, 1.0)
        m[:3, 3] = (w.end[0], w.end[1], 0.0)
        return m
    return scene.get(anchor_id).pose.matrix(with_scale=False)


def _unit_order(scene: Scene) -> list[str]:
    """Anchors with children, top-down: floor, walls, ceiling, then object anchors breadth-first."""
    roots = [FLOOR, *([w.id for w in scene.room.walls] if scene.room else []), CEILING]
    order: list[str] = []
    queue = list(roots)
    seen: set[str] = set()
    while queue:
        a = queue.pop(0)
        if a in seen:
            continue
        seen.add(a)
        kids = scene.children_of(a)
        if kids:
            order.append(a)
        queue.extend(k for k in kids if k not in seen)
    return order


def _clauses_for(scene: Scene, units: dict[str, list[str]]) -> dict[str, list[ConstraintClause]]:
    """Each constraint clause goes to its anchor's unit; an anchor with no children of its own
    (a table nobody stands on) hands its clause to the unit it is a child of."""
    out: dict[str, list[ConstraintClause]] = {a: [] for a in units}
    child_to_unit = {c: a for a, kids in units.items() for c in kids}
    for c in scene.constraints:
        for clause in (c.anchor_a, c.anchor_b):
            target = clause.anchor_id if clause.anchor_id in units else child_to_unit.get(clause.anchor_id)
            if target is not None:
                out[target].append(clause)
    return out


def build_structure(scene: Scene) -> SceneStructure:
    """Local units of ``scene`` in top-down order (parents before children), with clauses.

    Only anchors with at least one child form a unit. A unit is ``contained`` when every child
    is inside its anchor (``contain`` relations); it is then viewed along the anchor's front.
    """
    order = _unit_order(scene)
    units = {a: scene.children_of(a) for a in order}
    clauses = _clauses_for(scene, units)
    out: list[LocalUnit] = []
    for a in order:
        kind = scene.anchor_kind(a)
        kids = units[a]
        contained = kind == "object" and all(
            (r := scene.support_of(k)) is not None and r.kind == "contain" for k in kids
        )
        projection = {
            "floor": "top_down", "ceiling": "bottom_up", "wall": "wall_normal",
            "object": "anchor_front" if contained else "top_down",
        }[kind]
        frame = [float(v) for v in unit_frame(scene, a).reshape(-1)]
        out.append(
            LocalUnit(anchor_id=a, anchor_kind=kind, children=kids, contained=contained,
                      projection=projection, frame=frame, clauses=clauses[a])  # type: ignore[arg-type]
        )
    return SceneStructure(units=out)


def _anchor_of(unit: LocalUnit | str) -> str:
    return unit if isinstance(unit, str) else unit.anchor_id


def unit_layout(scene: Scene, unit: LocalUnit | str) -> dict[str, Pose]:
    """Poses of a unit's children in the unit (anchor) frame, keyed by object id.

    The frame is computed from the scene as it is now (not a stored ``LocalUnit.frame``),
    so the layout stays anchor-relative after the anchor moves. Scale is carried unchanged.
    """
    anchor = _anchor_of(unit)
    inv = np.linalg.inv(unit_frame(scene, anchor))
    out: dict[str, Pose] = {}
    for cid in scene.children_of(anchor):
        o = scene.get(cid)
        local = inv @ o.pose.matrix(with_scale=False)
        out[cid] = Pose(position=tuple(float(v) for v in local[:3, 3]),  # type: ignore[arg-type]
                        quaternion=quat_from_matrix(local[:3, :3]), scale=o.pose.scale)
    return out


def descendants(scene: Scene, object_id: str) -> list[str]:
    """Every object resting on ``object_id``, directly or through others (depth first, no repeats)."""
    out: list[str] = []
    seen = {object_id}
    frontier = [object_id]
    while frontier:
        for k in scene.children_of(frontier.pop()):
            if k not in seen:
                seen.add(k)
                out.append(k)
                frontier.append(k)
    return out


_EYE4 = np.eye(4)
_STILL = 1e-12 + 1e-5 * _EYE4
"""How far a move's matrix may be from the identity and still be no move: ``np.allclose``'s
test (``atol`` 1e-12 and its default ``rtol`` 1e-5 of the identity's entries)."""


def rigid_moves(scene: Scene, poses: Mapping[str, Pose]) -> dict[str, Pose]:
    """World poses after moving each object of ``poses`` to its new world pose, carrying along
    rigidly everything resting on it (recursively). Descendants named in ``poses`` keep the pose
    given there. The one implementation of "move with descendants" (units, physics, evolution).
    """
    moved: dict[str, Pose] = dict(poses)
    for oid, new in poses.items():
        old = scene.get(oid).pose
        delta = new.matrix(with_scale=False) @ np.linalg.inv(old.matrix(with_scale=False))
        if bool((np.abs(delta - _EYE4) <= _STILL).all()):  # np.allclose(delta, eye, atol=1e-12), without its overhead
            continue
        for d in descendants(scene, oid):
            if d in poses:
                continue
            dp = scene.get(d).pose
            m = delta @ dp.matrix(with_scale=False)
            moved[d] = Pose(
                position=(float(m[0, 3]), float(m[1, 3]), float(m[2, 3])),
                quaternion=quat_from_matrix(m[:3, :3]),
                scale=dp.scale,
            )
    return moved


def with_unit_layout(scene: Scene, unit: LocalUnit | str, poses: Mapping[str, Pose]) -> Scene:
    """A NEW scene in which the given children of ``unit`` take ``poses`` (in the unit frame).

    Whatever a moved child carries (its own unit's children, recursively) moves rigidly with
    it, so every other unit's anchor-relative layout is unchanged. Raises ``KeyError`` for an
    id that is not a child of the unit. The input scene is not modified.
    """
    anchor = _anchor_of(unit)
    kids = set(scene.children_of(anchor))
    for oid in poses:
        if oid not in kids:
            raise KeyError(f"{oid!r} is not a child of unit {anchor!r}")
    frame = unit_frame(scene, anchor)
    targets: dict[str, Pose] = {}
    for oid, local in poses.items():
        world = frame @ local.matrix(with_scale=False)
        targets[oid] = Pose(
            position=(float(world[0, 3]), float(world[1, 3]), float(world[2, 3])),
            quaternion=quat_from_matrix(world[:3, :3]),
            scale=local.scale,
        )
    return with_world_poses(scene, targets)


def with_world_poses(scene: Scene, poses: Mapping[str, Pose]) -> Scene:
    """A NEW scene in which the objects of ``poses`` take those world poses, each carrying what
    rests on it (:func:`rigid_moves`). The input scene is not modified."""
    new_world = rigid_moves(scene, poses)
    data = scene.model_dump()
    for obj in data["objects"]:  # the new poses go into the copy's data: one dump, one validation
        pose = new_world.get(obj["id"])
        if pose is not None:
            obj["pose"] = pose.model_dump()
    return Scene.model_validate(data)


def format_tree(scene: Scene | House) -> str:
    """A readable tree of the scene: room, anchors, children with their relations, constraints
    (a house: each room's tree under the house, in its room order)."""
    if isinstance(scene, House):
        trees = [f"{scene.id}  ({len(scene.rooms)} rooms, {len(scene.objects)} objects)"]
        for part in scene.rooms:
            trees.append(f"  {part.id}:")
            trees += ["    " + line for line in format_tree(part).splitlines()]
        return "\n".join(trees)
    lines: list[str] = []
    room = scene.room
    if room is not None:
        lines.append(f"{room.id}  ({len(room.walls)} walls, ceiling {room.ceiling_height:.2f} m)")
    else:
        lines.append("(no room)")
    against = {r.child: r for r in scene.relations if r.kind == "against"}

    def label(oid: str) -> str:
        o = scene.get(oid)
        r = scene.support_of(oid)
        bits = [f"{oid} [{o.category}]"]
        if r is not None and r.kind == "contain":
            bits.append(f"inside, opens {r.opening or '?'}")
        if r is not None and r.distance is not None:
            bits.append(f"{r.distance:.2f} m from wall")
        if oid in against:
            a = against[oid]
            bits.append(f"against {a.parent}" + (f" ({a.distance:.3f} m)" if a.distance is not None else ""))
        bits += [f"{r.kind} {r.parent}" for r in scene.relations if r.child == oid and r.kind in ("faces", "beside")]
        return "  ".join(bits)

    def walk(anchor: str, prefix: str) -> None:
        kids = scene.children_of(anchor)
        for i, k in enumerate(kids):
            last = i == len(kids) - 1
            lines.append(f"{prefix}{'└── ' if last else '├── '}{label(k)}")
            walk(k, prefix + ("    " if last else "│   "))

    roots = [FLOOR, *([w.id for w in room.walls] if room else []), CEILING]
    shown = [r for r in roots if r in (FLOOR, CEILING) or scene.children_of(r)]
    for i, r in enumerate(shown):
        last = i == len(shown) - 1
        lines.append(f"{'└── ' if last else '├── '}{r}")
        walk(r, "    " if last else "│   ")
    orphans = [o.id for o in scene.objects if scene.support_of(o.id) is None]
    if orphans:
        lines.append("unparented: " + ", ".join(orphans))
    if scene.structure is not None:
        lines.append(f"units: {len(scene.structure.units)}")
        for u in scene.structure.units:
            lines.append(f"  {u.anchor_id} ({u.anchor_kind}, {u.projection}): {', '.join(u.children)}")
    if scene.constraints:
        lines.append("constraints:")
        for c in scene.constraints:
            lines.append(f"  {c.id} [{c.kind}] {c.description}")
            for clause in (c.anchor_a, c.anchor_b):
                rel = ", ".join(clause.related_objects) or "-"
                lines.append(f"    @{clause.anchor_id}: [{rel}] {clause.layout_note}")
    return "\n".join(lines)

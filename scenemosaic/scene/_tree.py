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

from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._model import (
    CEILING,
    FLOOR,
    ConstraintClause,
    LocalUnit,
    Pose,
    Scene,
    SceneObject,
    SceneStructure,
)

__all__ = [
    "build_structure",
    "format_tree",
    "unit_frame",
    "unit_layout",
    "with_unit_layout",
]


def _matrix_to_quat(r: FloatArray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a 3x3 rotation matrix (Shepperd's method)."""
    t = float(np.trace(r))
    if t > 0:
        s = 2.0 * np.sqrt(t + 1.0)
        q = (0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s)
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * np.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = ((r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s)
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * np.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = ((r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s)
    else:
        s = 2.0 * np.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = ((r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s)
    n = float(np.sqrt(sum(float(c) * float(c) for c in q)))
    w, x, y, z = (float(c) / n for c in q)
    return (w, x, y, z) if w >= 0 else (-w, -x, -y, -z)


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
                        quaternion=_matrix_to_quat(local[:3, :3]), scale=o.pose.scale)
    return out


def _descendants(scene: Scene, object_id: str) -> list[str]:
    out: list[str] = []
    frontier = [object_id]
    while frontier:
        for k in scene.children_of(frontier.pop()):
            if k not in out and k != object_id:
                out.append(k)
                frontier.append(k)
    return out


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
    new_world: dict[str, Pose] = {}
    for oid, local in poses.items():
        old = scene.get(oid).pose
        world = frame @ local.matrix(with_scale=False)
        new_pose = Pose(position=tuple(float(v) for v in world[:3, 3]),  # type: ignore[arg-type]
                        quaternion=_matrix_to_quat(world[:3, :3]), scale=local.scale)
        new_world[oid] = new_pose
        delta = world @ np.linalg.inv(old.matrix(with_scale=False))
        for d in _descendants(scene, oid):
            dp = scene.get(d).pose
            moved = delta @ dp.matrix(with_scale=False)
            new_world[d] = Pose(position=tuple(float(v) for v in moved[:3, 3]),  # type: ignore[arg-type]
                                quaternion=_matrix_to_quat(moved[:3, :3]), scale=dp.scale)
    objects: list[SceneObject] = [
        o.model_copy(update={"pose": new_world[o.id]}) if o.id in new_world else o.model_copy() for o in scene.objects
    ]
    data = scene.model_dump()
    data["objects"] = [o.model_dump() for o in objects]
    return Scene.model_validate(data)


def format_tree(scene: Scene) -> str:
    """A readable tree of the scene: room, anchors, children with their relations, constraints."""
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
            bits.append(f"against {a.parent}" + (f" ({a.distance:.2f} m)" if a.distance is not None else ""))
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

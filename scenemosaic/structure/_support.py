"""Support (attach): every object gets exactly one parent — floor, ceiling, a wall or an object.

Rule solver, per object, in this order:

1. ceiling fixtures (pendant / ceiling lamps, chandeliers) hang from the ceiling, wherever the
   input put them (a generator sometimes stands one on the floor);
2. furniture that stands on the floor (beds, chairs, tables, wardrobes... from the category
   table, else ProcTHOR's floor-only types) goes to the floor even when the input sank it into
   the floor or floated it above a neighbour;
3. otherwise the object rests on (or inside) the best supporting object below it: one whose
   footprint covers the object's centre, that can carry things (category table / ProcTHOR
   receptacles), that is not much smaller, and whose *real surface* under the object — measured
   by downward rays on the parent's mesh (:func:`resting_surfaces`), the box top only when no
   mesh is available — is closest under the object's bottom; an object inside a carrier's box,
   above its base, rests on an inner surface of it (a shelf board, a seat) when nothing matches
   better; ProcTHOR's receptacle probabilities break ties;
4. wall things (paintings, mirrors, and anything hanging above the floor with nothing under it
   near a wall) are mounted on the nearest wall;
5. everything else stands on the floor.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar, Literal

import numpy as np
import trimesh
from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent
from scenemosaic.assets import object_mesh
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    Relation,
    Scene,
    SceneObject,
    SupportPriors,
    is_known,
    load_priors,
    traits,
)
from scenemosaic.structure._facts import (
    CHUNK_OBJECTS,
    ObjectFacts,
    RoomFacts,
    chunk_ids,
    object_facts,
    parent_cycles,
    replace_scene,
    room_facts,
    wall_gap,
)
from scenemosaic.structure._views import FloorPlanImages

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = [
    "PlacementHints",
    "RestingSurface",
    "SupportAgent",
    "SupportAssignment",
    "SupportEvidence",
    "SupportOutput",
    "resting_surfaces",
    "supports_ok",
]

ON_TOP_TOLERANCE = 0.12
"""A child whose bottom is within this many metres below a parent's top still rests on it (sunk inputs)."""
WALL_MOUNT_REACH = 0.35
"""Largest gap (metres) between a floating object and a wall for it to count as wall-mounted."""
MOUNT_MIN_HEIGHT = 0.3
"""A wall thing must hang at least this high (metres) above the floor to count as mounted."""
MOUNT_GAP = 0.25
"""A wall-mountable object hovering this far (metres) above the furniture under it hangs on the wall."""
WALL_MOUNTABLE = frozenset({"television", "mirror", "painting", "picture", "wall_clock", "wall_shelf"})
"""Categories that may hang on a wall even with furniture below them."""
LARGE_AREA = 0.6
"""Footprint area (m²) above which an unknown object is treated as floor furniture."""
INTERIOR_MIN_LIFT = 0.05
"""An object this far (metres) above a supporting object's base, inside its box, rests on an inner surface of it."""
BOX_ONLY_PENALTY = 0.05
"""Score added when only the parent's box top (not its measured surface) matches the object's bottom."""
INTERIOR_PENALTY = 0.3
"""Score added to an inner-surface match, so a measured or box-top surface wins over it."""


class SupportAssignment(AgentOutput):
    """One object's support parent."""

    object_id: str = Field(max_length=64)
    parent: str = Field(max_length=64, description="'floor', 'ceiling', a wall id or an object id.")
    kind: Literal["attach", "contain"] = "attach"
    reason: str = Field(default="", max_length=200)


class SupportOutput(AgentOutput):
    """A support parent for every object."""

    assignments: list[SupportAssignment] = Field(max_length=MAX_ITEMS)


class PlacementHints(AgentOutput):
    """Category priors of the scene's objects, as id lists (given to the model as evidence)."""

    floor_only: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects that always stand on the floor."
    )
    wall_items: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects usually mounted on a wall."
    )
    ceiling_items: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects usually hung from the ceiling."
    )
    carriers: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects that can carry others on top."
    )
    containers: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects that can hold others inside."
    )


class RestingSurface(AgentOutput):
    """Where a candidate parent's real geometry lies under a child (measured on its mesh)."""

    child: str
    parent: str
    z: float | None = Field(
        description="Height of the candidate parent's highest real surface under the child (measured on "
        "its mesh: a mattress, a shelf board); blank when none of it lies under the child."
    )


class SupportEvidence(AgentOutput):
    """Objects with their boxes, the room, per-object category priors and measured resting surfaces."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    room: RoomFacts | None = None
    hints: PlacementHints = Field(default_factory=PlacementHints)
    surfaces: list[RestingSurface] = Field(default_factory=list, max_length=4 * MAX_ITEMS)


def can_support(category: str, priors: SupportPriors) -> bool:
    """Whether objects of this category may carry other objects."""
    return traits(category).supports or priors.is_receptacle(category) is True


def floor_only(o: ObjectFacts, priors: SupportPriors) -> bool:
    """Whether an object always stands on the floor (never on another object)."""
    t = traits(o.category)
    if is_known(o.category):
        return t.placement == "floor"
    prior = priors.floor_only(o.category)
    if prior is not None:
        return prior
    return o.area > LARGE_AREA or o.size[2] > 1.2


def supports_ok(child: ObjectFacts, parent: ObjectFacts, priors: SupportPriors) -> str | None:
    """Why ``parent`` cannot carry ``child`` (a sentence), or None when it can."""
    if not can_support(parent.category, priors):
        return f"{parent.id!r} ({parent.category}) cannot carry other objects"
    if parent.area < 0.25 * child.area:
        return f"{parent.id!r} ({parent.category}) is far too small to carry {child.id!r} ({child.category})"
    if traits(child.category).placement == "floor" and parent.category != "rug":
        return f"{child.id!r} ({child.category}) is floor furniture and cannot stand on {parent.id!r}"
    return None


def _candidate(o: ObjectFacts, p: ObjectFacts, priors: SupportPriors) -> bool:
    """Whether ``p`` could carry ``o`` at all (footprint under it, can carry things, big enough)."""
    if p.id == o.id or not can_support(p.category, priors) or p.area < 0.25 * o.area:
        return False
    return p.contains_point(o.center, 0.02) or o.overlap_fraction(p) >= 0.5


def resting_surfaces(
    scene: Scene, objs: list[ObjectFacts], priors: SupportPriors, base_dir: Path | None
) -> list[RestingSurface]:
    """Measure, on each candidate parent's real mesh, the surface under each object.

    Downward rays from five points of the child's footprint (its centre and half-way to each
    corner), starting ``ON_TOP_TOLERANCE`` above the child's bottom; the highest first hit is the
    surface the child rests on (a mattress under a pillow, a shelf board under a book), ``None``
    when no ray meets the parent. A parent whose mesh cannot be loaded is left unmeasured (the
    solver then uses its box top).
    """
    by_id = {o.id: o for o in scene.objects}
    meshes: dict[str, trimesh.Trimesh | None] = {}
    out: list[RestingSurface] = []
    for o in objs:
        if traits(o.category).placement == "ceiling" or floor_only(o, priors):
            continue
        for p in objs:
            if not _candidate(o, p, priors):
                continue
            if p.id not in meshes:
                meshes[p.id] = _world_mesh(by_id[p.id], base_dir)
            mesh = meshes[p.id]
            if mesh is None:
                continue
            z = _surface_under(mesh, o)
            out.append(RestingSurface(child=o.id, parent=p.id, z=None if z is None else round(z, 4)))
    return out


def _world_mesh(obj: SceneObject, base_dir: Path | None) -> trimesh.Trimesh | None:
    try:
        local = object_mesh(obj, base_dir)
    except SceneMosaicError:
        return None
    mesh = trimesh.Trimesh(vertices=np.asarray(local.vertices), faces=np.asarray(local.faces), process=False)
    mesh.apply_transform(obj.pose.matrix(with_scale=False))
    return mesh


def _surface_under(mesh: trimesh.Trimesh, o: ObjectFacts) -> float | None:
    corners = np.asarray(o.footprint, dtype=np.float64)
    centre = corners.mean(axis=0)
    points = np.vstack([centre, centre + 0.5 * (corners - centre)])
    start = o.bottom + ON_TOP_TOLERANCE
    best: float | None = None
    for z in _vertical_hits(mesh, points):
        below = z[z <= start + 1e-9]
        if len(below):
            top = float(below.max())
            best = top if best is None else max(best, top)
    return best


def _vertical_hits(mesh: trimesh.Trimesh, points: np.ndarray) -> list[np.ndarray]:
    """Heights where vertical lines through ``points`` (n, 2) cross the mesh's triangles.

    A vertical line meets a triangle where the point lies inside the triangle's XY projection;
    the height follows from the barycentric weights. Exact, vectorised over the triangles, and
    free of a spatial index (no optional dependency).
    """
    tri = np.asarray(mesh.triangles, dtype=np.float64)  # (m, 3, 3)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b[:, :2] - a[:, :2], c[:, :2] - a[:, :2]
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    ok = np.abs(den) > 1e-12  # triangles seen edge-on from above hold no surface
    lo, hi = tri[:, :, :2].min(axis=1), tri[:, :, :2].max(axis=1)
    out = []
    for px, py in points:
        near = ok & (lo[:, 0] <= px) & (px <= hi[:, 0]) & (lo[:, 1] <= py) & (py <= hi[:, 1])
        if not near.any():
            out.append(np.empty(0))
            continue
        d = np.array([px, py]) - a[near, :2]
        dn = den[near]
        u = (d[:, 0] * v1[near, 1] - v1[near, 0] * d[:, 1]) / dn
        v = (v0[near, 0] * d[:, 1] - d[:, 0] * v0[near, 1]) / dn
        inside = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)
        z = a[near, 2] + u * (b[near, 2] - a[near, 2]) + v * (c[near, 2] - a[near, 2])
        out.append(z[inside])
    return out


def _nearest_wall(o: ObjectFacts, room: RoomFacts | None) -> tuple[str, float] | None:
    if room is None or not room.walls:
        return None
    best = min(room.walls, key=lambda w: abs(wall_gap(w, o)))
    return best.id, wall_gap(best, o)


def solve_support(evidence: SupportEvidence, priors: SupportPriors) -> SupportOutput:
    """The support rule solver (see the module docstring)."""
    objs = evidence.objects
    surfaces = {(s.child, s.parent): s.z for s in evidence.surfaces}
    out: list[SupportAssignment] = []
    for o in objs:
        t = traits(o.category)
        if t.placement == "ceiling":
            out.append(SupportAssignment(object_id=o.id, parent=CEILING, reason="ceiling fixture"))
            continue
        if floor_only(o, priors):
            out.append(SupportAssignment(object_id=o.id, parent=FLOOR, reason="stands on the floor"))
            continue
        best: tuple[float, ObjectFacts, bool] | None = None
        for p in objs:
            if not _candidate(o, p, priors):
                continue
            inside = (
                traits(p.category).contains
                and p.bottom - 0.02 <= o.bottom
                and o.top <= p.top + 0.02
                and p.area * (p.top - p.bottom) > o.area * (o.top - o.bottom)
            )
            # the measured surface (the parent's mesh under the child) is the best evidence; the box
            # top counts too, a little less, since a procedural stand-in only approximates an asset
            measured = surfaces.get((o.id, p.id))
            box_gap = o.bottom - p.top
            close = [abs(box_gap) + BOX_ONLY_PENALTY] if abs(box_gap) <= ON_TOP_TOLERANCE else []
            if measured is not None and abs(o.bottom - measured) <= ON_TOP_TOLERANCE:
                close.append(abs(o.bottom - measured))
            within = (
                not inside
                and p.bottom + INTERIOR_MIN_LIFT < o.bottom < p.top - 0.02
                and o.overlap_fraction(p) >= 0.8
            )
            if inside:
                score = 0.0
            elif close and p.bottom < o.bottom:
                score = min(close)
            elif within:
                # inside the parent's box, above its base: resting on an inner surface (a shelf
                # board, a seat, a mattress below a headboard) that the box alone does not show
                score = INTERIOR_PENALTY
            elif box_gap > ON_TOP_TOLERANCE:
                score = box_gap  # floating above it: the closest surface below wins
            else:
                continue
            if priors.can_rest_on(o.category, p.category):
                score -= 0.02
            if best is None or score < best[0]:
                best = (score, p, inside)
        wall = _nearest_wall(o, evidence.room)
        if t.placement == "wall" and wall is not None and o.bottom > MOUNT_MIN_HEIGHT:
            out.append(SupportAssignment(object_id=o.id, parent=wall[0], reason="wall-mounted by category"))
            continue
        hovering = best is not None and not best[2] and o.bottom - best[1].top > MOUNT_GAP
        if hovering and o.category in WALL_MOUNTABLE and wall is not None and wall[1] < WALL_MOUNT_REACH:
            out.append(
                SupportAssignment(object_id=o.id, parent=wall[0], reason="hangs on the wall above furniture")
            )
            continue
        if best is not None:
            _, p, inside = best
            out.append(
                SupportAssignment(
                    object_id=o.id,
                    parent=p.id,
                    kind="contain" if inside else "attach",
                    reason=("inside " if inside else "rests on ") + p.category,
                )
            )
            continue
        if wall is not None and o.bottom > MOUNT_MIN_HEIGHT and wall[1] < WALL_MOUNT_REACH:
            out.append(
                SupportAssignment(object_id=o.id, parent=wall[0], reason="hangs near a wall, nothing below")
            )
            continue
        out.append(SupportAssignment(object_id=o.id, parent=FLOOR, reason="nothing below it"))
    return SupportOutput(assignments=out)


def _anchor_problem(child: ObjectFacts, parent: str, scene: Scene, priors: SupportPriors) -> str | None:
    """Why ``child`` cannot have the room anchor ``parent`` (floor, ceiling, a wall), if it cannot:
    only ceiling fixtures hang from the ceiling (and are never left on the floor), and nothing
    that stands on the floor or rests low hangs on a wall."""
    placement = traits(child.category).placement
    if parent == CEILING and placement != "ceiling":
        height = scene.room.ceiling_height if scene.room is not None else None
        near_top = height is not None and child.top >= height - 0.3
        if floor_only(child, priors) or is_known(child.category) or not near_top:
            return (
                f"{child.id!r} ({child.category}) does not hang from the ceiling (only ceiling lamps and "
                "fixtures do); give it the floor, a wall or the object it rests on"
            )
    if parent == FLOOR and placement == "ceiling":
        return f"{child.id!r} ({child.category}) hangs from the ceiling: give it parent \"ceiling\", even if it sits low"
    if scene.anchor_kind(parent) == "wall" and (floor_only(child, priors) or child.bottom <= MOUNT_MIN_HEIGHT):
        return (
            f"{child.id!r} ({child.category}) stands on the floor or on furniture, it does not hang on "
            f"{parent!r}; a wall parent is for things mounted above the floor (pictures, wall shelves)"
        )
    return None


def check_parents(
    pairs: Sequence[tuple[str, str, str]], state: SceneState, priors: SupportPriors, *, complete: bool
) -> list[str]:
    """Problems with (child, parent, kind) support triples against the scene.

    Self-support, parents that cannot carry or contain the child, and cycles (including
    through the scene's other support relations). ``complete`` also requires every object to
    be covered. Unknown and repeated children are the agents' base id check's
    (``object_id_fields``): unknown ones are skipped here.
    """
    scene = state.scene
    facts = {f.id: f for f in object_facts(scene)}
    anchors = scene.anchor_ids()
    problems: list[str] = []
    seen: set[str] = set()
    parents = {r.child: r.parent for r in scene.relations if r.is_support}
    for child, parent, kind in pairs:
        if child not in facts:
            continue
        seen.add(child)
        if parent not in anchors:
            problems.append(
                f"parent {parent!r} of {child!r} is not 'floor', 'ceiling', a wall id or an object id"
            )
            continue
        if parent == child:
            problems.append(f"object {child!r} cannot support itself")
            continue
        parents[child] = parent
        why_anchor = _anchor_problem(facts[child], parent, scene, priors)
        if why_anchor:
            problems.append(why_anchor)
        if parent in facts:
            why = supports_ok(facts[child], facts[parent], priors)
            if why:
                problems.append(why)
            if kind == "contain" and not traits(facts[parent].category).contains:
                problems.append(
                    f"{parent!r} ({facts[parent].category}) cannot contain {child!r}; "
                    f"use kind \"attach\" for {child!r} resting on it"
                )
        elif kind == "contain":
            problems.append(
                f"{child!r}: only objects can contain others; with parent {parent!r} use kind \"attach\""
            )
    if complete:
        missing = sorted(set(facts) - seen)
        if missing:
            problems.append("these objects have no parent: " + ", ".join(missing[:20]))
    for cyc in parent_cycles(parents):
        problems.append("parent cycle: " + " -> ".join([*cyc, cyc[0]]))
    return problems


class SupportAgent(FloorPlanImages, TaskAgent[SceneState, SupportEvidence, SupportOutput]):
    """Gives every object exactly one support parent (floor, ceiling, a wall or an object)."""

    name: ClassVar[str] = "support"
    depends_on: ClassVar[tuple[str, ...]] = ("room",)
    prompt: ClassVar[str] = "support"
    reply_tokens: ClassVar[tuple[int, int] | None] = (200, 45)
    chunk_size: ClassVar[int | None] = CHUNK_OBJECTS
    items_field: ClassVar[str | None] = "assignments"
    object_id_fields: ClassVar[tuple[str, ...]] = ("assignments.object_id",)

    def needed(self, summary: SceneSummary) -> Need:
        """Always, and every plan must have it: every object needs a parent."""
        return Need(True, f"parent each of {summary.object_count} objects", required=True)

    def __init__(self, priors: SupportPriors | None = None) -> None:
        self.priors = priors if priors is not None else load_priors()

    def gather(self, state: SceneState) -> SupportEvidence:
        objs = object_facts(state.scene)
        surfaces = resting_surfaces(state.scene, objs, self.priors, state.base_dir)
        placement = {
            o.id: "floor" if floor_only(o, self.priors) else traits(o.category).placement for o in objs
        }
        hints = PlacementHints(
            floor_only=[k for k, v in placement.items() if v == "floor"],
            wall_items=[k for k, v in placement.items() if v == "wall"],
            ceiling_items=[k for k, v in placement.items() if v == "ceiling"],
            carriers=[o.id for o in objs if can_support(o.category, self.priors)],
            containers=[o.id for o in objs if traits(o.category).contains],
        )
        return SupportEvidence(objects=objs, room=room_facts(state.scene), hints=hints, surfaces=surfaces)

    def solve(self, evidence: SupportEvidence) -> SupportOutput:
        return solve_support(evidence, self.priors)

    def split(self, evidence: SupportEvidence, size: int) -> list[tuple[list[str], SupportEvidence]]:
        """Chunks of objects to parent, each shown with every object that could carry them."""
        runs = chunk_ids(evidence.objects, size)
        if len(runs) == 1:
            return [(runs[0], evidence)]
        carriers = set(evidence.hints.carriers) | set(evidence.hints.containers)
        out: list[tuple[list[str], SupportEvidence]] = []
        for ids in runs:
            mine = set(ids)
            shown = {o.id for o in evidence.objects if o.id in mine or o.id in carriers}
            hints = evidence.hints.model_dump()
            out.append(
                (
                    ids,
                    SupportEvidence(
                        objects=[o for o in evidence.objects if o.id in shown],
                        room=evidence.room,
                        hints=PlacementHints(**{k: [i for i in v if i in shown] for k, v in hints.items()}),
                        surfaces=[x for x in evidence.surfaces if x.child in mine],
                    ),
                )
            )
        return out

    def check(self, output: SupportOutput, state: SceneState) -> list[str]:
        pairs = [(a.object_id, a.parent, a.kind) for a in output.assignments]
        return check_parents(pairs, state, self.priors, complete=True)

    def apply(self, output: SupportOutput, state: SceneState) -> None:
        assigned = {a.object_id for a in output.assignments}
        kept = [r for r in state.scene.relations if not (r.is_support and r.child in assigned)]
        new = [
            Relation(kind=a.kind, child=a.object_id, parent=a.parent, source=self.name)
            for a in output.assignments
        ]
        state.scene = replace_scene(state.scene, relations=kept + new)

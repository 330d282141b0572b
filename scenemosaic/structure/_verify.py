"""Verification: the last pass over the structured scene, fixing what it can and reporting the rest.

Rule solver: an object with no parent goes to the floor (the ceiling for ceiling fixtures); a
parent cycle is broken by standing its lowest member on the floor; a constraint whose clauses
name missing objects, or objects outside the clause's unit (in ``related_objects`` or in
parentheses in its layout note), is dropped; pillows and cushions on the floor beside a bed or
seat are put on it; two floor-standing pieces of furniture whose boxes stand inside each other
(:func:`scenemosaic.scene.nested_pairs`: a TV stand slid under a dressing table) are parted by
moving the smaller one the least distance that separates them, provided it stays inside the
room and clear of every other piece; otherwise the larger one, otherwise the pair is reported.
Receptacles (``docs/structuring.md``, "Crowded surfaces"): a small item whose receptacle is
implausible by the ProcTHOR priors (seen there on that receptacle's type less than
``PLAUSIBLE_P`` of the time: toilet paper in a garbage can, a bowl on a chair) moves to the
nearest plausible receptacle of the room with room for it, or to the floor when its type may lie
there; fruit on top of a fridge goes inside it; and a top that cannot take all its items
(``scene.pack_surface``) sends the ones that do not fit the same way. Each move is a fix with its
reason, so the report lists every re-parenting.
Apply then builds the
scene tree (:func:`scenemosaic.scene._tree.build_structure`) so every unit is non-empty by
construction; anything left over is reported in the scene's provenance notes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, ClassVar, Literal

import numpy as np
from pydantic import Field
from shapely.affinity import translate
from shapely.geometry import Polygon

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent
from scenemosaic.assets import compartment_fits, interior_boards
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    MAX_FLOOR_POINTS,
    CrossUnitConstraint,
    PackItem,
    Relation,
    Scene,
    SupportPriors,
    build_structure,
    load_priors,
    nested_pairs,
    pack_surface,
    traits,
)
from scenemosaic.structure._constraints import foreign_note_ids
from scenemosaic.structure._facts import (
    ObjectFacts,
    Vec2,
    object_facts,
    parent_cycles,
    replace_scene,
    translate_objects,
)
from scenemosaic.structure._room import MAX_PULL_IN, ObjectShift

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = [
    "MAX_PROBLEMS",
    "PLAUSIBLE_P",
    "ItemPlacement",
    "NestedFacts",
    "ParentFix",
    "ReceptacleOption",
    "VerificationAgent",
    "VerificationEvidence",
    "VerificationOutput",
    "placement_options",
]


PROMPT_OPTIONS = 3
"""Receptacles a verification prompt offers each item (the nearest; the rule solver reads up to 8)."""
MAX_PROBLEMS = MAX_ITEMS
"""Most problems verification reports; past it, the last line says how many more there were (400
items on one counter that holds 60 would otherwise report 340 lines)."""


class ParentFix(AgentOutput):
    """Give an object a (new) support parent."""

    object_id: str = Field(max_length=64)
    parent: str = Field(max_length=64)
    reason: str = Field(default="", max_length=200)
    kind: Literal["attach", "contain"] = Field(
        default="attach", description="attach: rests on (or hangs from) the parent; contain: inside it."
    )
    at: Vec2 | None = Field(
        default=None, description="Where the object's centre goes (x, y), when it moves to another receptacle."
    )


class ReceptacleOption(AgentOutput):
    """A receptacle of the room where an item would be plausible."""

    receptacle_id: str
    p: float = Field(description="How often ProcTHOR found the item's type on this receptacle's type (share of its items).")
    distance_m: float = Field(description="From the item's centre to the receptacle's footprint.")
    contain: bool = Field(description="Items go inside it (a fridge), not on top.")


class ItemPlacement(AgentOutput):
    """A small item resting on (or in) another object, and where else it would be plausible."""

    object_id: str
    parent_p: float | None = Field(
        description="How often ProcTHOR found the item's type on its parent's type; null when unknown."
    )
    into_parent: bool = Field(description="The parent is a tall front-opening container: the item belongs inside.")
    fits_inside: bool | None = Field(
        default=None,
        description="Whether any compartment of its parent can take it; null when the parent has none known.",
    )
    floor_ok: bool = Field(description="Its type may lie on the floor.")
    options: list[ReceptacleOption] = Field(default_factory=list, max_length=8)


class VerificationOutput(AgentOutput):
    """Fixes to apply and problems to report."""

    fixes: list[ParentFix] = Field(default_factory=list, max_length=MAX_ITEMS)
    moves: list[ObjectShift] = Field(
        default_factory=list,
        max_length=MAX_ITEMS,
        description="Translations that part furniture standing inside other furniture (dz stays 0).",
    )
    drop_constraints: list[str] = Field(default_factory=list, max_length=MAX_ITEMS)
    problems: list[str] = Field(default_factory=list, max_length=MAX_PROBLEMS)
    lay_down: list[str] = Field(
        default_factory=list,
        max_length=MAX_ITEMS,
        description="Tall, thin loose things (a baseball bat, a broom) laid down on their side, long side along their width.",
    )


class NestedFacts(AgentOutput):
    """Two floor-standing pieces whose boxes stand inside each other."""

    a: str
    b: str
    shared: float = Field(description="Fraction of the smaller footprint both boxes cover.")
    depth: float = Field(description="Least in-plane move (metres) that parts the two boxes.")
    axis: Vec2 = Field(description="Moving b by depth along this unit vector (or a against it) parts them.")


class VerificationEvidence(AgentOutput):
    """Objects with their parents, the constraints, and furniture standing inside furniture."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    constraints: list[CrossUnitConstraint] = Field(default_factory=list, max_length=MAX_ITEMS)
    anchors: list[str] = Field(
        default_factory=list,
        max_length=MAX_ITEMS,
        description="Every valid anchor id: floor, ceiling, the wall ids and the object ids.",
        json_schema_extra={"prompt": False},
    )
    nested: list[NestedFacts] = Field(default_factory=list, max_length=MAX_ITEMS)
    floor: list[Vec2] = Field(default_factory=list, max_length=MAX_FLOOR_POINTS, description="Room floor polygon, if any.")
    items: list[ItemPlacement] = Field(default_factory=list, max_length=MAX_ITEMS)
    standing_thin: list[str] = Field(
        default_factory=list,
        max_length=MAX_ITEMS,
        description="Loose things standing on end that are taller than LIE_DOWN_RATIO times their width: they would topple.",
    )


SOFT_ON_FURNITURE = frozenset({"pillow", "throw_pillow", "cushion"})
"""Things that belong on a bed or a seat, never on the floor beside one."""
SOFT_HOSTS = ("bed", "sofa", "armchair", "lounge_chair", "loveseat")
"""Category fragments of the furniture soft things rest on."""
BESIDE_M = 0.5
"""A soft thing this close (metres) to a bed or seat's footprint lies *beside* it."""


def _soft_things_on_the_floor(objects: list[ObjectFacts], parents: dict[str, str]) -> list[ParentFix]:
    """Pillows and cushions on the floor next to a bed or seat go onto it (physics then lays them on top)."""
    hosts = [o for o in objects if any(h in o.category for h in SOFT_HOSTS)]
    fixes: list[ParentFix] = []
    for o in objects:
        if o.category not in SOFT_ON_FURNITURE or parents.get(o.id) != FLOOR or not hosts:
            continue
        host = min(hosts, key=lambda h: h.polygon().distance(o.polygon()))
        if host.polygon().distance(o.polygon()) <= BESIDE_M:
            fixes.append(
                ParentFix(
                    object_id=o.id,
                    parent=host.id,
                    reason=f"a {o.category} on the floor beside the {host.category} belongs on it",
                )
            )
            parents[o.id] = host.id
    return fixes


PART_GAP_M = 0.01
"""Clearance left between two pieces of furniture parted by verification."""


def _parting_moves(evidence: VerificationEvidence) -> tuple[list[ObjectShift], list[str]]:
    """One move per nested pair (see the module docstring), and the pairs it could not part."""
    facts = {o.id: o for o in evidence.objects}
    shapes = {o.id: o.polygon() for o in evidence.objects}
    room = Polygon(evidence.floor).buffer(1e-3) if len(evidence.floor) >= 3 else None
    moves: list[ObjectShift] = []
    problems: list[str] = []
    moved: set[str] = set()
    for pair in evidence.nested:
        if pair.a in moved or pair.b in moved or pair.a not in facts or pair.b not in facts:
            continue
        step = pair.depth + PART_GAP_M
        if step > MAX_PULL_IN:
            problems.append(
                f"{pair.a} and {pair.b} stand inside each other by {pair.depth:.2f} m; too deep to part"
            )
            continue
        axis = np.asarray(pair.axis, dtype=np.float64)
        order = sorted(
            [(pair.b, axis * step), (pair.a, -axis * step)], key=lambda c: facts[c[0]].area
        )  # the smaller piece first
        for oid, (dx, dy) in order:
            other = pair.a if oid == pair.b else pair.b
            shape = translate(shapes[oid], float(dx), float(dy))
            if room is not None and not room.contains(shape):
                continue
            clash = [
                k
                for k, poly in shapes.items()
                if k not in (oid, other)
                and facts[k].parent == FLOOR
                and traits(facts[k].category).placement == "floor"
                and poly.intersection(shape).area > 0.05 * min(poly.area, shape.area) + 1e-9
                and poly.intersection(shapes[oid]).area <= 1e-9
            ]
            if clash:
                continue
            moves.append(
                ObjectShift(
                    object_id=oid,
                    dx=round(float(dx), 4),
                    dy=round(float(dy), 4),
                    reason=f"stood {pair.depth:.2f} m inside {other}; moved out",
                )
            )
            shapes[oid] = shape
            moved.add(oid)
            break
        else:
            problems.append(
                f"{pair.a} and {pair.b} stand inside each other ({pair.shared:.0%} of the smaller box); "
                "no short move parts them inside the room"
            )
    return moves, problems


PLAUSIBLE_P = 0.04
"""An item ProcTHOR found on its receptacle's type less often than this (share of that receptacle
type's items) is implausible there: toilet paper in a garbage can (0.036), a candle in one (0.005),
a bowl on a chair (0.007), a baseball bat on a bed (0.024) or a chair (0)."""
LIE_DOWN_RATIO = 4.0
"""A loose thing standing taller than this many times its largest width (a baseball bat on end) is
laid down: standing, it would topple (or pierce what hangs behind it)."""
REHOME_REACH_M = 6.0
"""Receptacles farther than this from an item are not offered as its new place."""
TALL_CONTAINER_M = 1.2
"""A front-opening container taller than this (a fridge) holds its items inside, not on top."""


def placement_options(
    objects: list[ObjectFacts],
    parents: dict[str, str | None],
    priors: SupportPriors,
    compartments: Mapping[str, list[tuple[float, float, float, float, float, float]]] | None = None,
) -> list[ItemPlacement]:
    """For every small item resting on or in another object: how plausible its parent is and the
    plausible receptacles of the room, nearest first."""
    facts = {o.id: o for o in objects}
    carriers = [o for o in objects if traits(o.category).supports or priors.is_receptacle(o.category) is True]
    out: list[ItemPlacement] = []
    for o in objects:
        parent = facts.get(parents.get(o.id) or "")
        if parent is None or not priors.is_pickupable(o.category):
            continue
        options: list[ReceptacleOption] = []
        for c in carriers:
            if c.id in (o.id, parent.id):
                continue
            p = priors.probability(o.category, c.category)
            dist = float(c.polygon().distance(o.polygon()))
            inside_only = _holds_inside(c)
            fits = not inside_only or (boxes_of := (compartments or {}).get(c.id)) is None or _fits_a_compartment(o, boxes_of)
            if p is not None and p >= PLAUSIBLE_P and dist <= REHOME_REACH_M and fits:
                options.append(
                    ReceptacleOption(receptacle_id=c.id, p=round(p, 4), distance_m=round(dist, 3), contain=inside_only)
                )
        options.sort(key=lambda r: (r.distance_m, -r.p, r.receptacle_id))
        p_parent = priors.probability(o.category, parent.category)
        boxes = (compartments or {}).get(parent.id)
        out.append(
            ItemPlacement(
                object_id=o.id,
                parent_p=round(p_parent, 4) if p_parent is not None else None,
                into_parent=_holds_inside(parent) and o.relation != "contain",
                fits_inside=_fits_a_compartment(o, boxes) if boxes else None,
                floor_ok=priors.on_floor(o.category),
                options=options[:8],
            )
        )
    return out


def _fits_a_compartment(o: ObjectFacts, boxes: list[tuple[float, float, float, float, float, float]]) -> bool:
    """Whether the item's box fits some compartment (``assets.compartment_fits``)."""
    size = (float(o.size[0]), float(o.size[1]), float(o.size[2]))
    return any(compartment_fits(size, box) for box in boxes)


def _holds_inside(o: ObjectFacts) -> bool:
    t = traits(o.category)
    return t.contains and t.opening == "front" and o.size[2] > TALL_CONTAINER_M


def _receptacle_fixes(
    evidence: VerificationEvidence, parents: dict[str, str]
) -> tuple[list[ParentFix], list[ObjectShift], list[str]]:
    """Implausible receptacles and over-full tops: the fixes that re-home items, and the moves that
    lay each top out so that what stays fits (see the module docstring)."""
    facts = {o.id: o for o in evidence.objects}
    items = {i.object_id: i for i in evidence.items}
    kids: dict[str, list[ObjectFacts]] = {}
    for o in evidence.objects:
        if parents.get(o.id) in facts and o.relation != "contain":
            kids.setdefault(parents[o.id], []).append(o)
    fixes: list[ParentFix] = []
    moves: list[ObjectShift] = []
    problems: list[str] = []
    leaving: list[tuple[str, str]] = []
    inside: set[str] = set()
    on_top_now: set[str] = set()
    for i in evidence.items:
        if i.object_id not in facts or parents.get(i.object_id) not in facts:
            continue
        if i.parent_p is not None and i.parent_p < PLAUSIBLE_P and (i.options or i.floor_ok):
            leaving.append((i.object_id, f"{facts[i.object_id].category} is implausible on its receptacle (p {i.parent_p:g})"))
        elif i.into_parent and i.fits_inside is not False:
            parent = parents[i.object_id]
            fixes.append(ParentFix(object_id=i.object_id, parent=parent, kind="contain", reason="belongs inside it, not on top"))
            inside.add(i.object_id)
        elif i.fits_inside is False and facts[i.object_id].relation == "contain":  # too big for every shelf: on top
            kids.setdefault(parents[i.object_id], []).append(facts[i.object_id])
            on_top_now.add(i.object_id)
    gone = {oid for oid, _ in leaving} | inside
    layout: dict[str, list[np.ndarray]] = {}
    for parent, on_top in sorted(kids.items()):
        staying = [k for k in on_top if k.id not in gone]
        if not staying:
            continue
        top = facts[parent].polygon()
        pack = {k.id: PackItem(k.id, np.asarray(k.footprint), may_turn=k.id in items) for k in staying}
        packed = pack_surface(top, list(pack.values()))
        wide = {oid for oid in packed.unplaced if oid not in items}
        if wide:  # wider than the top (a television): it stays where it stands, and its box takes room
            pack = {oid: PackItem(oid, i.corners, movable=False) if oid in wide else i for oid, i in pack.items()}
            packed = pack_surface(top, list(pack.values()))
        for k in staying:
            if k.id in packed.unplaced:
                if k.id in items:
                    leaving.append((k.id, f"no room left on {parent}"))
                    gone.add(k.id)
                continue
            if k.id in on_top_now:
                fixes.append(ParentFix(object_id=k.id, parent=parent, reason="too big for its compartments; set on top"))
            shift = packed.shifts.get(k.id, np.zeros(2))
            layout.setdefault(parent, []).append(packed.footprint(pack[k.id]))
            # physics packs the top the same way; a move here only tells the model and the report
            if k.id not in packed.kept and k.id not in packed.turned and 1e-3 < float(np.hypot(*shift)) <= MAX_PULL_IN:
                moves.append(
                    ObjectShift(
                        object_id=k.id,
                        dx=round(float(shift[0]), 4),
                        dy=round(float(shift[1]), 4),
                        reason=f"made room on the crowded {facts[parent].category}",
                    )
                )
    for oid, why in leaving:
        fix = _rehome(facts[oid], items.get(oid), why, facts, layout, evidence, parents)
        if fix is None:
            problems.append(f"{oid}: {why}, and no plausible receptacle or floor spot has room for it")
            continue
        fixes.append(fix)
        parents[oid] = fix.parent
    return fixes, moves, problems


def _rehome(
    item: ObjectFacts,
    placement: ItemPlacement | None,
    why: str,
    facts: dict[str, ObjectFacts],
    layout: dict[str, list[np.ndarray]],
    evidence: VerificationEvidence,
    parents: dict[str, str],
) -> ParentFix | None:
    """The nearest plausible receptacle with room for ``item`` (its laid-out top packed again with
    the item set down at its centre), else a free floor spot near it when its type may lie there.
    ``layout`` holds each top's footprints as laid out so far and gains the item's."""
    corners = np.asarray(item.footprint)
    centre = corners.mean(axis=0)
    for opt in placement.options if placement is not None else []:
        host = facts.get(opt.receptacle_id)
        if host is None or _within(host.id, item.id, parents):
            continue
        here = np.asarray(host.center) - centre
        others = [PackItem(f"placed_{n}", c, movable=False) for n, c in enumerate(layout.get(host.id, []))]
        packed = pack_surface(host.polygon(), [*others, PackItem(item.id, corners + here, may_turn=False)])
        if item.id in packed.unplaced:
            continue
        spot = corners + here + packed.shifts[item.id]
        layout.setdefault(host.id, []).append(spot)
        at = spot.mean(axis=0)
        return ParentFix(
            object_id=item.id,
            parent=host.id,
            kind="contain" if opt.contain else "attach",
            at=(round(float(at[0]), 4), round(float(at[1]), 4)),
            reason=f"{why}; moved to {host.id} (p {opt.p:g})",
        )
    if placement is None or not placement.floor_ok or len(evidence.floor) < 3:
        return None
    standing = [PackItem(o.id, np.asarray(o.footprint), movable=False) for o in evidence.objects if parents.get(o.id) == FLOOR and o.id != item.id]
    standing += [PackItem(f"placed_{n}", c, movable=False) for n, c in enumerate(layout.get(FLOOR, []))]
    packed = pack_surface(Polygon(evidence.floor), [*standing, PackItem(item.id, corners, may_turn=False)], clearance=0.02, edge=0.05)
    if item.id in packed.unplaced:
        return None
    spot = corners + packed.shifts[item.id]
    layout.setdefault(FLOOR, []).append(spot)
    at = spot.mean(axis=0)
    return ParentFix(
        object_id=item.id,
        parent=FLOOR,
        at=(round(float(at[0]), 4), round(float(at[1]), 4)),
        reason=f"{why}; set on the floor beside it",
    )


def _within(candidate: str, item: str, parents: dict[str, str]) -> bool:
    """Whether ``candidate`` rests (directly or not) on ``item``: an item cannot move onto what it carries."""
    seen = set()
    node = candidate
    while node in parents and node not in seen:
        seen.add(node)
        node = parents[node]
        if node == item:
            return True
    return False


def laid_down(o: ObjectFacts) -> ObjectFacts:
    """``o`` lying on its side: its height becomes its width (along its own x), its footprint grows."""
    w, d, h = o.size
    yaw = math.radians(o.yaw_deg)
    c, s_ = math.cos(yaw), math.sin(yaw)
    half = [(-h / 2, -d / 2), (h / 2, -d / 2), (h / 2, d / 2), (-h / 2, d / 2)]
    foot = [(o.center[0] + x * c - y * s_, o.center[1] + x * s_ + y * c) for x, y in half]
    return o.model_copy(update={"size": (h, d, w), "top": o.bottom + w, "footprint": foot})


def solve_verification(evidence: VerificationEvidence) -> VerificationOutput:
    """The verification rule solver (see the module docstring)."""
    lay = [oid for oid in evidence.standing_thin if any(o.id == oid for o in evidence.objects)]
    if lay:  # decided on the objects as they will lie
        evidence = evidence.model_copy(
            update={"objects": [laid_down(o) if o.id in lay else o for o in evidence.objects]}
        )
    facts = {o.id: o for o in evidence.objects}
    fixes: list[ParentFix] = []
    parents = {o.id: o.parent for o in evidence.objects if o.parent}
    for o in evidence.objects:
        if o.parent is None:
            target = CEILING if traits(o.category).placement == "ceiling" else FLOOR
            fixes.append(ParentFix(object_id=o.id, parent=target, reason="had no parent"))
            parents[o.id] = target
    for cyc in parent_cycles({k: v for k, v in parents.items() if v is not None}):
        low = min((facts[c] for c in cyc if c in facts), key=lambda f: f.bottom)
        fixes.append(ParentFix(object_id=low.id, parent=FLOOR, reason="broke a parent cycle"))
        parents[low.id] = FLOOR
    fixes += _soft_things_on_the_floor(evidence.objects, parents)
    moves, problems = _parting_moves(evidence)
    rehomed, room_made, unhoused = _receptacle_fixes(evidence, parents)
    fixes += rehomed
    moves += room_made
    problems += unhoused
    drop: list[str] = []
    for c in evidence.constraints:
        for clause in (c.anchor_a, c.anchor_b):
            bad = [oid for oid in clause.related_objects if parents.get(oid) != clause.anchor_id]
            bad += [oid for oid in foreign_note_ids(clause, parents, facts) if oid not in bad]
            if clause.anchor_id not in evidence.anchors:
                bad.append(clause.anchor_id)
            if bad:
                drop.append(c.id)
                problems.append(
                    f"constraint {c.id} dropped: {', '.join(bad)} not in the unit of {clause.anchor_id}"
                )
                break
    if len(problems) > MAX_PROBLEMS:
        more = len(problems) - MAX_PROBLEMS + 1
        problems = [*problems[: MAX_PROBLEMS - 1], f"... and {more} more problems of the kinds above"]
    return VerificationOutput(fixes=fixes, moves=moves, drop_constraints=drop, problems=problems, lay_down=lay)


def _compartments(scene: Scene) -> dict[str, list[tuple[float, float, float, float, float, float]]]:
    """The compartments of every procedural container of the scene (``assets.interior_boards``)."""
    out = {}
    for o in scene.objects:
        if o.asset.kind == "procedural" and traits(o.category).contains:
            size = o.size
            boxes = interior_boards(o.asset.category or o.category, (float(size[0]), float(size[1]), float(size[2])))
            if boxes:
                out[o.id] = boxes
    return out


class VerificationAgent(TaskAgent[SceneState, VerificationEvidence, VerificationOutput]):
    """Checks completeness (one parent each, no cycles, valid constraints), fixes, and builds the tree."""

    name: ClassVar[str] = "verify"
    runs_last: ClassVar[bool] = True
    prompt: ClassVar[str] = "verify"
    reply_tokens: ClassVar[tuple[int, int] | None] = (400, 20)
    # a constraint's description says again what its clauses' notes say; headings decide nothing here
    prompt_omit: ClassVar[frozenset[str]] = frozenset({"top", "relation", "label", "description", "yaw_deg"})
    nested_rows: ClassVar[bool] = True
    object_id_fields: ClassVar[tuple[str, ...]] = ("fixes.object_id", "moves.object_id", "lay_down")

    def needed(self, summary: SceneSummary) -> Need:
        """Always, and every plan must have it: the final check builds the scene tree."""
        del summary
        return Need(True, "final completeness check and scene tree", required=True)

    def __init__(self, priors: SupportPriors | None = None) -> None:
        self.priors = priors if priors is not None else load_priors()

    def gather(self, state: SceneState) -> VerificationEvidence:
        scene = state.scene
        objs = object_facts(scene)
        return VerificationEvidence(
            objects=objs,
            constraints=list(scene.constraints),
            anchors=sorted(scene.anchor_ids()),
            nested=[  # past MAX_ITEMS pairs (a pile of furniture), physics parts the rest
                NestedFacts(a=p.a, b=p.b, shared=round(p.shared, 3), depth=round(p.depth_m, 3), axis=p.axis)
                for p in nested_pairs(scene)[:MAX_ITEMS]
            ],
            floor=[(round(x, 3), round(y, 3)) for x, y in scene.room.floor] if scene.room is not None else [],
            items=placement_options(objs, {o.id: o.parent for o in objs}, self.priors, _compartments(scene)),
            standing_thin=[
                o.id
                for o in objs
                if self.priors.is_pickupable(o.category)
                and scene.get(o.id).asset.kind == "procedural"
                and o.size[2] > LIE_DOWN_RATIO * max(o.size[0], o.size[1])
            ],
        )

    def solve(self, evidence: VerificationEvidence) -> VerificationOutput:
        return solve_verification(evidence)

    def render_evidence_text(self, evidence: VerificationEvidence) -> str:
        """The evidence with each item's :data:`PROMPT_OPTIONS` nearest receptacles (the rule
        solver reads them all), so a 60-object room's prompt stays within a small model's context."""
        items = [i.model_copy(update={"options": i.options[:PROMPT_OPTIONS]}) for i in evidence.items]
        return super().render_evidence_text(evidence.model_copy(update={"items": items}))

    def answer_without_model(self, evidence: VerificationEvidence) -> VerificationOutput | None:
        """The rule pass's empty answer when it finds nothing to fix or report: a clean scene needs no call."""
        found = solve_verification(evidence)
        busy = found.fixes or found.moves or found.drop_constraints or found.problems or found.lay_down
        return None if busy else found

    def check(self, output: VerificationOutput, state: SceneState) -> list[str]:
        scene = state.scene
        anchors = scene.anchor_ids()
        objects = {o.id for o in scene.objects}
        problems: list[str] = []
        parents = {r.child: r.parent for r in scene.relations if r.is_support}
        for f in output.fixes:
            if f.object_id not in objects:
                continue  # the base check reports it
            if f.parent not in anchors or f.parent == f.object_id:
                problems.append(f"parent {f.parent!r} of {f.object_id!r} is not a valid anchor")
            else:
                parents[f.object_id] = f.parent
        for m in output.moves:
            if abs(m.dz) > 1e-9:
                problems.append(
                    f"move of {m.object_id!r} has dz {m.dz:g}; parting moves stay in the floor plane (dz 0)"
                )
        known = {c.id for c in scene.constraints}
        for cid in output.drop_constraints:
            if cid not in known:
                problems.append(f"constraint id {cid!r} does not exist")
        missing = sorted(objects - set(parents))
        if missing:
            problems.append("objects still without a parent after the fixes: " + ", ".join(missing[:20]))
        for cyc in parent_cycles(parents):
            problems.append("parent cycle remains: " + " -> ".join([*cyc, cyc[0]]))
        return problems

    def apply(self, output: VerificationOutput, state: SceneState) -> None:
        scene = state.scene
        fixed = {f.object_id: f for f in output.fixes}
        rels = [r for r in scene.relations if not (r.is_support and r.child in fixed)]
        rels += [Relation(kind=f.kind, child=f.object_id, parent=f.parent, source=self.name) for f in output.fixes]
        drop = set(output.drop_constraints)
        constraints = [c for c in scene.constraints if c.id not in drop]
        notes = [*scene.provenance.notes, *(f"verify: {p}" for p in output.problems)]
        before = {r.child: r.parent for r in scene.relations if r.is_support}
        notes += [
            f"verify: {f.object_id} -> {f.parent} ({f.reason}; was on {before.get(f.object_id) or 'nothing'})"
            for f in output.fixes
        ]
        notes += [f"verify: {m.object_id} {m.reason} ({m.dx:+.2f}, {m.dy:+.2f}) m" for m in output.moves]
        notes += [f"verify: {oid} laid down (too tall and thin to stand)" for oid in output.lay_down]
        scene = replace_scene(
            scene,
            relations=rels,
            constraints=constraints,
            provenance=scene.provenance.model_copy(update={"notes": notes}),
        )
        for oid in output.lay_down:  # the procedural stand-in is drawn lying in its new box
            obj = scene.get(oid)
            w, d, h = obj.asset.extents
            obj.asset = obj.asset.model_copy(update={"extents": (h, d, w)})
        if output.moves:
            translate_objects(scene, {m.object_id: (m.dx, m.dy, 0.0) for m in output.moves})
        placed = {f.object_id: f.at for f in output.fixes if f.at is not None}
        if placed:  # a re-homed item goes to its new receptacle; physics sets it down on the surface
            centres = {o.id: o.center for o in object_facts(scene) if o.id in placed}
            translate_objects(
                scene, {k: (at[0] - centres[k][0], at[1] - centres[k][1], 0.0) for k, at in placed.items() if at is not None}
            )
        state.scene = replace_scene(scene, structure=build_structure(scene))

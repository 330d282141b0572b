"""Cross-unit constraints: the few strong functional relations that span local units.

Rule solver (:func:`solve_constraints`): functional relations are found in the scene's geometry
for the kinds of :data:`FUNCTIONAL_PAIRS` (seats at the edges of their table, nightstands at a
bed's head end, screens on a desk, a wall TV over its stand, a sofa facing its coffee table and
TV stand), each kind informed by a ProcTHOR asset group where one exists (dining table + chairs,
desk + chair, TV stand + TV + sofa); bed ↔ nightstands is our own. A kind becomes a relation
only when it is unique and unambiguous (one coffee table in front of the sofa, one TV stand in
the room...). Weak pairs — a painting and the sofa below it, a wall display and a central table —
are never emitted (:data:`WEAK_PAIRS`), since they would freeze layouts for no functional reason.

A relation becomes a constraint only when it spans two units, and is then split into two
clauses that each name one unit's anchor and only that unit's objects: a wall TV's wall unit
and its stand's floor unit; the floor unit where seats face a desk and the desk's own unit,
where its monitor keeps facing the seats. A relation inside one unit (seats around a dining
table that carries nothing) is recorded as a ``faces`` or ``beside`` relation instead.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar, Literal

import numpy as np
from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent, evidence_text
from scenemosaic.scene import (
    PROCTHOR_PRIORS_DIR,
    ConstraintClause,
    CrossUnitConstraint,
    Relation,
    is_bed,
    normalize_category,
    traits,
)
from scenemosaic.structure._facts import ObjectFacts, object_facts, replace_scene, room_facts
from scenemosaic.structure._views import FloorPlanImages
from scenemosaic.structure._walls import flush_walls

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = [
    "FUNCTIONAL_PAIRS",
    "MAX_CONSTRAINTS",
    "WEAK_PAIRS",
    "ConstraintEvidence",
    "ConstraintsAgent",
    "ConstraintsOutput",
    "FunctionalPair",
    "UnitRelation",
    "find_functional_relations",
    "foreign_note_ids",
    "procthor_group_pairs",
]

MAX_CONSTRAINTS = 64
"""Most cross-unit constraints the constraints agent returns (its output schema's bound, which a
recorded model run's requests are keyed on). A scene with more functional groups than this (70
desks, each with its monitor and chair) keeps the first ones found; the groups past them are
not held together across units (evolve may move a desk away from its chair)."""
SEAT_REACH = 0.8
"""A chair this close (metres) to a table's footprint is one of its chairs."""
NIGHTSTAND_REACH = 0.6
"""A nightstand this close (metres) to a bed's footprint is one of its nightstands."""
COFFEE_REACH = 1.5
"""A coffee table this close (metres) to a sofa's footprint is the sofa's coffee table."""
TV_REACH = 5.0
"""Largest sofa-to-TV-stand distance (metres) for a 'sofa faces the TV' constraint."""


@dataclass(frozen=True)
class FunctionalPair:
    """One row of the functional-pair table."""

    name: str
    kind: str
    description: str
    procthor: tuple[str, str] | None
    """The (anchor, child) AI2-THOR types of the ProcTHOR asset group that supports the pair, if any."""


FUNCTIONAL_PAIRS: tuple[FunctionalPair, ...] = (
    FunctionalPair(
        "seats_face_table",
        "orientation",
        "chairs face the table or desk they belong to",
        ("DiningTable", "Chair"),
    ),
    FunctionalPair("desk_chair", "orientation", "a desk chair faces the desk", ("Desk", "Chair")),
    FunctionalPair(
        "nightstands_beside_bed", "placement", "nightstands stand beside the head of the bed", None
    ),
    FunctionalPair(
        "monitor_keeps_desk_orientation", "orientation", "a monitor on a desk faces the desk's front", None
    ),
    FunctionalPair(
        "wall_tv_over_stand",
        "placement",
        "a wall TV and the TV stand below it share a centre line",
        ("TVStand", "Television"),
    ),
    FunctionalPair("sofa_faces_coffee_table", "orientation", "the sofa faces its coffee table", None),
    FunctionalPair("sofa_faces_tv", "orientation", "the sofa faces the TV stand", ("TVStand", "Sofa")),
)
"""The strong, unique functional pairs the rule solver may emit."""

WEAK_PAIRS: tuple[tuple[frozenset[str], frozenset[str]], ...] = (
    (
        frozenset({"painting", "picture", "mirror", "wall_clock"}),
        frozenset(
            {
                "sofa",
                "multi_seat_sofa",
                "loveseat_sofa",
                "l_shaped_sofa",
                "bed",
                "double_bed",
                "single_bed",
                "armchair",
                "console_table",
                "dining_table",
                "desk",
            }
        ),
    ),
    (frozenset({"television"}), frozenset({"dining_table", "table", "coffee_table"})),
    (
        frozenset({"pendant_lamp", "ceiling_lamp", "chandelier"}),
        frozenset({"dining_table", "table", "coffee_table", "bed", "double_bed", "sofa"}),
    ),
)
"""Category pairs whose relation is too weak or ambiguous to constrain (never emitted, rejected if proposed)."""

MONITORS = {"monitor", "computer_monitor", "television", "laptop"}


@lru_cache(maxsize=4)
def procthor_group_pairs(folder: str | None) -> frozenset[tuple[str, str]]:
    """(anchor, child) AI2-THOR type pairs found in ProcTHOR's ``asset_groups/*.json`` trees."""
    if not folder:
        return frozenset()
    pairs: set[tuple[str, str]] = set()

    def walk(nodes: list[dict[str, object]], parent: str | None) -> None:
        for n in nodes:
            title = str(n.get("title", ""))
            if parent:
                pairs.add((parent, title))
            kids = n.get("children")
            if isinstance(kids, list):
                walk(kids, title)

    for path in sorted(Path(folder, "asset_groups").glob("*.json")):
        try:
            tree = json.loads(path.read_text(encoding="utf-8")).get("treeData", [])
        except (OSError, ValueError):
            continue
        walk(tree, None)
    return frozenset(pairs)


class UnitRelation(AgentOutput):
    """A functional relation inside one unit: ``object_id`` faces, or stands beside, ``reference_id``."""

    kind: Literal["faces", "beside"]
    object_id: str = Field(max_length=64)
    reference_id: str = Field(max_length=64)


class ConstraintsOutput(AgentOutput):
    """The cross-unit constraints of the scene, and the functional relations inside one unit
    (both replace any earlier ones)."""

    constraints: list[CrossUnitConstraint] = Field(default_factory=list, max_length=MAX_CONSTRAINTS)
    within_unit: list[UnitRelation] = Field(default_factory=list, max_length=MAX_ITEMS)


class ConstraintEvidence(AgentOutput):
    """Objects with their parents, wall relations, and the ProcTHOR-backed pair table."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    against: dict[str, str] = Field(
        default_factory=dict, description="Object id -> wall it stands flush against."
    )
    pairs: list[str] = Field(
        default_factory=list, max_length=32, description="Allowed functional pair names."
    )
    units: dict[str, list[str]] = Field(
        default_factory=dict,
        description="Local units: anchor id -> its children. Only these anchors may hold a clause.",
    )


def _dist(a: ObjectFacts, b: ObjectFacts) -> float:
    return float(a.polygon().distance(b.polygon()))


def _children(objs: list[ObjectFacts], anchor: str) -> list[str]:
    return [o.id for o in objs if o.parent == anchor][:32]


_NOTE_REF = re.compile(r"\(([^()]*)\)")


def foreign_note_ids(
    clause: ConstraintClause, parents: Mapping[str, str | None], object_ids: Collection[str]
) -> list[str]:
    """Object ids a clause's ``layout_note`` names in parentheses that are outside its unit.

    A clause may mention only its own anchor and that anchor's children (``parents`` maps an
    object id to its support parent). Parenthesised words that are not object ids are ignored.
    """
    out: list[str] = []
    for group in _NOTE_REF.findall(clause.layout_note):
        for token in (t.strip() for t in group.split(",")):
            inside = token == clause.anchor_id or parents.get(token) == clause.anchor_id
            if token in object_ids and not inside and token not in out:
                out.append(token)
    return out


def _clause(anchor: str, related: list[str], note: str) -> ConstraintClause:
    return ConstraintClause(anchor_id=anchor, related_objects=related[:32], layout_note=note[:400])


@dataclass(frozen=True)
class _Found:
    """A functional relation found in the scene: ``subjects`` relate to ``reference``."""

    pair: str
    kind: str
    description: str
    subjects: tuple[ObjectFacts, ...]
    reference: ObjectFacts
    same_unit_note: str
    """Clause of the unit holding subjects and reference (names both)."""
    reference_unit_note: str
    """Clause of the reference's own unit (names the reference and its children only)."""
    subject_note: str = ""
    """Clause of the subjects' unit when the reference lives in another unit (names subjects only)."""
    reference_note: str = ""
    """Clause of the reference's parent unit in that case (names the reference only)."""


def _edge_name(seat: ObjectFacts, table: ObjectFacts) -> str:
    """Which edge of ``table`` (in its own frame: front, back, left or right) ``seat`` is pulled up to."""
    way = np.subtract(seat.center, table.center)
    front = table.front
    right = np.array([-front[1], front[0]])  # the table's right hand, looking out of its front
    along, across = (
        float(way @ front) / max(table.size[1] / 2, 1e-6),
        float(way @ right) / max(table.size[0] / 2, 1e-6),
    )
    if abs(along) >= abs(across):
        return "front" if along > 0 else "back"
    return "right" if across > 0 else "left"


def _facing(subject: ObjectFacts, target: ObjectFacts, max_deg: float) -> bool:
    """Whether ``subject``'s front points at ``target``'s footprint within ``max_deg``."""
    way = np.subtract(target.center, subject.center)
    n = float(np.linalg.norm(way))
    if n < 1e-6:
        return True
    return float(subject.front @ way) / n >= math.cos(math.radians(max_deg))


def find_functional_relations(evidence: ConstraintEvidence) -> list[_Found]:
    """The strong functional relations of the scene, found from categories and geometry.

    * seats (chairs, stools) with their table or desk: the nearest table-like piece within
      :data:`SEAT_REACH` of the seat's footprint, on the same support; the note gives the edge
      each seat is pulled up to;
    * nightstands at the head end of a bed (within :data:`NIGHTSTAND_REACH` of its footprint and
      level with the back half of the bed);
    * screens on a desk or table keeping its orientation;
    * a wall TV over the one TV stand standing against the same wall;
    * the largest sofa with the one coffee table within :data:`COFFEE_REACH` it faces, and with
      the one TV stand within :data:`TV_REACH` it faces.

    Each kind is used only when its row of :data:`FUNCTIONAL_PAIRS` is allowed.
    """
    objs = evidence.objects
    allowed = set(evidence.pairs)
    found: list[_Found] = []
    tables = [o for o in objs if traits(o.category).table and o.parent]
    seats = [
        o for o in objs if traits(o.category).seat and not ("sofa" in o.category or o.category == "armchair")
    ]
    screens_of = {t.id: [o for o in objs if o.parent == t.id and o.category in MONITORS] for t in tables}
    if {"seats_face_table", "desk_chair"} & allowed and tables:
        owned: dict[str, list[ObjectFacts]] = {}
        for seat in seats:
            t = min(tables, key=lambda t: _dist(seat, t))
            if _dist(seat, t) <= SEAT_REACH and seat.parent and seat.parent == t.parent:
                owned.setdefault(t.id, []).append(seat)
        for t in tables:
            group = owned.get(t.id)
            if not group:
                continue
            names = ", ".join(s.id for s in group)
            edges = "; ".join(f"({s.id}) at its {_edge_name(s, t)} edge" for s in group)
            screens = screens_of.get(t.id, [])
            keep = (
                f"keep ({', '.join(s.id for s in screens)}) facing the way ({t.id})'s front faces"
                if screens
                else f"keep the edges of ({t.id}) where its seats sit clear"
            )
            found.append(
                _Found(
                    "seats_face_table",
                    "orientation",
                    f"seats ({names}) face {t.category} ({t.id})",
                    tuple(group),
                    t,
                    f"turn each of ({names}) to face ({t.id}): {edges}",
                    f"({t.id}) is the reference its seats face; {keep}",
                )
            )
    if "nightstands_beside_bed" in allowed:
        for b in (
            o for o in objs if is_bed(o.category) and traits(o.category).placement == "floor" and o.parent
        ):
            axis = -b.front  # toward the head end
            stands = [
                o
                for o in objs
                if o.category == "nightstand"
                and o.parent == b.parent
                and _dist(o, b) <= NIGHTSTAND_REACH
                and float(np.subtract(o.center, b.center) @ axis) > 0.0
            ]
            if stands:
                names = ", ".join(s.id for s in stands)
                found.append(
                    _Found(
                        "nightstands_beside_bed",
                        "placement",
                        f"nightstands ({names}) stand beside the head of {b.category} ({b.id})",
                        tuple(stands),
                        b,
                        f"keep ({names}) beside the head end of ({b.id}), level with its headboard",
                        f"({b.id}) keeps its head end where the nightstands stand; what lies on it stays on the bed",
                    )
                )
    if "monitor_keeps_desk_orientation" in allowed:
        for t in tables:
            screens = screens_of.get(t.id, [])
            if screens and t.id not in {f.reference.id for f in found}:
                names = ", ".join(s.id for s in screens)
                found.append(
                    _Found(
                        "monitor_keeps_desk_orientation",
                        "orientation",
                        f"({names}) keep the orientation of ({t.id})",
                        tuple(screens),
                        t,
                        "",
                        "",
                        subject_note=f"({names}) face the same way as ({t.id})'s front",
                        reference_note=f"({t.id})'s orientation is the reference for the screens on it",
                    )
                )
    if "wall_tv_over_stand" in allowed:
        for tv in (o for o in objs if o.category == "television" and (o.parent or "").startswith("wall")):
            stands = [o for o in objs if o.category == "tv_stand" and evidence.against.get(o.id) == tv.parent]
            if len(stands) == 1 and stands[0].parent:
                st = stands[0]
                found.append(
                    _Found(
                        "wall_tv_over_stand",
                        "placement",
                        f"wall TV ({tv.id}) and TV stand ({st.id}) share a centre line on {tv.parent}",
                        (tv,),
                        st,
                        "",
                        "",
                        subject_note=f"keep ({tv.id}) centred on the centre line it shares with the TV stand below it",
                        reference_note=f"keep ({st.id}) against {tv.parent}, centred under the TV mounted on that wall",
                    )
                )
    sofas = sorted((o for o in objs if "sofa" in o.category and o.parent), key=lambda o: -o.area)
    if sofas:
        sofa = sofas[0]
        coffees = [
            o for o in objs if o.category in ("coffee_table", "tea_table") and _dist(o, sofa) <= COFFEE_REACH
        ]
        if "sofa_faces_coffee_table" in allowed and len(coffees) == 1 and sofa.parent == coffees[0].parent:
            ct = coffees[0]
            found.append(
                _Found(
                    "sofa_faces_coffee_table",
                    "orientation",
                    f"{sofa.category} ({sofa.id}) faces {ct.category} ({ct.id})",
                    (sofa,),
                    ct,
                    f"({sofa.id}) faces ({ct.id}), which stays in front of it",
                    f"({ct.id}) is the reference the sofa in front of it faces",
                )
            )
        stands = [o for o in objs if o.category == "tv_stand"]
        if (
            "sofa_faces_tv" in allowed
            and len(stands) == 1
            and stands[0].parent == sofa.parent
            and _dist(stands[0], sofa) <= TV_REACH
            and _facing(sofa, stands[0], 60.0)
        ):
            st = stands[0]
            found.append(
                _Found(
                    "sofa_faces_tv",
                    "orientation",
                    f"{sofa.category} ({sofa.id}) faces the TV stand ({st.id})",
                    (sofa,),
                    st,
                    f"({sofa.id}) faces ({st.id})",
                    f"({st.id}) is the reference the sofa faces; what stands on it faces out of its front",
                )
            )
    return found


def solve_constraints(evidence: ConstraintEvidence) -> ConstraintsOutput:
    """The constraint rule solver: :func:`find_functional_relations`, each split by where it lives.

    * subjects and reference in different units (a wall TV and a floor TV stand; screens on a desk
      and the desk on the floor): one clause in each of the two units;
    * in one unit, with the reference carrying things of its own (a desk with a monitor, a bed with
      pillows): one clause in the shared unit, one in the reference's unit;
    * in one unit, with a reference that carries nothing (a bare dining table): not a cross-unit
      constraint but a relation inside the unit, ``faces`` (seats, sofas) or ``beside``
      (nightstands), for the unit's own evolution.
    """
    units = evidence.units
    out: list[CrossUnitConstraint] = []
    within: list[UnitRelation] = []
    for f in find_functional_relations(evidence):
        ref = f.reference
        homes = {s.parent for s in f.subjects}
        if len(homes) != 1 or ref.parent is None:
            continue
        home = homes.pop()
        assert home is not None
        subject_ids = [s.id for s in f.subjects]
        if home != ref.parent:
            a = _clause(home, subject_ids, f.subject_note)
            b = _clause(ref.parent, [ref.id], f.reference_note)
        elif units.get(ref.id):
            a = _clause(home, [*subject_ids, ref.id], f.same_unit_note)
            b = _clause(ref.id, units[ref.id], f.reference_unit_note)
        else:
            kind = "beside" if f.kind == "placement" else "faces"
            within += [UnitRelation(kind=kind, object_id=s, reference_id=ref.id) for s in subject_ids]
            continue
        if len(out) == MAX_CONSTRAINTS:
            continue
        out.append(
            CrossUnitConstraint(
                id=f"c{len(out)}",
                kind=f.kind,
                description=f.description[:400],
                anchor_a=a,
                anchor_b=b,  # type: ignore[arg-type]
            )
        )
    return ConstraintsOutput(constraints=out, within_unit=within)


def _functional(category: str) -> bool:
    """Whether objects of ``category`` can take part in a functional pair."""
    t = traits(category)
    return (
        t.seat
        or t.table
        or is_bed(category)
        or "sofa" in category
        or category in {"nightstand", "coffee_table", "tea_table", "tv_stand", *MONITORS}
    )


def _weak(categories: set[str]) -> bool:
    return any(categories & a and categories & b and not (categories - a - b) for a, b in WEAK_PAIRS)


class ConstraintsAgent(FloorPlanImages, TaskAgent[SceneState, ConstraintEvidence, ConstraintsOutput]):
    """Finds the strong functional relations spanning units and splits each into two clauses."""

    name: ClassVar[str] = "constraints"
    depends_on: ClassVar[tuple[str, ...]] = ("support", "containment")
    prompt: ClassVar[str] = "constraints"
    reply_tokens: ClassVar[tuple[int, int] | None] = (900, 10)
    prompt_omit: ClassVar[frozenset[str]] = frozenset({"bottom", "top", "relation", "label"})
    object_ref_fields: ClassVar[tuple[str, ...]] = (
        "constraints.anchor_a.related_objects",
        "constraints.anchor_b.related_objects",
        "within_unit.object_id",
        "within_unit.reference_id",
    )

    def needed(self, summary: SceneSummary) -> Need:
        """When a functional pair (seats and a table, a bed and nightstands, ...) is present."""
        pairs = tuple(summary.functional_pairs)
        why = "functional pairs: " + ", ".join(pairs) if pairs else "no functional pair in the scene"
        return Need(bool(pairs), why, evidence=pairs, insist="functional pairs are present")

    def __init__(self, priors_dir: str | Path | None = None) -> None:
        """``priors_dir``: ProcTHOR folder with ``asset_groups/`` (default: the priors shipped with the package)."""
        self.priors_dir = str(priors_dir if priors_dir is not None else PROCTHOR_PRIORS_DIR)

    def gather(self, state: SceneState) -> ConstraintEvidence:
        groups = procthor_group_pairs(self.priors_dir)
        allowed = [
            p.name
            for p in FUNCTIONAL_PAIRS
            if not groups or p.procthor is None or p.procthor in groups or _reverse(p.procthor) in groups
        ]
        scene = state.scene
        objects = object_facts(scene)
        against = flush_walls(objects, room_facts(scene))  # the geometry: this agent runs beside the walls agent
        units: dict[str, list[str]] = {}
        for r in scene.relations:
            if r.is_support:
                units.setdefault(r.parent, []).append(r.child)
        return ConstraintEvidence(objects=objects, against=against, pairs=allowed, units=units)

    def solve(self, evidence: ConstraintEvidence) -> ConstraintsOutput:
        return solve_constraints(evidence)

    def render_evidence_text(self, evidence: ConstraintEvidence) -> str:
        """Only the objects of functional categories (seats, tables, beds, nightstands, sofas,
        screens, TV stands): no other object can take part in a constraint."""
        keep = {o.id for o in evidence.objects if _functional(o.category)}
        units = {
            anchor: [c for c in kids if c in keep]
            for anchor, kids in evidence.units.items()
            if anchor in keep or anchor not in {o.id for o in evidence.objects}
        }
        slim = evidence.model_copy(
            update={
                "objects": [o for o in evidence.objects if o.id in keep],
                "against": {k: v for k, v in evidence.against.items() if k in keep},
                "units": {k: v for k, v in units.items() if v},
            }
        )
        return evidence_text(slim, omit=self.prompt_omit, extra=self.prompt_extra)

    def check(self, output: ConstraintsOutput, state: SceneState) -> list[str]:
        scene = state.scene
        anchors = scene.anchor_ids()
        parents = {r.child: r.parent for r in scene.relations if r.is_support}
        cats = {o.id: traits_key(o.category) for o in scene.objects}
        problems: list[str] = []
        ids = [c.id for c in output.constraints]
        if len(set(ids)) != len(ids):
            problems.append("constraint ids must be unique")
        for c in output.constraints:
            involved: set[str] = set()
            for clause in (c.anchor_a, c.anchor_b):
                if clause.anchor_id not in anchors:
                    problems.append(f"constraint {c.id!r}: anchor {clause.anchor_id!r} does not exist")
                    continue
                if clause.anchor_id not in set(parents.values()):
                    problems.append(
                        f"constraint {c.id!r}: {clause.anchor_id!r} carries nothing, so it anchors no unit; "
                        "a relation inside one unit goes in within_unit, not in a constraint"
                    )
                if clause.anchor_id in cats:
                    involved.add(cats[clause.anchor_id])
                for oid in clause.related_objects:
                    if oid not in cats:
                        continue  # the base check reports it
                    if parents.get(oid) != clause.anchor_id:
                        problems.append(
                            f"constraint {c.id!r}: ({oid}) is not in the unit of {clause.anchor_id!r} "
                            f"(its parent is {parents.get(oid)!r}); a clause may only name its own unit's objects"
                        )
                    else:
                        involved.add(cats[oid])
                for oid in foreign_note_ids(clause, parents, cats):
                    problems.append(
                        f"constraint {c.id!r}: the layout note of {clause.anchor_id!r} names ({oid}), which is not "
                        f"in that unit (its parent is {parents.get(oid)!r}); name only the unit's own objects"
                    )
            if _weak(involved):
                problems.append(
                    f"constraint {c.id!r} relates a weak pair ({', '.join(sorted(involved))}); drop it"
                )
        for w in output.within_unit:
            if w.object_id in cats and w.reference_id in cats:
                if w.object_id == w.reference_id:
                    problems.append(f"within_unit: {w.object_id!r} cannot relate to itself")
                elif parents.get(w.object_id) != parents.get(w.reference_id):
                    problems.append(
                        f"within_unit: ({w.object_id}) and ({w.reference_id}) are in different units "
                        f"(parents {parents.get(w.object_id)!r} and {parents.get(w.reference_id)!r}); "
                        "relate them with a constraint instead"
                    )
        return problems

    def apply(self, output: ConstraintsOutput, state: SceneState) -> None:
        scene = state.scene
        relations = [r for r in scene.relations if r.kind not in ("faces", "beside")]
        relations += [
            Relation(kind=w.kind, child=w.object_id, parent=w.reference_id, source=self.name)
            for w in output.within_unit
        ]
        state.scene = replace_scene(scene, constraints=list(output.constraints), relations=relations)


def traits_key(category: str) -> str:
    """The category name used by :data:`WEAK_PAIRS` (normalized)."""
    return normalize_category(category)


def _reverse(pair: tuple[str, str] | None) -> tuple[str, str] | None:
    return None if pair is None else (pair[1], pair[0])

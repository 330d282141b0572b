"""Cross-unit constraints: the few strong functional relations that span local units.

Rule solver: a table of functional pairs (:data:`FUNCTIONAL_PAIRS`), each one informed by a
ProcTHOR asset group where one exists (dining table + chairs, desk + chair, TV stand + TV +
sofa), plus bed ↔ nightstands, which ProcTHOR's groups lack. A pair becomes a constraint only
when it is unique and unambiguous (one coffee table in front of the sofa, one TV stand in the
room...). Weak pairs — a painting and the sofa below it, a wall display and a central table —
are never emitted (:data:`WEAK_PAIRS`), since they would freeze layouts for no functional reason.

Each constraint is split into two clauses that each name one anchor and only objects of that
anchor's unit; the shared reference is usually the anchor object itself (the table in
"chairs face the table": the floor clause turns the chairs toward it, the table clause keeps the
table's own frame the reference for what stands on it).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import ClassVar

from pydantic import BaseModel, Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, SceneState, TaskAgent
from scenemosaic.scene import (
    PROCTHOR_PRIORS_DIR,
    ConstraintClause,
    CrossUnitConstraint,
    normalize_category,
    traits,
)
from scenemosaic.structure._facts import ObjectFacts, object_facts, replace_scene
from scenemosaic.structure._views import FloorPlanImages

__all__ = [
    "FUNCTIONAL_PAIRS",
    "WEAK_PAIRS",
    "ConstraintEvidence",
    "ConstraintsAgent",
    "ConstraintsOutput",
    "FunctionalPair",
    "foreign_note_ids",
    "procthor_group_pairs",
]

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


class ConstraintsOutput(AgentOutput):
    """The cross-unit constraints of the scene (replacing any earlier ones)."""

    constraints: list[CrossUnitConstraint] = Field(default_factory=list, max_length=64)


class ConstraintEvidence(AgentOutput):
    """Objects with their parents, wall relations, and the ProcTHOR-backed pair table."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    against: dict[str, str] = Field(
        default_factory=dict, description="Object id -> wall it stands flush against."
    )
    pairs: list[str] = Field(
        default_factory=list, max_length=32, description="Allowed functional pair names."
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


def solve_constraints(evidence: ConstraintEvidence) -> ConstraintsOutput:
    """The constraint rule solver (see the module docstring)."""
    objs = evidence.objects
    allowed = set(evidence.pairs)
    out: list[CrossUnitConstraint] = []

    def add(kind: str, desc: str, a: ConstraintClause, b: ConstraintClause) -> None:
        if a.anchor_id != b.anchor_id:
            out.append(
                CrossUnitConstraint(
                    id=f"c{len(out)}",
                    kind=kind,
                    description=desc[:400],  # type: ignore[arg-type]
                    anchor_a=a,
                    anchor_b=b,
                )
            )

    tables = [o for o in objs if traits(o.category).table and o.parent]
    seats = [
        o for o in objs if traits(o.category).seat and not ("sofa" in o.category or o.category == "armchair")
    ]
    # seats -> nearest table/desk
    if {"seats_face_table", "desk_chair"} & allowed and tables:
        owned: dict[str, list[ObjectFacts]] = {}
        for s in seats:
            t = min(tables, key=lambda t: _dist(s, t))
            if _dist(s, t) <= SEAT_REACH and s.parent and s.parent == t.parent:
                owned.setdefault(t.id, []).append(s)
        for t in tables:
            group = owned.get(t.id)
            if not group or t.parent is None:
                continue
            names = ", ".join(s.id for s in group)
            add(
                "orientation",
                f"chairs ({names}) face {t.category} ({t.id})",
                _clause(
                    t.parent,
                    [*(s.id for s in group), t.id],
                    f"turn each of ({names}) to face ({t.id}) and keep them along its edges",
                ),
                _clause(
                    t.id,
                    _children(objs, t.id),
                    f"({t.id}) is the reference the chairs face; keep its edges free where they sit",
                ),
            )
    # bed <-> nightstands
    if "nightstands_beside_bed" in allowed:
        for b in (o for o in objs if "bed" in o.category and traits(o.category).placement == "floor"):
            stands = [
                o
                for o in objs
                if o.category == "nightstand" and o.parent == b.parent and _dist(o, b) <= NIGHTSTAND_REACH
            ]
            if not stands or b.parent is None:
                continue
            names = ", ".join(s.id for s in stands)
            add(
                "placement",
                f"nightstands ({names}) stand beside the head of {b.category} ({b.id})",
                _clause(
                    b.parent,
                    [b.id, *(s.id for s in stands)],
                    f"keep ({names}) beside the head end of ({b.id}), level with its headboard",
                ),
                _clause(
                    b.id, _children(objs, b.id), f"({b.id}) keeps its head end where the nightstands stand"
                ),
            )
    # desk -> monitor orientation
    if "monitor_keeps_desk_orientation" in allowed:
        for t in tables:
            screens = [o for o in objs if o.parent == t.id and o.category in MONITORS]
            if screens and t.parent:
                names = ", ".join(s.id for s in screens)
                add(
                    "orientation",
                    f"({names}) keep the orientation of ({t.id})",
                    _clause(
                        t.id, [s.id for s in screens], f"({names}) face the same way as ({t.id})'s front"
                    ),
                    _clause(
                        t.parent, [t.id], f"({t.id})'s orientation is the reference for the screens on it"
                    ),
                )
    # wall TV <-> floor TV stand on the same wall
    if "wall_tv_over_stand" in allowed:
        for tv in (o for o in objs if o.category == "television" and (o.parent or "").startswith("wall")):
            stands = [o for o in objs if o.category == "tv_stand" and evidence.against.get(o.id) == tv.parent]
            if len(stands) == 1 and stands[0].parent and tv.parent:
                st = stands[0]
                add(
                    "placement",
                    f"wall TV ({tv.id}) and TV stand ({st.id}) share a centre line on {tv.parent}",
                    _clause(
                        tv.parent,
                        [tv.id],
                        f"keep ({tv.id}) centred on the centre line it shares with the TV stand below it",
                    ),
                    _clause(
                        str(st.parent),
                        [st.id],
                        f"keep ({st.id}) against {tv.parent}, centred under the TV mounted on that wall",
                    ),
                )
    # sofa -> coffee table / TV stand (only unique pairs)
    sofas = sorted((o for o in objs if "sofa" in o.category), key=lambda o: -o.area)
    if sofas:
        sofa = sofas[0]
        coffees = [
            o for o in objs if o.category in ("coffee_table", "tea_table") and _dist(o, sofa) <= COFFEE_REACH
        ]
        if (
            "sofa_faces_coffee_table" in allowed
            and len(coffees) == 1
            and sofa.parent == coffees[0].parent
            and sofa.parent
        ):
            ct = coffees[0]
            add(
                "orientation",
                f"{sofa.category} ({sofa.id}) faces {ct.category} ({ct.id})",
                _clause(
                    sofa.parent, [sofa.id, ct.id], f"({sofa.id}) faces ({ct.id}), which stays in front of it"
                ),
                _clause(
                    ct.id, _children(objs, ct.id), f"({ct.id}) is the reference the sofa in front of it faces"
                ),
            )
        stands = [o for o in objs if o.category == "tv_stand"]
        if (
            "sofa_faces_tv" in allowed
            and len(stands) == 1
            and len(sofas) >= 1
            and sofa.parent
            and stands[0].parent == sofa.parent
            and _dist(stands[0], sofa) <= TV_REACH
        ):
            st = stands[0]
            way = (st.center[0] - sofa.center[0], st.center[1] - sofa.center[1])
            n = math.hypot(*way)
            if n > 1e-6 and (sofa.front[0] * way[0] + sofa.front[1] * way[1]) / n > 0.5:
                add(
                    "orientation",
                    f"{sofa.category} ({sofa.id}) faces the TV stand ({st.id})",
                    _clause(sofa.parent, [sofa.id, st.id], f"({sofa.id}) faces ({st.id})"),
                    _clause(st.id, _children(objs, st.id), f"({st.id}) is the reference the sofa faces"),
                )
    return ConstraintsOutput(constraints=out)


def _weak(categories: set[str]) -> bool:
    return any(categories & a and categories & b and not (categories - a - b) for a, b in WEAK_PAIRS)


class ConstraintsAgent(FloorPlanImages, TaskAgent[ConstraintEvidence, ConstraintsOutput]):
    """Finds the strong functional relations spanning units and splits each into two clauses."""

    name: ClassVar[str] = "constraints"
    depends_on: ClassVar[tuple[str, ...]] = ("support", "containment", "walls", "semantics")
    prompt: ClassVar[str] = "constraints"
    output_type: ClassVar[type[BaseModel]] = ConstraintsOutput

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
        against = {r.child: r.parent for r in state.scene.relations if r.kind == "against"}
        return ConstraintEvidence(objects=object_facts(state.scene), against=against, pairs=allowed)

    def solve(self, evidence: ConstraintEvidence) -> ConstraintsOutput:
        return solve_constraints(evidence)

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
                if clause.anchor_id in cats:
                    involved.add(cats[clause.anchor_id])
                for oid in clause.related_objects:
                    if oid not in cats:
                        problems.append(
                            f"constraint {c.id!r}: object id {oid!r} does not exist in this scene"
                        )
                    elif parents.get(oid) != clause.anchor_id:
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
        return problems

    def apply(self, output: ConstraintsOutput, state: SceneState) -> None:
        state.scene = replace_scene(state.scene, constraints=list(output.constraints))


def traits_key(category: str) -> str:
    """The category name used by :data:`WEAK_PAIRS` (normalized)."""
    return normalize_category(category)


def _reverse(pair: tuple[str, str] | None) -> tuple[str, str] | None:
    return None if pair is None else (pair[1], pair[0])

"""Verification: the last pass over the structured scene, fixing what it can and reporting the rest.

Rule solver: an object with no parent goes to the floor (the ceiling for ceiling fixtures); a
parent cycle is broken by standing its lowest member on the floor; a constraint whose clauses
name missing objects, or objects outside the clause's unit (in ``related_objects`` or in
parentheses in its layout note), is dropped. Apply then builds the
scene tree (:func:`scenemosaic.scene._tree.build_structure`) so every unit is non-empty by
construction; anything left over is reported in the scene's provenance notes.
"""

from __future__ import annotations

from typing import ClassVar

from pydantic import BaseModel, Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, SceneState, TaskAgent
from scenemosaic.scene import CEILING, FLOOR, CrossUnitConstraint, Relation, build_structure, traits
from scenemosaic.structure._constraints import foreign_note_ids
from scenemosaic.structure._facts import ObjectFacts, object_facts, parent_cycles, replace_scene

__all__ = ["ParentFix", "VerificationAgent", "VerificationEvidence", "VerificationOutput"]


class ParentFix(AgentOutput):
    """Give an object a (new) support parent."""

    object_id: str = Field(max_length=64)
    parent: str = Field(max_length=64)
    reason: str = Field(default="", max_length=200)


class VerificationOutput(AgentOutput):
    """Fixes to apply and problems to report."""

    fixes: list[ParentFix] = Field(default_factory=list, max_length=MAX_ITEMS)
    drop_constraints: list[str] = Field(default_factory=list, max_length=64)
    problems: list[str] = Field(default_factory=list, max_length=64)


class VerificationEvidence(AgentOutput):
    """Objects with their parents, and the constraints."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    constraints: list[CrossUnitConstraint] = Field(default_factory=list, max_length=64)
    anchors: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Every valid anchor id."
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
            fixes.append(ParentFix(object_id=o.id, parent=host.id, reason=f"a {o.category} on the floor beside the {host.category} belongs on it"))
            parents[o.id] = host.id
    return fixes


def solve_verification(evidence: VerificationEvidence) -> VerificationOutput:
    """The verification rule solver (see the module docstring)."""
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
    problems: list[str] = []
    fixes += _soft_things_on_the_floor(evidence.objects, parents)
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
    return VerificationOutput(fixes=fixes, drop_constraints=drop, problems=problems)


class VerificationAgent(TaskAgent[VerificationEvidence, VerificationOutput]):
    """Checks completeness (one parent each, no cycles, valid constraints), fixes, and builds the tree."""

    name: ClassVar[str] = "verify"
    runs_last: ClassVar[bool] = True
    prompt: ClassVar[str] = "verify"
    output_type: ClassVar[type[BaseModel]] = VerificationOutput

    def gather(self, state: SceneState) -> VerificationEvidence:
        return VerificationEvidence(
            objects=object_facts(state.scene),
            constraints=list(state.scene.constraints),
            anchors=sorted(state.scene.anchor_ids()),
        )

    def solve(self, evidence: VerificationEvidence) -> VerificationOutput:
        return solve_verification(evidence)

    def check(self, output: VerificationOutput, state: SceneState) -> list[str]:
        scene = state.scene
        anchors = scene.anchor_ids()
        objects = {o.id for o in scene.objects}
        problems: list[str] = []
        parents = {r.child: r.parent for r in scene.relations if r.is_support}
        for f in output.fixes:
            if f.object_id not in objects:
                problems.append(f"object id {f.object_id!r} does not exist in this scene")
            elif f.parent not in anchors or f.parent == f.object_id:
                problems.append(f"parent {f.parent!r} of {f.object_id!r} is not a valid anchor")
            else:
                parents[f.object_id] = f.parent
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
        rels += [
            Relation(kind="attach", child=f.object_id, parent=f.parent, source=self.name)
            for f in output.fixes
        ]
        drop = set(output.drop_constraints)
        constraints = [c for c in scene.constraints if c.id not in drop]
        notes = [*scene.provenance.notes, *(f"verify: {p}" for p in output.problems)]
        notes += [f"verify: {f.object_id} -> {f.parent} ({f.reason})" for f in output.fixes]
        scene = replace_scene(
            scene,
            relations=rels,
            constraints=constraints,
            provenance=scene.provenance.model_copy(update={"notes": notes}),
        )
        state.scene = replace_scene(scene, structure=build_structure(scene))

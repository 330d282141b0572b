"""Containment: objects inside cabinets, shelves, bookcases, boxes — and where each container opens.

Rule solver: an object (that is not floor furniture) whose box lies inside a container's box —
centre within the container's footprint, bottom and top within the container's height — is
contained by the smallest such container. The opening comes from the container's category:
shelves, cabinets, wardrobes open to the front; boxes, baskets and bins open at the top.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, Literal

from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent, evidence_text
from scenemosaic.scene import Relation, SupportPriors, load_priors, traits
from scenemosaic.structure._facts import ObjectFacts, object_facts, replace_scene
from scenemosaic.structure._support import check_parents, floor_only
from scenemosaic.structure._views import FloorPlanImages

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = ["ContainedItem", "ContainerFacts", "ContainmentAgent", "ContainmentEvidence", "ContainmentOutput"]

INSIDE_TOLERANCE = 0.02
"""How far (metres) a contained object may poke out of its container's box."""


class ContainedItem(AgentOutput):
    """One object inside one container."""

    object_id: str = Field(max_length=64)
    container_id: str = Field(max_length=64)
    opening: Literal["front", "top", "back", "left", "right"] = "front"
    reason: str = Field(default="", max_length=200)


class ContainmentOutput(AgentOutput):
    """Every contained object; objects not listed keep their support."""

    items: list[ContainedItem] = Field(default_factory=list, max_length=MAX_ITEMS)


class ContainerFacts(AgentOutput):
    """A container candidate and the side it usually opens to."""

    id: str
    category: str
    opening: Literal["front", "top"]


class ContainmentEvidence(AgentOutput):
    """Objects, and which of them can contain others."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)
    containers: list[ContainerFacts] = Field(max_length=MAX_ITEMS)


def _volume(o: ObjectFacts) -> float:
    return o.area * max(o.top - o.bottom, 1e-6)


def inside(child: ObjectFacts, box: ObjectFacts) -> bool:
    """Whether ``child``'s box lies inside ``box``'s (centre in footprint, height within)."""
    return (
        box.contains_point(child.center, INSIDE_TOLERANCE)
        and box.bottom - INSIDE_TOLERANCE <= child.bottom
        and child.top <= box.top + INSIDE_TOLERANCE
        and _volume(box) > _volume(child)
    )


def solve_containment(evidence: ContainmentEvidence, priors: SupportPriors) -> ContainmentOutput:
    """The containment rule solver (see the module docstring)."""
    facts = {o.id: o for o in evidence.objects}
    items: list[ContainedItem] = []
    for o in evidence.objects:
        if floor_only(o, priors) or traits(o.category).placement in ("ceiling", "wall"):
            continue
        holders = [facts[c.id] for c in evidence.containers if c.id != o.id and inside(o, facts[c.id])]
        if not holders:
            continue
        box = min(holders, key=_volume)
        opening = next(c.opening for c in evidence.containers if c.id == box.id)
        items.append(
            ContainedItem(
                object_id=o.id, container_id=box.id, opening=opening, reason=f"inside {box.category}"
            )
        )
    return ContainmentOutput(items=items)


class ContainmentAgent(FloorPlanImages, TaskAgent[SceneState, ContainmentEvidence, ContainmentOutput]):
    """Finds objects inside containers and the side each container opens to."""

    name: ClassVar[str] = "containment"
    depends_on: ClassVar[tuple[str, ...]] = ("support",)
    prompt: ClassVar[str] = "containment"
    reply_tokens: ClassVar[tuple[int, int] | None] = (200, 40)
    object_id_fields: ClassVar[tuple[str, ...]] = ("items.object_id",)

    def needed(self, summary: SceneSummary) -> Need:
        """When some object stands over a container's footprint (it may be inside)."""
        found = tuple(summary.container_candidates)
        why = f"{len(found)} objects over containers" if found else "nothing could be inside a container"
        return Need(bool(found), why, evidence=found, insist="objects stand over a container")

    def __init__(self, priors: SupportPriors | None = None) -> None:
        self.priors = priors if priors is not None else load_priors()

    def gather(self, state: SceneState) -> ContainmentEvidence:
        objs = object_facts(state.scene)
        containers = [
            ContainerFacts(id=o.id, category=o.category, opening=traits(o.category).opening or "front")
            for o in objs
            if traits(o.category).contains
        ]
        return ContainmentEvidence(objects=objs, containers=containers)

    def solve(self, evidence: ContainmentEvidence) -> ContainmentOutput:
        return solve_containment(evidence, self.priors)

    def render_evidence_text(self, evidence: ContainmentEvidence) -> str:
        """Only the containers and the objects standing over one: nothing else can be inside."""
        boxes = {c.id for c in evidence.containers}
        shells = [o for o in evidence.objects if o.id in boxes]
        over = {o.id for o in evidence.objects for c in shells if c.id != o.id and c.contains_point(o.center, 0.02)}
        slim = evidence.model_copy(update={"objects": [o for o in evidence.objects if o.id in boxes | over]})
        return evidence_text(slim, omit=self.prompt_omit, extra=self.prompt_extra)

    def check(self, output: ContainmentOutput, state: SceneState) -> list[str]:
        problems = check_parents(
            [(i.object_id, i.container_id, "contain") for i in output.items],
            state,
            self.priors,
            complete=False,
        )
        facts = {o.id: o for o in object_facts(state.scene)}
        for i in output.items:
            if i.object_id in facts and floor_only(facts[i.object_id], self.priors):
                problems.append(
                    f"{i.object_id!r} ({facts[i.object_id].category}) is floor furniture, not contents"
                )
        return problems

    def apply(self, output: ContainmentOutput, state: SceneState) -> None:
        moved = {i.object_id for i in output.items}
        kept = [r for r in state.scene.relations if not (r.is_support and r.child in moved)]
        new = [
            Relation(
                kind="contain", child=i.object_id, parent=i.container_id, opening=i.opening, source=self.name
            )
            for i in output.items
        ]
        state.scene = replace_scene(state.scene, relations=kept + new)

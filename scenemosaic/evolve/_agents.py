"""The evolution's task agents: critic, actor, archetype proposal and pose instantiation.

They are ordinary :class:`~scenemosaic.agents.TaskAgent` s working on an
:class:`EvolveState` (one evolving layout of one unit); the critic and the actor get one round's
input with it (:class:`RoundState`, :class:`RoundInput`), the pose agent its archetype
(:class:`PoseState`). Each has a rule solver, the offline default and the fallback of a real model:

* **critic** — words the rule findings (:func:`~scenemosaic.evolve.find_problems`) as notes,
  asks for no change when only soft remarks are left, and scores the layout;
* **actor** — writes pose expressions for the objects the notes name, from the fixes the
  findings carry (push apart, snap to a wall, turn to face...);
* **archetypes** — proposes structurally different arrangements (:mod:`._archetypes`);
* **pose** — instantiates one archetype into 2D poses for every child.

A model's answer is checked against the unit (ids that exist, objects the notes name, the
expression sandbox) and sent back with the problems when it fails; see ``docs/evolution.md``.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from typing import Any, ClassVar

from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, SceneState, TaskAgent
from scenemosaic.evolve._analysis import Finding, PhysicalCheck, merged_fixes
from scenemosaic.evolve._archetypes import instantiate, max_alternatives, rule_archetypes
from scenemosaic.evolve._context import UnitContext
from scenemosaic.evolve._memory import LayoutMemory
from scenemosaic.exceptions import ExpressionError
from scenemosaic.models import ImagePart
from scenemosaic.scene import UnitLayout, apply_expressions, normalize_degrees

__all__ = [
    "ActorAgent",
    "ActorOutput",
    "Archetype",
    "ArchetypeAgent",
    "ArchetypeOutput",
    "CriticAgent",
    "CriticOutput",
    "EvolveState",
    "PoseAgent",
    "PoseOutput",
    "PosePlacement",
    "PoseState",
    "RoundInput",
    "RoundState",
    "named_objects",
]

_NO_PROMPT: dict[str, Any] = {"prompt": False}


@dataclass(kw_only=True)
class EvolveState(SceneState):
    """One evolving layout: the scene it lives in, its unit context, current layout and memory.

    ``layout`` is what the actor's and the pose agent's ``apply`` write; the rest stays as the
    loop made it. What changes from round to round comes as a :class:`RoundInput`.
    """

    layout: UnitLayout
    context: UnitContext
    memory: LayoutMemory = field(default_factory=LayoutMemory)
    view: Callable[[UnitLayout], bytes] | None = None
    """The unit view PNG of a layout (for vision models); ``None``: no images."""
    alternatives: int | None = None
    """How many archetypes this unit may get; ``None``: the method's count for its size."""

    def shared(self) -> dict[str, Any]:
        """This state's fields (as :class:`EvolveState`'s), to build a :class:`RoundState` or :class:`PoseState` on:
        ``RoundState(**state.shared(), input=round_input)``."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(EvolveState)}


@dataclass(frozen=True)
class RoundInput:
    """What the critic and the actor are given for one round of the loop."""

    round: int
    check: PhysicalCheck
    """The physics check of the round's layout."""
    findings: tuple[Finding, ...] = ()
    """The rule findings on the round's layout."""
    notes: tuple[str, ...] = ()
    """The notes the actor carries out (the critic's, and one per object out of bounds); empty for the critic."""


@dataclass(kw_only=True)
class RoundState(EvolveState):
    """An evolving layout with one round's input: what the critic and the actor work on."""

    input: RoundInput


@dataclass(kw_only=True)
class PoseState(EvolveState):
    """An evolving layout with the archetype the pose agent instantiates."""

    archetype: Archetype


# -- evidence rows ----------------------------------------------------------------------------------


class ObjectRow(AgentOutput):
    """One child of the unit in the 2D view."""

    id: str
    category: str
    center: tuple[float, float] = Field(description="Centre (u, v) on the anchor surface, metres; u right, v up.")
    size: tuple[float, float] = Field(description="Extent of the object's box along u and along v.")
    bbox: tuple[float, float, float, float] = Field(description="Box as min_u, min_v, max_u, max_v.")
    rotation: float = Field(description="Facing: 0 down (-v), 90 left (-u), 180 up (+v), -90 right (+u).")


class UnitInfo(AgentOutput):
    """The unit being evolved."""

    anchor: str = Field(description="The anchor (never moves).")
    kind: str
    view: str = Field(description="How the view looks at the anchor surface.")
    surface: tuple[float, float] = Field(description="Size of the anchor surface: in-bounds u is 0..first, v is 0..second.")
    rotations_frozen: bool = Field(default=False, description="True when only centres may change.")
    walls: list[str] = Field(default_factory=list, description="Walls around a floor unit: id, from (u, v) to (u, v), inward side.")


class CollisionRow(AgentOutput):
    """Two objects whose collision shapes interpenetrate."""

    a: str
    b: str
    contacts: int = Field(description="Convex-piece pairs in contact.")
    depth: float = Field(description="Deepest interpenetration, metres.")


class CheckRow(AgentOutput):
    """A problem the geometric checks found."""

    kind: str
    severity: str
    note: str


class FixRow(AgentOutput):
    """What the rule solver would do for one object (solver input, not shown to models)."""

    object_id: str
    u: float | None = None
    v: float | None = None
    rotation: float | None = None
    symbolic: list[str] = Field(default_factory=list)


def _rows(layout: UnitLayout) -> list[ObjectRow]:
    out = []
    for s in layout.state().objects:
        out.append(
            ObjectRow(
                id=s.id, category=s.category, center=(s.center.u, s.center.v), size=(s.size.u, s.size.v),
                bbox=(s.bbox.min_u, s.bbox.min_v, s.bbox.max_u, s.bbox.max_v), rotation=s.rotation_degrees,
            )
        )
    return out


_VIEWS = {
    "top_down": "from above, looking down",
    "bottom_up": "from below, looking up at the ceiling",
    "wall_normal": "from inside the room, facing the wall",
    "anchor_front": "from in front of the anchor, looking into it",
}


def _unit_info(layout: UnitLayout, ctx: UnitContext) -> UnitInfo:
    s = layout.surface
    walls = []
    for w in ctx.walls:
        side = {(0, 1): "+v", (0, -1): "-v", (1, 0): "+u", (-1, 0): "-u"}.get(
            (round(w.inward[0]), round(w.inward[1])), f"{w.inward[0]:.2f},{w.inward[1]:.2f}"
        )
        a0, a1, b0, b1 = (round(x, 2) + 0.0 for x in (*w.a, *w.b))  # + 0.0: no "-0.00"
        walls.append(f"{w.id}: ({a0:.2f}, {a1:.2f}) to ({b0:.2f}, {b1:.2f}), room on its {side} side")
    return UnitInfo(
        anchor=s.anchor_id, kind=ctx.unit.anchor_kind, view=_VIEWS.get(s.projection, s.projection),
        surface=s.size, rotations_frozen=ctx.frozen_rotation, walls=walls,
    )  # fmt: skip


def _clauses(ctx: UnitContext) -> list[str]:
    return [f"{c.layout_note} (objects: {', '.join(c.related_objects) or 'the anchor'})" for c in ctx.clauses]


def _view_images(state: EvolveState, label: str) -> list[ImagePart]:
    if state.view is None:
        return []
    return [ImagePart(png=state.view(state.layout), label=label)]


_VIEW_LABEL = (
    "orthographic view of the unit: grid ticks in metres of (u, v) on the anchor surface, u right, v up; "
    "each object outlined with its id; arrows point where each object faces"
)


def named_objects(notes: list[str], layout: UnitLayout) -> set[str]:
    """Objects the notes name: by id (in parentheses or not), or every object of a category the
    notes name (``dining_chair``, ``dining chairs``)."""
    text = " ".join(notes).lower()
    out: set[str] = set()
    for oid in layout.ids:
        if re.search(r"(?<![\w.\-])" + re.escape(oid.lower()) + r"(?![\w\-])", text):
            out.add(oid)
    for oid in layout.ids:
        cat = layout.object(oid).category.lower()
        for form in {cat, cat.replace("_", " ")}:
            if re.search(r"(?<![\w.\-])" + re.escape(form) + r"(e?s)?(?![\w\-])", text):
                out.add(oid)
    return out


# -- critic -------------------------------------------------------------------------------------------


class CriticEvidence(AgentOutput):
    """What the critic looks at."""

    round: int
    unit: UnitInfo
    objects: list[ObjectRow] = Field(max_length=MAX_ITEMS)
    collisions: list[CollisionRow] = Field(default_factory=list, description="From the physics checker.")
    out_of_bounds: list[str] = Field(default_factory=list, description="Objects sticking out of the anchor surface (must be fixed).")
    clauses: list[str] = Field(default_factory=list, description="Cross-unit rules this unit must keep.")
    checks: list[CheckRow] = Field(default_factory=list, description="Problems the geometric rules found.")
    memory: str = Field(default="", description="Earlier rounds of this layout.")


class CriticOutput(AgentOutput):
    """The critic's judgement of one round."""

    should_modify: bool
    reasoning: str = Field(default="", max_length=2000)
    modification_notes: list[str] = Field(default_factory=list, max_length=24)
    quality_basis: str = Field(default="", max_length=800)
    quality_score: int = Field(ge=0, le=100)


_SEVERITY_COST = {"physical": 25, "semantic": 10, "soft": 3}


def solve_critic(evidence: CriticEvidence) -> CriticOutput:
    """Notes from the findings (most important first); no change when only soft remarks are left."""
    hard = [c for c in evidence.checks if c.severity != "soft"]
    cost = sum(_SEVERITY_COST.get(c.severity, 5) for c in evidence.checks)
    counts = {s: sum(1 for c in evidence.checks if c.severity == s) for s in ("physical", "semantic", "soft")}
    basis = f"{counts['physical']} physical, {counts['semantic']} semantic, {counts['soft']} soft problems"
    return CriticOutput(
        should_modify=bool(hard),
        reasoning="geometric and semantic rules of the room" + (": nothing to fix" if not hard else ""),
        modification_notes=[c.note for c in hard][:24],
        quality_basis=basis,
        quality_score=max(0, 100 - cost),
    )


class CriticAgent(TaskAgent[RoundState, CriticEvidence, CriticOutput]):
    """Judges one round of a unit layout and says what to change, in words."""

    name: ClassVar[str] = "critic"
    prompt: ClassVar[str] = "critic"
    reply_tokens: ClassVar[tuple[int, int] | None] = (500, 40)

    def gather(self, state: RoundState) -> CriticEvidence:
        layout, ctx, check = state.layout, state.context, state.input.check
        return CriticEvidence(
            round=state.input.round,
            unit=_unit_info(layout, ctx),
            objects=_rows(layout),
            collisions=[CollisionRow(a=p.a, b=p.b, contacts=p.contacts, depth=p.depth_m) for p in check.collisions],
            out_of_bounds=list(check.out_of_bounds),
            clauses=_clauses(ctx),
            checks=[CheckRow(kind=f.kind, severity=f.severity, note=f.note) for f in state.input.findings],
            memory=state.memory.text(),
        )

    def solve(self, evidence: CriticEvidence) -> CriticOutput:
        return solve_critic(evidence)

    def images(self, evidence: CriticEvidence, state: RoundState) -> list[ImagePart]:
        return _view_images(state, _VIEW_LABEL)

    def check(self, output: CriticOutput, state: RoundState) -> list[str]:
        layout, ctx = state.layout, state.context
        known = set(layout.ids) | {layout.surface.anchor_id} | {w.id for w in ctx.walls}
        known |= {o.id for o in ctx.obstacles}
        problems = []
        for note in output.modification_notes:
            for ref in re.findall(r"\(([^()]{1,80})\)", note):
                ref = ref.strip()
                if re.fullmatch(r"[A-Za-z][\w.\-]*_\d+", ref) and ref not in known:
                    problems.append(f"note names {ref!r}, which is not an object of this unit (objects: {', '.join(layout.ids)})")
        if output.should_modify and not output.modification_notes:
            problems.append("should_modify is true but there are no modification_notes")
        return problems


# -- actor ----------------------------------------------------------------------------------------------


class ActorEvidence(AgentOutput):
    """What the actor works from."""

    unit: UnitInfo
    objects: list[ObjectRow] = Field(max_length=MAX_ITEMS)
    notes: list[str] = Field(description="The critic's notes to carry out.")
    may_change: list[str] = Field(description="The only objects whose centre or rotation may be assigned.")
    memory: str = Field(default="", description="Earlier rounds of this layout.")
    fixes: list[FixRow] = Field(default_factory=list, json_schema_extra=_NO_PROMPT)


class ActorOutput(AgentOutput):
    """Pose expressions carrying out the notes."""

    reasoning: str = Field(default="", max_length=2000)
    pose_expressions: list[str] = Field(default_factory=list, max_length=64)


def _num(x: float, digits: int = 4) -> str:
    r = round(float(x), digits)
    return f"{r:.{digits}f}".rstrip("0").rstrip(".") if r != 0 else "0"


def solve_actor(evidence: ActorEvidence) -> ActorOutput:
    """Expressions for the named objects' fixes: rotation first (it changes the box), then centre."""
    allowed = set(evidence.may_change)
    lines: list[str] = []
    why: list[str] = []
    for fix in evidence.fixes:
        if fix.object_id not in allowed:
            continue
        oid = fix.object_id
        if fix.rotation is not None:
            lines.append(f"{oid}.rotation_degrees = {_num(fix.rotation, 2)}")
        if fix.symbolic:
            lines += fix.symbolic
            why.append(f"{oid} placed relative to its neighbour")
        elif fix.u is not None and fix.v is not None:
            lines += [f"{oid}.center.u = {_num(fix.u)}", f"{oid}.center.v = {_num(fix.v)}"]
            why.append(f"{oid} moved")
    return ActorOutput(reasoning="; ".join(why) or "no fix applies to the named objects", pose_expressions=lines)


class ActorAgent(TaskAgent[RoundState, ActorEvidence, ActorOutput]):
    """Turns the critic's notes into pose expressions, applied through the sandbox.

    A refused reply's reasons are in the run's result (``AgentResult.problems``)."""

    name: ClassVar[str] = "actor"
    prompt: ClassVar[str] = "actor"
    reply_tokens: ClassVar[tuple[int, int] | None] = (400, 40)

    def gather(self, state: RoundState) -> ActorEvidence:
        layout, ctx, notes = state.layout, state.context, list(state.input.notes)
        allowed = named_objects(notes, layout)
        fixes = merged_fixes(list(state.input.findings), allowed)
        return ActorEvidence(
            unit=_unit_info(layout, ctx),
            objects=_rows(layout),
            notes=notes,
            may_change=sorted(allowed),
            memory=state.memory.text(),
            fixes=[
                FixRow(object_id=k, u=t.u, v=t.v, rotation=t.rotation, symbolic=list(t.symbolic))
                for k, t in fixes.items()
            ],
        )

    def solve(self, evidence: ActorEvidence) -> ActorOutput:
        return solve_actor(evidence)

    def _try(self, output: ActorOutput, state: RoundState) -> tuple[UnitLayout, list[str]]:
        layout, ctx = state.layout, state.context
        trial = layout.copy()
        try:
            apply_expressions(
                trial, output.pose_expressions, allowed=named_objects(list(state.input.notes), layout), frozen_rotation=ctx.frozen_rotation
            )
        except ExpressionError as exc:
            return trial, list(exc.problems)
        return trial, []

    def check(self, output: ActorOutput, state: RoundState) -> list[str]:
        _, problems = self._try(output, state)
        return problems

    def apply(self, output: ActorOutput, state: RoundState) -> None:
        trial, problems = self._try(output, state)
        if not problems:
            state.layout = trial


# -- archetypes -------------------------------------------------------------------------------------------


class Archetype(AgentOutput):
    """A structurally different arrangement of a unit, in words (no coordinates)."""

    layout_id: str = Field(min_length=1, max_length=40, pattern=r"^[a-z0-9_]+$")
    layout_style_name: str = Field(min_length=1, max_length=80)
    layout_reasoning: str = Field(default="", max_length=600)


class ArchetypeEvidence(AgentOutput):
    """What the archetype agent looks at."""

    unit: UnitInfo
    objects: list[ObjectRow] = Field(max_length=MAX_ITEMS)
    clauses: list[str] = Field(default_factory=list, description="Cross-unit rules every variant must keep.")
    max_alternatives: int = Field(description="Propose at most this many (0 is fine when the layout is the only sensible one).")
    candidates: list[Archetype] = Field(default_factory=list, json_schema_extra=_NO_PROMPT)


class ArchetypeOutput(AgentOutput):
    """Alternative arrangements of the unit."""

    alternative_layouts: list[Archetype] = Field(default_factory=list, max_length=12)


class ArchetypeAgent(TaskAgent[EvolveState, ArchetypeEvidence, ArchetypeOutput]):
    """Proposes 0-3 structurally different design patterns for a unit."""

    name: ClassVar[str] = "archetypes"
    prompt: ClassVar[str] = "archetypes"
    reply_tokens: ClassVar[tuple[int, int] | None] = (500, 0)

    def gather(self, state: EvolveState) -> ArchetypeEvidence:
        layout, ctx = state.layout, state.context
        limit = state.alternatives if state.alternatives is not None else max_alternatives(len(layout.ids))
        return ArchetypeEvidence(
            unit=_unit_info(layout, ctx),
            objects=_rows(layout),
            clauses=_clauses(ctx),
            max_alternatives=limit,
            candidates=[Archetype(layout_id=a.layout_id, layout_style_name=a.style_name, layout_reasoning=a.reasoning) for a in rule_archetypes(layout, ctx, limit)],
        )

    def solve(self, evidence: ArchetypeEvidence) -> ArchetypeOutput:
        return ArchetypeOutput(alternative_layouts=list(evidence.candidates[: evidence.max_alternatives]))

    def images(self, evidence: ArchetypeEvidence, state: EvolveState) -> list[ImagePart]:
        return _view_images(state, _VIEW_LABEL)

    def check(self, output: ArchetypeOutput, state: EvolveState) -> list[str]:
        layout = state.layout
        limit = state.alternatives if state.alternatives is not None else max_alternatives(len(layout.ids))
        problems = []
        if len(output.alternative_layouts) > limit:
            problems.append(f"{len(output.alternative_layouts)} alternatives for {len(layout.ids)} objects; at most {limit}")
        ids = [a.layout_id for a in output.alternative_layouts]
        if len(set(ids)) != len(ids) or "original" in ids:
            problems.append("layout_id values must be distinct and not 'original'")
        return problems


# -- pose instantiation -----------------------------------------------------------------------------------


class PoseCenter(AgentOutput):
    """A centre on the anchor surface."""

    u: float
    v: float


class PosePlacement(AgentOutput):
    """One child's place in the archetype."""

    object_id: str
    reasoning: str = Field(default="", max_length=300)
    center_coordinates: PoseCenter
    rotation_degrees: float | None = Field(default=None, description="Omit (or keep) in units whose rotations are frozen.")


class PoseEvidence(AgentOutput):
    """What the pose agent instantiates."""

    unit: UnitInfo
    objects: list[ObjectRow] = Field(max_length=MAX_ITEMS)
    archetype: Archetype
    clauses: list[str] = Field(default_factory=list, description="Cross-unit rules every variant must keep.")
    placements: list[PosePlacement] = Field(default_factory=list, json_schema_extra=_NO_PROMPT)


class PoseOutput(AgentOutput):
    """2D poses of every child for one archetype."""

    poses: list[PosePlacement] = Field(max_length=MAX_ITEMS)


class PoseAgent(TaskAgent[PoseState, PoseEvidence, PoseOutput]):
    """Places every child of a unit according to one archetype."""

    name: ClassVar[str] = "pose"
    prompt: ClassVar[str] = "pose"
    reply_tokens: ClassVar[tuple[int, int] | None] = (200, 60)
    object_id_fields: ClassVar[tuple[str, ...]] = ("poses.object_id",)
    id_scope: ClassVar[str] = "unit"

    def known_ids(self, state: PoseState) -> Collection[str]:
        """The unit's children."""
        return set(state.layout.ids)

    def gather(self, state: PoseState) -> PoseEvidence:
        layout, ctx = state.layout, state.context
        placed, how = instantiate(layout, ctx, state.archetype)
        U, V = layout.surface.size  # a group carried past an edge starts at the edge: the loop pulls it in
        placed = {k: (min(max(u, 0.0), U), min(max(v, 0.0), V), r) for k, (u, v, r) in placed.items()}
        return PoseEvidence(
            unit=_unit_info(layout, ctx),
            objects=_rows(layout),
            archetype=state.archetype,
            clauses=_clauses(ctx),
            placements=[
                PosePlacement(
                    object_id=k, reasoning=how, center_coordinates=PoseCenter(u=u, v=v),
                    rotation_degrees=None if ctx.frozen_rotation else r,
                )
                for k, (u, v, r) in placed.items()
            ],
        )

    def solve(self, evidence: PoseEvidence) -> PoseOutput:
        return PoseOutput(poses=list(evidence.placements))

    def images(self, evidence: PoseEvidence, state: PoseState) -> list[ImagePart]:
        return _view_images(state, _VIEW_LABEL)

    def check(self, output: PoseOutput, state: PoseState) -> list[str]:
        layout, ctx = state.layout, state.context
        ids = set(layout.ids)
        problems = []
        missing = sorted(ids - {p.object_id for p in output.poses})
        if missing:
            problems.append(f"every child needs a pose; missing: {', '.join(missing)}")
        U, V = layout.surface.size
        for p in output.poses:
            c = p.center_coordinates
            if not (math.isfinite(c.u) and math.isfinite(c.v)) or not (-0.5 <= c.u <= U + 0.5 and -0.5 <= c.v <= V + 0.5):
                problems.append(f"{p.object_id}: centre ({c.u:g}, {c.v:g}) is off the surface (0..{U:.2f}, 0..{V:.2f})")
            if p.rotation_degrees is not None and not math.isfinite(p.rotation_degrees):
                problems.append(f"{p.object_id}: rotation is not a number")
            if (
                ctx.frozen_rotation
                and p.rotation_degrees is not None
                and p.object_id in ids
                and abs(normalize_degrees(p.rotation_degrees - layout.rotation(p.object_id))) > 0.5
            ):
                problems.append(f"{p.object_id}: rotations are frozen in this unit; give centres only")
        return problems

    def apply(self, output: PoseOutput, state: PoseState) -> None:
        layout, ctx = state.layout, state.context
        trial = layout.copy()
        for p in output.poses:
            if p.rotation_degrees is not None and not ctx.frozen_rotation:
                trial.set_rotation(p.object_id, p.rotation_degrees)
            trial.set_center(p.object_id, p.center_coordinates.u, p.center_coordinates.v)
        state.layout = trial

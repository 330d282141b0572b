"""The manager agent: looks at the scene and decides which structuring agents to schedule.

Rule solver: every agent says when it is needed (``TaskAgent.needed`` over the manager's
:class:`SceneSummary`), built-ins and plugins through the same seam: room, support, semantics,
attributes and verification always run; containment only when some object could contain another
(a container with a non-furniture object over its footprint); wall attachment only when
something could stand against or hang on a wall; cross-unit constraints only when a functional
pair (seat + table, bed + nightstand, sofa + coffee table / TV stand, screen on a desk, TV) is
present; a plugin agent whenever given, unless it says otherwise. A plan (a model's too) that
leaves out a required agent, or one the scene calls for, is refused. The
scheduler trims each agent's dependencies to the agents present, so skipping one never leaves
a dangling edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, SceneState, TaskAgent
from scenemosaic.exceptions import UsageError
from scenemosaic.scene import Scene, SupportPriors, is_bed, load_priors, traits
from scenemosaic.structure._attributes import AttributesAgent
from scenemosaic.structure._constraints import ConstraintsAgent
from scenemosaic.structure._containment import ContainmentAgent
from scenemosaic.structure._facts import object_facts
from scenemosaic.structure._room import RoomAgent
from scenemosaic.structure._semantics import SemanticsAgent
from scenemosaic.structure._support import SupportAgent, floor_only
from scenemosaic.structure._verify import VerificationAgent
from scenemosaic.structure._walls import WallAttachmentAgent

__all__ = [
    "DEFAULT_AGENTS",
    "REQUIRED_AGENTS",
    "ManagerAgent",
    "PlannedAgent",
    "SceneSummary",
    "StructuringPlan",
    "plan_structuring",
    "select_agents",
]

AgentList = Sequence[TaskAgent[SceneState, Any, Any]]

DEFAULT_AGENTS: tuple[TaskAgent[SceneState, Any, Any], ...] = (
    RoomAgent(),
    SupportAgent(),
    ContainmentAgent(),
    WallAttachmentAgent(),
    SemanticsAgent(),
    AttributesAgent(),
    ConstraintsAgent(),
    VerificationAgent(),
)
"""The built-in structuring agents, in a valid order. A value to extend, not a registry:
``GenerateConfig(agents=[*DEFAULT_AGENTS, MyAgent()])`` adds a plugin beside them."""
REQUIRED_AGENTS = frozenset({"room", "support", "verify"})
"""The built-in agents every plan must contain when they are available (a tree needs a room,
parents and a final check): those whose :meth:`~scenemosaic.agents.TaskAgent.needed` says
``required``."""


class PlannedAgent(AgentOutput):
    """One agent of the plan and why it is (or is not) scheduled."""

    name: str = Field(min_length=1, max_length=64, description="An agent name from the evidence's available list.")
    reason: str = Field(default="", max_length=200)


class StructuringPlan(AgentOutput):
    """Which structuring agents to run; dependencies follow from the agents themselves."""

    agents: list[PlannedAgent] = Field(min_length=1, max_length=16)
    skipped: list[PlannedAgent] = Field(default_factory=list, max_length=16)


class SceneSummary(AgentOutput):
    """What the manager looks at."""

    available: list[str] = Field(
        default_factory=list, max_length=64, description="Agents that can be scheduled, in a valid order."
    )
    object_count: int
    has_room: bool
    has_walls: bool
    categories: list[str] = Field(max_length=MAX_ITEMS)
    containers: list[str] = Field(default_factory=list, max_length=MAX_ITEMS)
    container_candidates: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects over a container's footprint."
    )
    wall_candidates: list[str] = Field(default_factory=list, max_length=MAX_ITEMS)
    stack_candidates: list[str] = Field(
        default_factory=list, max_length=MAX_ITEMS, description="Objects that could rest on another object."
    )
    functional_pairs: list[str] = Field(default_factory=list, max_length=32)


def summarize(scene: Scene, priors: SupportPriors, available: Sequence[str] = ()) -> SceneSummary:
    """The manager's evidence for ``scene`` when the agents named ``available`` can run."""
    objs = object_facts(scene)
    containers = [o for o in objs if traits(o.category).contains]
    movable = [o for o in objs if not floor_only(o, priors) and traits(o.category).placement == "surface"]
    in_container = sorted(
        {o.id for o in movable for c in containers if c.id != o.id and c.contains_point(o.center, 0.02)}
    )
    cats = {o.category for o in objs}
    pairs: list[str] = []
    if any(traits(c).seat for c in cats) and any(traits(c).table for c in cats):
        pairs.append("seats and a table or desk")
    if any(is_bed(c) for c in cats) and "nightstand" in cats:
        pairs.append("bed and nightstands")
    if any("sofa" in c for c in cats) and cats & {"coffee_table", "tea_table", "tv_stand"}:
        pairs.append("sofa and coffee table / TV stand")
    if cats & {"television", "monitor", "computer_monitor", "laptop"}:
        pairs.append("screen")
    wall_like = [
        o.id for o in objs if traits(o.category).against_wall or traits(o.category).placement == "wall"
    ]
    return SceneSummary(
        available=list(available),
        object_count=len(objs),
        has_room=scene.room is not None,
        has_walls=bool(scene.room and scene.room.walls),
        categories=sorted(cats),
        containers=[c.id for c in containers],
        container_candidates=in_container,
        wall_candidates=wall_like,
        stack_candidates=[o.id for o in movable],
        functional_pairs=pairs,
    )


def solve_plan(summary: SceneSummary, agents: AgentList = ()) -> StructuringPlan:
    """The manager's rule solver (see the module docstring): each agent that may run (``agents``,
    default :data:`DEFAULT_AGENTS`), in its given order, scheduled when it says it is needed here
    (:meth:`~scenemosaic.agents.TaskAgent.needed`), built-ins and plugins alike."""
    run: list[PlannedAgent] = []
    skip: list[PlannedAgent] = []
    for agent in agents or DEFAULT_AGENTS:
        need = agent.needed(summary)
        (run if need.run else skip).append(PlannedAgent(name=agent.name, reason=need.reason))
    return StructuringPlan(agents=run, skipped=skip)


class ManagerAgent(TaskAgent[SceneState, SceneSummary, StructuringPlan]):
    """Decides which of the available structuring agents to run on a scene.

    ``agents`` are the agents it may schedule (default :data:`DEFAULT_AGENTS`); plugins among
    them are scheduled by the rule solver whenever they are given.
    """

    name: ClassVar[str] = "manager"
    prompt: ClassVar[str] = "manager"
    reply_tokens: ClassVar[tuple[int, int] | None] = (700, 0)

    def __init__(self, agents: AgentList | None = None, priors: SupportPriors | None = None) -> None:
        self.agents: tuple[TaskAgent[SceneState, Any, Any], ...] = tuple(agents if agents is not None else DEFAULT_AGENTS)
        names = [a.name for a in self.agents]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise UsageError("two agents share the name(s) " + ", ".join(duplicates) + "; names must be unique")
        if "manager" in names:
            raise UsageError("'manager' is the manager agent's own name; give the plugin another name")
        self.priors = priors if priors is not None else load_priors()

    def gather(self, state: SceneState) -> SceneSummary:
        return summarize(state.scene, self.priors, [a.name for a in self.agents])

    def solve(self, evidence: SceneSummary) -> StructuringPlan:
        return solve_plan(evidence, self.agents)

    def check(self, output: StructuringPlan, state: SceneState) -> list[str]:
        names = [a.name for a in output.agents]
        available = [a.name for a in self.agents]
        problems = []
        if len(set(names)) != len(names):
            problems.append("each agent may be scheduled once")
        unknown = sorted(set(names) - set(available))
        if unknown:
            problems.append(
                "unknown agents " + ", ".join(unknown) + "; choose from: " + ", ".join(available)
            )
        both = sorted(set(names) & {a.name for a in output.skipped})
        if both:
            problems.append("agents both scheduled and skipped: " + ", ".join(both) + "; list each once")
        summary = self.gather(state)
        needs = [(a.name, a.needed(summary)) for a in self.agents]
        missing = sorted(name for name, need in needs if need.required and name not in names)
        if missing:
            problems.append("the plan must schedule: " + ", ".join(missing))
        for name, need in needs:  # what the scene calls for, left out
            if need.evidence and not need.required and name not in names:
                problems.append(f"schedule {name!r}: {need.insist} ({', '.join(need.evidence[:5])})")
        return problems

    def select(self, plan: StructuringPlan) -> list[TaskAgent[SceneState, Any, Any]]:
        """The agents ``plan`` schedules, in the order they were given."""
        return select_agents(plan, self.agents)


def select_agents(plan: StructuringPlan, agents: AgentList) -> list[TaskAgent[SceneState, Any, Any]]:
    """The members of ``agents`` that ``plan`` schedules, in their given order.

    Dependencies need no rewiring: the scheduler trims each agent's ``depends_on`` to the
    agents present (:func:`scenemosaic.agents.run_agents`).
    """
    wanted = {a.name for a in plan.agents}
    return [a for a in agents if a.name in wanted]


def plan_structuring(
    scene: Scene, *, agents: AgentList | None = None, priors: SupportPriors | None = None
) -> tuple[StructuringPlan, list[TaskAgent[SceneState, Any, Any]]]:
    """The rule manager's plan for ``scene`` and the agents it schedules (no model involved)."""
    manager = ManagerAgent(agents, priors)
    plan = solve_plan(summarize(scene, manager.priors, [a.name for a in manager.agents]), manager.agents)
    return plan, manager.select(plan)

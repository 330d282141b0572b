"""The manager agent: looks at the scene and decides which structuring agents to schedule.

Rule solver: room, support, semantics, attributes and verification always run; containment
only when some object could contain another (a container with a non-furniture object over its
footprint); wall attachment only when something could stand against or hang on a wall;
cross-unit constraints only when a functional pair (seat + table, bed + nightstand, sofa +
coffee table / TV stand, screen on a desk, TV) is present. Each scheduled agent depends on
the scheduled subset of its usual dependencies, so skipping one never leaves a dangling edge.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, Field

from scenemosaic.agents._attributes import AttributesAgent
from scenemosaic.agents._base import SceneState, TaskAgent
from scenemosaic.agents._categories import SupportPriors, load_priors, traits
from scenemosaic.agents._constraints import ConstraintsAgent
from scenemosaic.agents._containment import ContainmentAgent
from scenemosaic.agents._facts import MAX_ITEMS, AgentOutput, object_facts
from scenemosaic.agents._room import RoomAgent
from scenemosaic.agents._semantics import SemanticsAgent
from scenemosaic.agents._support import SupportAgent, floor_only
from scenemosaic.agents._verify import VerificationAgent
from scenemosaic.agents._walls import WallAttachmentAgent
from scenemosaic.scene import Scene

__all__ = [
    "AGENT_NAMES",
    "REQUIRED_AGENTS",
    "ManagerAgent",
    "PlannedAgent",
    "SceneSummary",
    "StructuringPlan",
    "build_agents",
    "plan_structuring",
]

AgentName = Literal[
    "room", "support", "containment", "walls", "semantics", "attributes", "constraints", "verify"
]
AGENT_NAMES: tuple[str, ...] = (
    "room",
    "support",
    "containment",
    "walls",
    "semantics",
    "attributes",
    "constraints",
    "verify",
)
"""Every structuring agent the manager can schedule, in a valid order."""
REQUIRED_AGENTS = frozenset({"room", "support", "verify"})
"""Agents every plan must contain (a tree needs a room, parents and a final check)."""


class PlannedAgent(AgentOutput):
    """One agent of the plan and why it is (or is not) scheduled."""

    name: AgentName
    reason: str = Field(default="", max_length=200)


class StructuringPlan(AgentOutput):
    """Which structuring agents to run; dependencies follow from the agents themselves."""

    agents: list[PlannedAgent] = Field(min_length=1, max_length=16)
    skipped: list[PlannedAgent] = Field(default_factory=list, max_length=16)


class SceneSummary(AgentOutput):
    """What the manager looks at."""

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


def summarize(scene: Scene, priors: SupportPriors) -> SceneSummary:
    """The manager's evidence for ``scene``."""
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
    if any("bed" in c for c in cats) and "nightstand" in cats:
        pairs.append("bed and nightstands")
    if any("sofa" in c for c in cats) and cats & {"coffee_table", "tea_table", "tv_stand"}:
        pairs.append("sofa and coffee table / TV stand")
    if cats & {"television", "monitor", "computer_monitor", "laptop"}:
        pairs.append("screen")
    wall_like = [
        o.id for o in objs if traits(o.category).against_wall or traits(o.category).placement == "wall"
    ]
    return SceneSummary(
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


def solve_plan(summary: SceneSummary) -> StructuringPlan:
    """The manager's rule solver (see the module docstring)."""
    run: list[PlannedAgent] = []
    skip: list[PlannedAgent] = []

    def decide(name: AgentName, yes: bool, why_yes: str, why_no: str) -> None:
        (run if yes else skip).append(PlannedAgent(name=name, reason=why_yes if yes else why_no))

    decide(
        "room",
        True,
        "complete the input room's walls" if summary.has_room else "recover the room boundary",
        "",
    )
    decide("support", True, f"parent each of {summary.object_count} objects", "")
    decide(
        "containment",
        bool(summary.container_candidates),
        f"{len(summary.container_candidates)} objects over containers",
        "nothing could be inside a container",
    )
    decide(
        "walls",
        bool(summary.wall_candidates) or summary.has_walls,
        "wall-type furniture or input walls present",
        "nothing stands against or hangs on a wall",
    )
    decide("semantics", True, "normalize categories and check fronts", "")
    decide("attributes", True, "mass, friction, static flags", "")
    decide(
        "constraints",
        bool(summary.functional_pairs),
        "functional pairs: " + ", ".join(summary.functional_pairs),
        "no functional pair in the scene",
    )
    decide("verify", True, "final completeness check and scene tree", "")
    return StructuringPlan(agents=run, skipped=skip)


class ManagerAgent(TaskAgent[SceneSummary, StructuringPlan]):
    """Decides which structuring agents to run on a scene (see :func:`build_agents`)."""

    name: ClassVar[str] = "manager"
    depends_on: ClassVar[tuple[str, ...]] = ()
    prompt: ClassVar[str] = "manager"
    output_type: ClassVar[type[BaseModel]] = StructuringPlan

    def __init__(self, priors: SupportPriors | None = None) -> None:
        self.priors = priors if priors is not None else load_priors()

    def gather(self, state: SceneState) -> SceneSummary:
        return summarize(state.scene, self.priors)

    def solve(self, evidence: SceneSummary) -> StructuringPlan:
        return solve_plan(evidence)

    def check(self, output: StructuringPlan, state: SceneState) -> list[str]:
        names = [a.name for a in output.agents]
        problems = []
        if len(set(names)) != len(names):
            problems.append("each agent may be scheduled once")
        missing = sorted(REQUIRED_AGENTS - set(names))
        if missing:
            problems.append("the plan must schedule: " + ", ".join(missing))
        return problems

    def apply(self, output: StructuringPlan, state: SceneState) -> None:
        state.artifacts["structuring_plan"] = output


def _rewired(agent: TaskAgent[Any, Any], depends_on: tuple[str, ...]) -> TaskAgent[Any, Any]:
    """The same agent with ``depends_on`` narrowed (a one-off subclass; the original is untouched)."""
    if depends_on == tuple(agent.depends_on):
        return agent
    cls = type(agent)
    sub = type(
        cls.__name__,
        (cls,),
        {"depends_on": depends_on, "__module__": cls.__module__, "__qualname__": cls.__qualname__},
    )
    clone: TaskAgent[Any, Any] = object.__new__(sub)
    clone.__dict__.update(agent.__dict__)
    return clone


def build_agents(
    plan: StructuringPlan, *, priors: SupportPriors | None = None, priors_dir: str | Path | None = None
) -> list[TaskAgent[Any, Any]]:
    """Agent instances for a plan, each depending only on scheduled agents."""
    priors = priors if priors is not None else load_priors(priors_dir)
    factories: dict[str, TaskAgent[Any, Any]] = {
        "room": RoomAgent(),
        "support": SupportAgent(priors),
        "containment": ContainmentAgent(priors),
        "walls": WallAttachmentAgent(),
        "semantics": SemanticsAgent(),
        "attributes": AttributesAgent(),
        "constraints": ConstraintsAgent(priors_dir),
        "verify": VerificationAgent(),
    }
    wanted = [n for n in AGENT_NAMES if n in {a.name for a in plan.agents}]
    out: list[TaskAgent[Any, Any]] = []
    for n in wanted:
        agent = factories[n]
        out.append(_rewired(agent, tuple(d for d in agent.depends_on if d in wanted)))
    return out


def plan_structuring(
    scene: Scene, *, priors: SupportPriors | None = None, priors_dir: str | Path | None = None
) -> tuple[StructuringPlan, list[TaskAgent[Any, Any]]]:
    """The rule manager's plan for ``scene`` and the agents it schedules (no model involved)."""
    priors = priors if priors is not None else load_priors(priors_dir)
    plan = solve_plan(summarize(scene, priors))
    return plan, build_agents(plan, priors=priors, priors_dir=priors_dir)

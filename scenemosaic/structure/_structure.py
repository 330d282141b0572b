"""``structure_scene``: the whole relation-guided structuring stage in one call."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import structlog

from scenemosaic.agents import AgentLog, AgentPolicy, SceneState, TaskAgent, run_agents
from scenemosaic.dag import EventListener, RunStore
from scenemosaic.exceptions import AgentOutputError, NodeFailedError
from scenemosaic.models import Model, ModelSettings, RulesModel
from scenemosaic.scene import Scene, load_priors
from scenemosaic.structure._constraints import ConstraintsAgent
from scenemosaic.structure._containment import ContainmentAgent
from scenemosaic.structure._manager import DEFAULT_AGENTS, ManagerAgent, StructuringPlan
from scenemosaic.structure._support import SupportAgent
from scenemosaic.structure._verify import VerificationAgent

__all__ = ["structure_scene"]

log = structlog.get_logger(__name__)


def _with_priors(agents: Sequence[TaskAgent[SceneState, Any, Any]], priors_dir: str | Path) -> list[TaskAgent[SceneState, Any, Any]]:
    """The built-in agents that read ProcTHOR priors, re-made over ``priors_dir``; others unchanged."""
    priors = load_priors(priors_dir)
    out: list[TaskAgent[SceneState, Any, Any]] = []
    for agent in agents:
        if type(agent) is SupportAgent:
            agent = SupportAgent(priors)
        elif type(agent) is ContainmentAgent:
            agent = ContainmentAgent(priors)
        elif type(agent) is ConstraintsAgent:
            agent = ConstraintsAgent(priors_dir)
        elif type(agent) is VerificationAgent:
            agent = VerificationAgent(priors)
        out.append(agent)
    return out


async def structure_scene(
    scene: Scene,
    model: Model | None = None,
    *,
    agents: Sequence[TaskAgent[SceneState, Any, Any]] | None = None,
    settings: ModelSettings | None = None,
    policy: AgentPolicy | None = None,
    store: RunStore | None = None,
    seed: int = 0,
    priors_dir: str | Path | None = None,
    events: EventListener | None = None,
    max_concurrency: int | None = 8,
    base_dir: str | Path | None = None,
    agent_log: AgentLog | None = None,
) -> Scene:
    """Structure ``scene``: room, parents, containment, walls, semantics, attributes, constraints, tree.

    Two phases over the task-graph runtime: the manager agent first plans which of ``agents``
    (default :data:`~scenemosaic.structure.DEFAULT_AGENTS`; add plugins to that list) to run,
    then the planned agents run as one graph, independent ones concurrently. ``model=None``
    uses the offline rules model. ``priors_dir`` replaces the ProcTHOR priors shipped with
    the package. The input scene is never modified; a new scene with ``structure`` set is
    returned. ``policy`` sets the agents' attempt budget and solver fallback. ``agent_log``,
    when given, receives every agent's result (how it answered, its fallback, its requests), in the
    plan's order (the manager first), also when structuring fails.

    Raises :class:`~scenemosaic.exceptions.AgentOutputError` when an agent's output stays
    inconsistent with the scene and fallback is off (other run errors pass through unchanged).
    ``base_dir`` is the folder relative mesh paths start from; vision models get floor plans
    drawn with the real meshes when it is given.
    """
    model = model if model is not None else RulesModel()
    available = list(agents if agents is not None else DEFAULT_AGENTS)
    if priors_dir is not None:
        available = _with_priors(available, priors_dir)
    manager = ManagerAgent(available, load_priors(priors_dir))
    state = SceneState(
        scene=scene.model_copy(deep=True),
        seed=seed,
        base_dir=Path(base_dir) if base_dir is not None else None,
        policy=policy or AgentPolicy(),
    )
    ran = AgentLog()  # in the order the agents finished
    try:
        # the plan and the planned agents are two graphs: each keeps its own record in the store
        plan_store = store.scoped("plan") if store is not None else None
        agents_store = store.scoped("agents") if store is not None else None
        planned = await run_agents([manager], state, model, settings=settings, store=plan_store, events=events, log=ran)
        plan = planned["manager"]
        assert isinstance(plan, StructuringPlan)
        chosen = manager.select(plan)
        log.info("structuring_plan", agents=[a.name for a in chosen], skipped=[s.name for s in plan.skipped])
        await run_agents(
            chosen,
            state,
            model,
            settings=settings,
            store=agents_store,
            events=events,
            max_concurrency=max_concurrency,
            log=ran,
        )
    except NodeFailedError as exc:
        cause: Any = exc.cause
        if isinstance(cause, AgentOutputError):
            raise cause from exc
        raise
    finally:
        rank = {name: i for i, name in enumerate(["manager", *(a.name for a in available)])}
        if agent_log is not None:
            agent_log.merge(ran, order=lambda agent: rank.get(agent, len(rank)))
    return _canonical(state.scene, notes_before=len(scene.provenance.notes), rank=rank)


_KIND_ORDER = {"attach": 0, "contain": 1, "against": 2, "faces": 3, "beside": 4}


def _canonical(out: Scene, *, notes_before: int, rank: dict[str, int]) -> Scene:
    """The structured scene in an order that does not depend on which concurrent agent finished
    first (a replayed run answers at once, a live one in the server's time): relations by object,
    then kind, then parent; the notes of this run grouped by agent in the plan's order."""
    index = {o.id: i for i, o in enumerate(out.objects)}
    relations = sorted(
        out.relations, key=lambda r: (index.get(r.child, len(index)), _KIND_ORDER.get(r.kind, 9), r.parent)
    )
    notes = out.provenance.notes
    ours = sorted(notes[notes_before:], key=lambda n: rank.get(n.split(":", 1)[0], len(rank)))
    provenance = out.provenance.model_copy(
        update={"steps": [*out.provenance.steps, "structure"], "notes": [*notes[:notes_before], *ours]}
    )
    return out.model_copy(update={"relations": relations, "provenance": provenance})

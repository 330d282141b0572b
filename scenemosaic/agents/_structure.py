"""``structure_scene``: the whole relation-guided structuring stage in one call."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import structlog

from scenemosaic.agents._base import SceneState
from scenemosaic.agents._categories import load_priors
from scenemosaic.agents._manager import ManagerAgent, StructuringPlan, build_agents
from scenemosaic.agents._node import run_agents
from scenemosaic.agents._views import BASE_DIR_ARTIFACT
from scenemosaic.dag import EventListener, RunStore
from scenemosaic.exceptions import AgentOutputError, NodeFailedError
from scenemosaic.models import Model, ModelSettings, RulesModel
from scenemosaic.scene import Scene

__all__ = ["structure_scene"]

log = structlog.get_logger(__name__)


async def structure_scene(
    scene: Scene,
    model: Model | None = None,
    *,
    settings: ModelSettings | None = None,
    store: RunStore | None = None,
    seed: int = 0,
    priors_dir: str | Path | None = None,
    events: EventListener | None = None,
    max_concurrency: int | None = 8,
    base_dir: str | Path | None = None,
) -> Scene:
    """Structure ``scene``: room, parents, containment, walls, semantics, attributes, constraints, tree.

    The manager agent runs first and plans the structuring DAG; the planned agents then run
    through the task-graph runtime, independent ones concurrently. ``model=None`` uses the
    offline rules model. ``priors_dir`` is a ProcTHOR priors folder (default:
    ``$SCENEMOSAIC_PRIORS_DIR``, else a bundled table). The input scene is never modified; a
    new scene with ``structure`` set is returned.

    Raises :class:`~scenemosaic.exceptions.AgentOutputError` when an agent's output stays
    inconsistent with the scene after its repairs (other run errors pass through unchanged).
    ``base_dir`` is the folder relative mesh paths start from; vision models get floor plans
    drawn with the real meshes when it is given.
    """
    model = model if model is not None else RulesModel()
    priors = load_priors(priors_dir)
    state = SceneState(scene=scene.model_copy(deep=True), seed=seed)
    if base_dir is not None:
        state.artifacts[BASE_DIR_ARTIFACT] = Path(base_dir)
    try:
        await run_agents([ManagerAgent(priors)], state, model, settings=settings, store=store, events=events)
        plan = state.outputs["manager"]
        assert isinstance(plan, StructuringPlan)
        agents = build_agents(plan, priors=priors, priors_dir=priors_dir)
        log.info("structuring_plan", agents=[a.name for a in agents], skipped=[s.name for s in plan.skipped])
        await run_agents(
            agents,
            state,
            model,
            settings=settings,
            store=store,
            events=events,
            max_concurrency=max_concurrency,
        )
    except NodeFailedError as exc:
        cause: Any = exc.cause
        if isinstance(cause, AgentOutputError):
            raise cause from exc
        raise
    out = state.scene
    steps = [*out.provenance.steps, "structure"]
    return out.model_copy(update={"provenance": out.provenance.model_copy(update={"steps": steps})})

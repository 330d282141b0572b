"""Evolve every local unit of a stabilized scene: the refined original and its variants.

:func:`evolve_scene` builds one task graph (:mod:`scenemosaic.dag`): per unit, a node evolving
the original layout and, when variants are asked for, a node asking the archetype agent, which
adds one node per proposed archetype (pose agent, then the same Critic-Actor loop). All run
concurrently; CPU work (physics, rendering) runs in worker threads. The base scene is then
rebuilt top-down from the refined originals, each in its anchor's frame, so what a unit's
children carry moves with them.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import structlog

from scenemosaic.agents import AgentLog, AgentPolicy, run_agent
from scenemosaic.assets import short_parts
from scenemosaic.dag import Node, NodeContext, Runner
from scenemosaic.evolve._agents import ArchetypeAgent, EvolveState
from scenemosaic.evolve._analysis import LayoutRule
from scenemosaic.evolve._archetypes import max_alternatives
from scenemosaic.evolve._context import UnitContext, unit_context
from scenemosaic.evolve._loop import MAX_ROUNDS, LayoutResult, evolve_layout
from scenemosaic.evolve._plans import MAX_PLANS
from scenemosaic.exceptions import (
    ModelConfigError,
    ReplayMissError,
    RunCancelledError,
    SceneMosaicError,
    UsageError,
    UsageLimitExceeded,
)
from scenemosaic.models import Model, ModelSettings, Usage
from scenemosaic.physics import ObjectShape, is_thin, require_finite_poses
from scenemosaic.scene import (
    FLOOR,
    LocalUnit,
    Scene,
    UnitLayout,
    build_structure,
    descendants,
    functional_relations,
    unit_layout,
    with_unit_layout,
)

__all__ = ["MAX_ALTERNATIVES", "EvolutionReport", "UnitEvolution", "alternative_counts", "evolve_scene", "unit_obstacles"]

log = structlog.get_logger(__name__)


@dataclass
class UnitEvolution:
    """The evolved layouts of one unit: the refined original first, then the variants."""

    anchor_id: str
    original: LayoutResult
    variants: list[LayoutResult] = field(default_factory=list)
    archetypes_asked: bool = False
    promoted_from: str | None = None
    """Set when the refined original still broke a rule and a variant met them all: the id of
    that broken original, now first among the variants (:meth:`promote_valid`)."""

    @property
    def layouts(self) -> list[LayoutResult]:
        return [self.original, *self.variants]

    def promote_valid(self) -> bool:
        """Rules met, not reported: when the refined original breaks a rule (the source's seats
        1 and 3 on a table's long sides, the loop unable to reseat them where they stand) and a
        variant of the unit came out physically clean with every rule met, that variant becomes
        the unit's base: the one that moves the children least from the refined original (ties by
        layout id). The broken original stays among the variants, where composition drops it.
        Returns whether a variant was promoted."""
        o = self.original
        if o.error is not None or not o.violations:
            return False
        ok = [v for v in self.variants if v.error is None and v.valid and not v.violations]
        if not ok:
            return False

        def moved(v: LayoutResult) -> float:
            return sum(math.dist(p.position, v.local_poses[k].position) for k, p in o.local_poses.items() if k in v.local_poses)

        best = min(ok, key=lambda v: (moved(v), v.layout_id))
        self.variants = [o, *(v for v in self.variants if v is not best)]
        self.original, self.promoted_from = best, o.layout_id
        return True


@dataclass
class EvolutionReport:
    """What the evolution stage did, per unit and layout, and what it cost."""

    units: list[UnitEvolution] = field(default_factory=list)
    wall_s: float = 0.0

    @property
    def usage(self) -> Usage:
        """What every layout's agents' requests cost."""
        return sum((lay.agents.usage for u in self.units for lay in u.layouts), Usage())

    def summary(self) -> dict[str, Any]:
        """JSON-ready record for ``report.json``."""
        layouts = [lay for u in self.units for lay in u.layouts]
        return {
            "units": len(self.units),
            "layout_count": len(layouts),
            "variants": sum(len(u.variants) for u in self.units),
            "valid_layouts": sum(1 for lay in layouts if lay.valid),
            "rule_violations": sum(len(lay.violations) for lay in layouts),
            "requests": self.usage.requests,
            "wall_s": round(self.wall_s, 3),
            "per_layout": [lay.summary() for lay in layouts],
        }


MAX_ALTERNATIVES = 12
"""Most archetypes one unit may get when the method's counts are raised for a large m."""
POOL_FACTOR = 2
"""The counts are raised until the units' layouts combine into this many times m + 1 whole
scenes: room for the filters to drop some, and for the selection to choose among layouts that
differ in more than one small unit."""


def alternative_counts(units: list[LocalUnit], m: int, followers: Collection[str] = ()) -> dict[str, int]:
    """Archetypes to ask per unit: the method's count for its size (0-1 for 1-5 children, 0-2 for
    6-10, 0-3 above), raised one at a time for the units with most children while the product of
    (1 + count) over units is below ``POOL_FACTOR`` (m + 1), up to :data:`MAX_ALTERNATIVES` each: room for the
    local filtering and the scene-level checks to drop some and still leave m distinct variants. A deliberate deviation for small rooms
    (a five-object room gets one alternative by the method's count, so at most one variant).
    A unit whose every child follows another unit's piece (``followers``: a ceiling of lamps
    over tables) gets none: composition puts its children where their groups go."""
    if m <= 0:
        return {u.anchor_id: 0 for u in units}
    free = [u for u in units if not set(u.children) <= set(followers)]
    counts = {u.anchor_id: max_alternatives(len(u.children)) if u in free else 0 for u in units}
    order = sorted(free, key=lambda u: (-len(u.children), u.anchor_id))
    while math.prod(1 + c for c in counts.values()) < POOL_FACTOR * (m + 1):
        grown = False
        for u in order:
            if counts[u.anchor_id] < MAX_ALTERNATIVES:
                counts[u.anchor_id] += 1
                grown = True
                break
        if not grown:
            break
    return counts


def unit_obstacles(scene: Scene, unit: LocalUnit, units: list[LocalUnit]) -> list[Any]:
    """Fixed objects a unit's children may run into: for a floor, wall or ceiling unit, the
    children of the other room-level units (a painting above a wardrobe, a low pendant lamp),
    except those that follow one of this unit's pieces (a lamp over its table moves with the
    table in composition: ``scene.functional_relations``)."""
    if unit.anchor_kind == "object":
        return []
    own = set(unit.children) | {d for c in unit.children for d in descendants(scene, c)}
    followers = {r.subject for r in functional_relations(scene) if r.follows and r.leader in own}
    roots = [u for u in units if u.anchor_kind != "object" and u.anchor_id != unit.anchor_id]
    return [scene.get(c) for u in roots for c in u.children if c not in followers]


async def evolve_scene(
    scene: Scene,
    model: Model,
    shapes: Mapping[str, ObjectShape],
    *,
    variants: int = 0,
    settings: ModelSettings | None = None,
    policy: AgentPolicy | None = None,
    max_rounds: int = MAX_ROUNDS,
    seed: int = 0,
    base_dir: Path | None = None,
    views_dir: Path | None = None,
    max_concurrency: int | None = None,
    rules: Sequence[LayoutRule] = (),
    agent_log: AgentLog | None = None,
) -> tuple[Scene, EvolutionReport]:
    """Evolve every unit of ``scene`` (stabilized, with its structure) and return the refined base
    scene and the report with every layout.

    ``variants`` (m) > 0 asks each unit's archetype agent for alternatives: the method's count for
    the unit's size (1, 2 or 3), raised (up to :data:`MAX_ALTERNATIVES` per unit, largest units
    first) when those counts could not combine into ``POOL_FACTOR`` (m + 1) distinct whole scenes (see
    :func:`alternative_counts`).

    ``shapes`` are the objects' collision shapes (``scenemosaic.physics.object_shape``);
    ``rules`` are plugin rules of the critic (:data:`~scenemosaic.evolve.LayoutRule`), run on
    every layout of every unit. ``views_dir``, when given, receives ``<anchor>/<layout>/round_<k>.png`` and ``final.png``.
    Each layout's agent results are in its ``agents`` log (the refined original's also holds the
    unit's archetype agent's); ``agent_log``, when given, receives them all, also when the stage fails.
    The input scene is not modified.
    """
    t0 = time.perf_counter()
    require_finite_poses(scene, "evolve the scene")
    structure = scene.structure or build_structure(scene)
    units = list(structure.units)
    thin = {o.id for o in scene.objects if is_thin(o)}
    short = await asyncio.to_thread(short_parts, scene, base_dir)
    contexts: dict[str, UnitContext] = await asyncio.to_thread(
        lambda: {
            u.anchor_id: unit_context(scene, u, unit_obstacles(scene, u, units), thin, short, base_dir)
            for u in units
        }
    )
    policy = policy or AgentPolicy()
    followers = {r.subject for r in functional_relations(scene) if r.follows}
    counts = alternative_counts(units, variants, followers)
    if variants and FLOOR in contexts and contexts[FLOOR].in_house:
        # a room of a house (doors, open passages): its floor gets a room plan per variant asked for
        counts[FLOOR] = max(counts[FLOOR], min(variants, MAX_PLANS))
    nodes: list[Node] = []
    logs: list[AgentLog] = []  # one per node: what its agents did, kept however the node ends

    def new_log() -> AgentLog:
        logs.append(AgentLog())
        return logs[-1]

    def views(anchor: str, layout_id: str) -> Path | None:
        return views_dir / anchor / layout_id if views_dir is not None else None

    async def guarded(anchor: str, layout_id: str, agents: AgentLog, work: Any) -> LayoutResult:
        """A layout whose loop fails (a model that keeps failing without fallback, physics that
        cannot settle) is kept as an error record (with what its agents did); configuration
        errors and bugs still raise."""
        try:
            result: LayoutResult = await work
            return result
        except (ModelConfigError, ReplayMissError, UsageError, UsageLimitExceeded, RunCancelledError):
            raise
        except SceneMosaicError as exc:
            log.warning("layout_evolution_failed", unit=anchor, layout=layout_id, error=str(exc)[:300])
            kept = {k: p for k, p in unit_layout(scene, anchor).items()}
            error = f"{type(exc).__name__}: {exc}"[:500]
            return LayoutResult(anchor, layout_id, local_poses=kept, agents=agents, error=error)

    def original(anchor: str) -> Node:
        async def run(ctx: NodeContext) -> LayoutResult:
            c, agents = contexts[anchor], new_log()
            return await guarded(anchor, "original", agents, evolve_layout(
                scene, c, UnitLayout.from_scene(scene, c.unit), shapes, model, settings=settings, policy=policy,
                max_rounds=max_rounds, seed=ctx.node_seed, base_dir=base_dir, views_dir=views(anchor, "original"), rules=rules,
                agent_log=agents,
            ))  # fmt: skip

        return Node(f"evolve/{anchor}/original", run)

    def variant_node(anchor: str, archetype: Any) -> Node:
        async def run(ctx: NodeContext) -> LayoutResult:
            c, agents = contexts[anchor], new_log()
            return await guarded(anchor, archetype.layout_id, agents, evolve_layout(
                scene, c, UnitLayout.from_scene(scene, c.unit), shapes, model, layout_id=archetype.layout_id,
                archetype=archetype, settings=settings, policy=policy, max_rounds=max_rounds, seed=ctx.node_seed,
                base_dir=base_dir, views_dir=views(anchor, archetype.layout_id), rules=rules, agent_log=agents,
            ))  # fmt: skip

        return Node(f"evolve/{anchor}/{archetype.layout_id}", run)

    def archetypes(anchor: str) -> Node:
        async def run(ctx: NodeContext) -> dict[str, Any]:
            c = contexts[anchor]
            state = EvolveState(
                scene=scene, seed=ctx.node_seed, base_dir=base_dir, policy=policy,
                layout=UnitLayout.from_scene(scene, c.unit), context=c, alternatives=counts[anchor],
            )  # fmt: skip
            agents = new_log()
            proposed = await run_agent(ArchetypeAgent(), state, model, settings, log=agents)
            alternatives = proposed.output.alternative_layouts
            ctx.add_nodes(variant_node(anchor, a) for a in alternatives)
            return {"ids": [a.layout_id for a in alternatives], "agents": agents}

        return Node(f"archetypes/{anchor}", run)

    for u in units:
        nodes.append(original(u.anchor_id))
        if variants:
            nodes.append(archetypes(u.anchor_id))
    try:
        outputs = await Runner(nodes, seed=seed, max_concurrency=max_concurrency).run() if nodes else {}
    finally:
        if agent_log is not None:
            for agents in logs:
                agent_log.merge(agents)

    report = EvolutionReport()
    for u in units:
        orig: LayoutResult = outputs[f"evolve/{u.anchor_id}/original"]
        ev = UnitEvolution(u.anchor_id, orig, archetypes_asked=variants > 0)
        arch = outputs.get(f"archetypes/{u.anchor_id}")
        if arch is not None:
            orig.agents.merge(arch["agents"])
            ev.variants = [outputs[f"evolve/{u.anchor_id}/{i}"] for i in arch["ids"]]
        if ev.promote_valid():
            log.info("unit_base_promoted", unit=u.anchor_id, layout=ev.original.layout_id, broke=ev.variants[0].violations[:3])
        report.units.append(ev)

    def refined() -> Scene:
        """Top-down: the parent's refined layout is in place, each unit's goes on in its anchor's
        frame; a unit whose evolution failed keeps its stabilized layout exactly."""
        out = scene.model_copy(deep=True)  # the caller's scene stays as it was
        for ev in report.units:
            if ev.original.error is None:
                out = with_unit_layout(out, ev.anchor_id, ev.original.local_poses)
        return out

    out = await asyncio.to_thread(refined)
    out.provenance.steps.append("evolve")
    report.wall_s = time.perf_counter() - t0
    log.info("scene_evolved", units=len(units), layouts=sum(len(e.layouts) for e in report.units), wall_s=round(report.wall_s, 3))
    return out, report


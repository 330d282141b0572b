"""The Critic-Actor loop of one layout of one unit, its round selection and final settle.

Per round: physics checks the layout (collisions with contact counts, out-of-bounds), the
rule findings are computed, the critic judges (objects out of bounds become mandatory notes),
the actor writes pose expressions, the sandbox applies them, and the round goes into the
layout memory. The critic and the actor get the round's check, findings and notes as a frozen
:class:`~scenemosaic.evolve.RoundInput`; the loop runs each agent (``scenemosaic.agents.run_agent``:
the actor's and the pose agent's answers are applied to their state, the critic only judges) and
records its result in the layout's :class:`~scenemosaic.agents.AgentLog`. The loop ends when the critic asks for no change, when the round cap
(:data:`MAX_ROUNDS`) is reached, or early, when the last round moved nothing by more than
:data:`EARLY_STOP_MOVE_M` nor turned anything by more than :data:`EARLY_STOP_TURN_DEG` and
the layout is physically clean; with a model (not the rules) also when such a round left it
unclean: the next round would ask the same of the same layout, a request that buys nothing. The final round is kept if clean, else the round with the
fewest collisions + out-of-bounds objects (later rounds win ties); then the unit settles
under gravity in MuJoCo with its anchor as the ground (:func:`scenemosaic.physics.settle_unit`).
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
import time
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import structlog
from pydantic import BaseModel

from scenemosaic.agents import AgentLog, AgentPolicy, AgentResult, SceneState, TaskAgent, run_agent
from scenemosaic.evolve._agents import (
    ActorAgent,
    Archetype,
    CriticAgent,
    EvolveState,
    PoseAgent,
    PoseState,
    RoundInput,
    RoundState,
    named_objects,
)
from scenemosaic.evolve._analysis import (
    Finding,
    LayoutRule,
    PhysicalCheck,
    find_problems,
    merged_fixes,
    physical_check,
    rule_violations,
)
from scenemosaic.evolve._context import UnitContext, parts_in_the_way, screens_put_behind, windows_in_the_way
from scenemosaic.evolve._memory import LayoutMemory, RoundRecord
from scenemosaic.evolve._views import scene_with, unit_view_png
from scenemosaic.models import Model, ModelSettings
from scenemosaic.physics import ObjectShape, SettleSettings, SimSettings, UnitPlan, settle_unit
from scenemosaic.scene import (
    LayoutState2D,
    Pose,
    Scene,
    UnitLayout,
    normalize_degrees,
    unit_layout,
    write_atomic,
)

__all__ = ["EARLY_STOP_MOVE_M", "EARLY_STOP_TURN_DEG", "MAX_ROUNDS", "LayoutResult", "evolve_layout"]

log = structlog.get_logger(__name__)

MAX_ROUNDS = 8
"""Round cap of one layout's loop (fixes cascade: a bed pushed to its wall moves its nightstands,
which may then meet a wardrobe; eight rounds settle the heavily disturbed layouts we tried)."""
EARLY_STOP_MOVE_M = 0.01
"""Early stop: no object moved further than this in the last round..."""
EARLY_STOP_TURN_DEG = 0.5
"""... nor turned by more than this, and the layout is free of collisions and out-of-bounds objects."""


@dataclass
class LayoutResult:
    """One evolved layout of one unit: final poses (anchor frame), checks, rounds and costs."""

    anchor_id: str
    layout_id: str
    style_name: str = "original"
    reasoning: str = ""
    local_poses: dict[str, Pose] = field(default_factory=dict)
    """Children's poses in the anchor frame after the final settle."""
    state: LayoutState2D | None = None
    check: PhysicalCheck | None = None
    violations: list[str] = field(default_factory=list)
    rounds: list[RoundRecord] = field(default_factory=list)
    selected_round: int = 0
    stop_reason: str = ""
    settle_moves_m: float = 0.0
    agents: AgentLog = field(default_factory=AgentLog)
    """Every agent result of this layout (the pose agent's, each round's critic and actor; the
    refined original also the unit's archetype agent's): outcomes, fallbacks, requests."""
    views: list[str] = field(default_factory=list)
    wall_s: float = 0.0
    error: str | None = None

    @property
    def valid(self) -> bool:
        """Physically clean after the final settle (no collisions, nothing out of bounds)."""
        return self.check is not None and self.check.clean

    def summary(self) -> dict[str, Any]:
        """JSON-ready record for reports."""
        return {
            "anchor": self.anchor_id,
            "layout_id": self.layout_id,
            "style": self.style_name,
            "reasoning": self.reasoning,
            "valid": self.valid,
            "collisions": [f"{p.a}~{p.b}" for p in (self.check.collisions if self.check else ())],
            "out_of_bounds": list(self.check.out_of_bounds) if self.check else [],
            "violations": list(self.violations),
            "rounds": len(self.rounds),
            "selected_round": self.selected_round,
            "stop_reason": self.stop_reason,
            "settle_moves_m": round(self.settle_moves_m, 4),
            "requests": self.agents.usage.requests,
            "answered_by": sorted({r.outcome.answered_by for r in self.agents.results}),
            "error": self.error,
            "wall_s": round(self.wall_s, 3),
        }


def _poses(layout: UnitLayout) -> dict[str, tuple[float, float, float]]:
    return {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids}


def _moved(a: UnitLayout, b: UnitLayout) -> tuple[float, float]:
    move = max((math.dist(a.center(k), b.center(k)) for k in a.ids), default=0.0)
    turn = max((abs((a.rotation(k) - b.rotation(k) + 180) % 360 - 180) for k in a.ids), default=0.0)
    return move, turn


S = TypeVar("S", bound=SceneState)
OutT = TypeVar("OutT", bound=BaseModel)


async def _ask(
    agent: TaskAgent[S, Any, OutT], state: S, model: Model, settings: ModelSettings | None, result: LayoutResult
) -> AgentResult[OutT]:
    """Run ``agent`` (its answer applied to ``state`` when it changes the state) and record its
    result in the layout's log."""
    return await run_agent(agent, state, model, settings, log=result.agents)


def _binding(findings: Sequence[Finding]) -> list[Finding]:
    """The rule findings no answer may overrule: physical or semantic problems the rules can fix
    (a collision, an object out of bounds, a seat not square to its table, a cut passage, a wall
    piece off its wall...). Soft remarks are the critic's to weigh."""
    return [f for f in findings if f.severity != "soft" and f.fixes]


def _mandatory(notes: list[str], findings: Sequence[Finding], layout: UnitLayout) -> list[str]:
    """The critic's notes plus the note of each binding rule finding (:func:`_binding`) about
    objects it did not name: a critic's "no change" does not end the loop while they stand."""
    named = named_objects(notes, layout)
    extra = [f for f in _binding(findings) if not set(f.fixes) <= named]
    return [*notes, *(f.note for f in extra)]


def _enforce(before: UnitLayout, after: UnitLayout, findings: Sequence[Finding]) -> list[str]:
    """Apply the rule fix of every binding finding to each object it fixes that the actor left
    where it was (within 1 cm and 0.5 degrees); returns those objects."""
    fixes = merged_fixes(_binding(findings), allowed=set(after.ids))
    done: list[str] = []
    for oid, t in sorted(fixes.items()):
        moved = math.dist(before.center(oid), after.center(oid)) >= EARLY_STOP_MOVE_M
        turned = abs(normalize_degrees(after.rotation(oid) - before.rotation(oid))) >= EARLY_STOP_TURN_DEG
        if moved or turned:
            continue
        if t.rotation is not None:
            after.set_rotation(oid, t.rotation)
        if t.u is not None and t.v is not None:
            after.set_center(oid, t.u, t.v)
        done.append(oid)
    return done


async def evolve_layout(
    scene: Scene,
    ctx: UnitContext,
    layout: UnitLayout,
    shapes: Mapping[str, ObjectShape],
    model: Model,
    *,
    layout_id: str = "original",
    archetype: Archetype | None = None,
    settings: ModelSettings | None = None,
    policy: AgentPolicy | None = None,
    max_rounds: int = MAX_ROUNDS,
    seed: int = 0,
    base_dir: Path | None = None,
    views_dir: Path | None = None,
    vision: bool | None = None,
    rules: Sequence[LayoutRule] = (),
    agent_log: AgentLog | None = None,
) -> LayoutResult:
    """Evolve one layout of ``ctx.unit`` (the original, or an archetype instantiated first by the
    pose agent) through the Critic-Actor loop, then settle it; never modifies ``scene``.
    ``rules``: plugin rules whose findings join the critic's evidence (:data:`LayoutRule`).
    ``agent_log`` becomes the result's ``agents`` (a caller that keeps it sees the agents' results and
    requests of a loop that fails); default: a new one."""
    t0 = time.perf_counter()
    anchor = ctx.unit.anchor_id
    result = LayoutResult(anchor_id=anchor, layout_id=layout_id, agents=agent_log if agent_log is not None else AgentLog())
    if archetype is not None:
        result.style_name, result.reasoning = archetype.layout_style_name, archetype.layout_reasoning
    use_vision = model.vision if vision is None else vision

    def view(shown: UnitLayout) -> bytes:
        return unit_view_png(scene, shown, base_dir=base_dir)

    state = EvolveState(
        scene=scene, seed=seed, base_dir=base_dir, policy=policy or AgentPolicy(), layout=layout.copy(), context=ctx,
        view=view if use_vision and not model.uses_rule_solvers else None,
    )  # fmt: skip

    def save_view(name: str) -> None:
        if views_dir is None:
            return
        views_dir.mkdir(parents=True, exist_ok=True)
        path = views_dir / f"{name}.png"
        write_atomic(path, view(state.layout))
        result.views.append(str(path))

    if archetype is not None:
        posing = PoseState(**state.shared(), archetype=archetype)
        await _ask(PoseAgent(), posing, model, settings, result)
        state.layout = posing.layout
    critic, actor = CriticAgent(), ActorAgent()
    memory: LayoutMemory = state.memory
    candidates: list[tuple[int, UnitLayout, PhysicalCheck]] = []
    last_move: tuple[float, float] | None = None
    check: PhysicalCheck | None = None
    stop = f"round cap ({max_rounds})"
    for rnd in range(1, max_rounds + 1):
        current = state.layout
        check = await asyncio.to_thread(physical_check, current, ctx, shapes)
        candidates.append((rnd, current.copy(), check))
        still = last_move is not None and last_move[0] < EARLY_STOP_MOVE_M and last_move[1] < EARLY_STOP_TURN_DEG
        if still and check.clean:
            stop = "early stop: converged"
            break
        if still and not model.uses_rule_solvers:  # a model's round that changed nothing: the next asks the same again
            stop = "early stop: the last round changed nothing"
            break
        findings = tuple(await asyncio.to_thread(find_problems, current, ctx, check, memory.avoid(), rules))
        await asyncio.to_thread(save_view, f"round_{rnd}")
        judged = RoundInput(round=rnd, check=check, findings=findings)
        verdict = (await _ask(critic, RoundState(**state.shared(), input=judged), model, settings, result)).output
        notes = _mandatory(list(verdict.modification_notes), findings, current)
        record = RoundRecord(
            round=rnd, poses=_poses(current), collisions=[(p.a, p.b, p.contacts) for p in check.collisions],
            out_of_bounds=list(check.out_of_bounds), score=verdict.quality_score, notes=notes,
        )  # fmt: skip
        if not verdict.should_modify and len(notes) == len(verdict.modification_notes):
            memory.add(record)
            stop = "critic asked for no change"
            break
        before = current.copy()
        acting = RoundState(**state.shared(), input=dataclasses.replace(judged, notes=tuple(notes)))
        reply = await _ask(actor, acting, model, settings, result)
        state.layout = after = acting.layout
        record.enforced = _enforce(before, after, findings)
        record.expressions = list(reply.output.pose_expressions)
        record.resolved = _poses(after)
        record.refused = ["; ".join(problems)[:400] for problems in reply.problems]
        memory.add(record)
        last_move = _moved(before, after)
    else:
        current = state.layout
        check = await asyncio.to_thread(physical_check, current, ctx, shapes)
        candidates.append((max_rounds + 1, current.copy(), check))
    final_round, chosen, chosen_check = candidates[-1]
    if not chosen_check.clean:
        final_round, chosen, chosen_check = min(candidates, key=lambda c: (c[2].count, -c[0]))
    result.rounds = memory.rounds
    result.selected_round = final_round
    result.stop_reason = stop
    def finish() -> UnitLayout:
        """Settle the chosen round, check it again, and keep its poses in the anchor's frame."""
        settled, moves = _settle(scene, ctx, chosen, shapes, seed)
        result.settle_moves_m = moves
        result.check = physical_check(settled, ctx, shapes)
        result.violations = rule_violations(settled, ctx, result.check)
        result.violations += _use_violations(settled, ctx)
        if archetype is None and result.violations and not _use_violations(layout, ctx):
            # the refined original blocks a part, a window or a screen the stabilized layout kept
            # (settling slid soap back into a lid's way): the stabilized layout, as it stood, if it
            # breaks nothing
            check = physical_check(layout, ctx, shapes)
            kept = rule_violations(layout, ctx, check)
            if check.clean and not kept:
                settled, result.check, result.violations, result.settle_moves_m = layout.copy(), check, kept, 0.0
        result.state = settled.state()
        local = unit_layout(scene_with(scene, settled), anchor)
        result.local_poses = {k: p for k, p in local.items() if k in set(layout.ids)}
        return settled

    state.layout = await asyncio.to_thread(finish)
    await asyncio.to_thread(save_view, "final")
    result.wall_s = time.perf_counter() - t0
    log.info(
        "layout_evolved", unit=anchor, layout=layout_id, rounds=len(result.rounds), stop=stop,
        valid=result.valid, violations=len(result.violations), wall_s=round(result.wall_s, 3),
    )  # fmt: skip
    return result


def _settle(
    scene: Scene, ctx: UnitContext, layout: UnitLayout, shapes: Mapping[str, ObjectShape], seed: int
) -> tuple[UnitLayout, float]:
    """Gravity settle of the unit with its anchor as the ground; returns the settled layout and
    the largest move the settle made."""
    posed = scene_with(scene, layout)
    plan = UnitPlan(ctx.unit.anchor_id, ctx.unit.anchor_kind, tuple(layout.ids), 0)
    neighbours = [o.id for o in ctx.obstacles]
    poses, _ = settle_unit(
        posed, plan, shapes, neighbours, sim=SimSettings(), settle=SettleSettings(),
        seed=zlib.crc32(f"{seed}:{ctx.unit.anchor_id}:settle".encode()),
    )  # fmt: skip
    objects = [o.model_copy(update={"pose": poses[o.id]}) if o.id in poses else o for o in posed.objects]
    settled = posed.model_copy(update={"objects": objects})
    out = UnitLayout.from_scene(settled, ctx.unit)
    moves = max((math.dist(out.pose(k).position, layout.pose(k).position) for k in layout.ids), default=0.0)
    return out, moves


def _use_violations(layout: UnitLayout, ctx: UnitContext) -> list[str]:
    """What a finished layout takes from the use of the room that its stabilized layout kept: a
    part it keeps from opening (a unit of what stands on furniture:
    :func:`~scenemosaic.evolve.parts_in_the_way`), a window a floor piece newly stands before
    (:func:`~scenemosaic.evolve.windows_in_the_way`: the loop may move a chair there after its
    pattern was checked) and a bed or sofa newly turned from its screen
    (:func:`~scenemosaic.evolve.screens_put_behind`)."""
    return [*parts_in_the_way(layout, ctx), *windows_in_the_way(layout, ctx), *screens_put_behind(layout, ctx)]

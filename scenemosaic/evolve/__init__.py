"""Stage 4 of the method: every local unit evolves on its orthographic 2D view.

Per unit, the stabilized original and (on request) structurally different variants each run a
Critic-Actor loop: the critic judges the layout (view, 2D state, collisions with contact
counts, out-of-bounds objects, cross-unit clauses, layout memory) and writes notes in words;
the actor turns the notes into pose expressions, evaluated by the sandbox of
:mod:`scenemosaic.scene` (``chair_0.center.u = table_0.bbox.max_u + 0.3``); physics settles
the chosen round. Entry point: :func:`evolve_scene`; one layout: :func:`evolve_layout`. The
agents (:class:`CriticAgent`, :class:`ActorAgent`, :class:`ArchetypeAgent`, :class:`PoseAgent`)
are task agents with rule solvers, so the loop runs offline; the critic and the actor get each
round's input as a frozen :class:`RoundInput` (in a :class:`RoundState`). See ``docs/evolution.md``.
"""

from scenemosaic.evolve._agents import (
    ActorAgent,
    ActorEvidence,
    ActorOutput,
    Archetype,
    ArchetypeAgent,
    ArchetypeOutput,
    CriticAgent,
    CriticEvidence,
    CriticOutput,
    EvolveState,
    PoseAgent,
    PoseOutput,
    PosePlacement,
    PoseState,
    RoundInput,
    RoundState,
    named_objects,
)
from scenemosaic.evolve._analysis import (
    BESIDE_GAP_MAX,
    FACING_TABLE_DEG,
    HEAD_ZONE,
    SEAT_GAP_MAX,
    SEAT_SQUARE_DEG,
    WALL_FACING_DEG,
    WALL_GAP_MAX,
    Finding,
    LayoutRule,
    PhysicalCheck,
    SeatSlot,
    Target,
    find_problems,
    merged_fixes,
    physical_check,
    rule_violations,
    seat_slots,
    seating_breaches,
)
from scenemosaic.evolve._archetypes import RuleArchetype, instantiate, max_alternatives, rule_archetypes
from scenemosaic.evolve._context import (
    UnitContext,
    WallLine,
    parts_in_the_way,
    screens_put_behind,
    unit_context,
    windows_in_the_way,
)
from scenemosaic.evolve._evolve import (
    MAX_ALTERNATIVES,
    EvolutionReport,
    UnitEvolution,
    alternative_counts,
    evolve_scene,
    unit_obstacles,
)
from scenemosaic.evolve._loop import (
    EARLY_STOP_MOVE_M,
    EARLY_STOP_TURN_DEG,
    MAX_ROUNDS,
    LayoutResult,
    evolve_layout,
)
from scenemosaic.evolve._memory import LayoutMemory, RoundRecord
from scenemosaic.evolve._views import VIEW_PX, unit_view, unit_view_png

__all__ = [
    "BESIDE_GAP_MAX",
    "EARLY_STOP_MOVE_M",
    "EARLY_STOP_TURN_DEG",
    "FACING_TABLE_DEG",
    "HEAD_ZONE",
    "MAX_ALTERNATIVES",
    "MAX_ROUNDS",
    "SEAT_GAP_MAX",
    "SEAT_SQUARE_DEG",
    "VIEW_PX",
    "WALL_FACING_DEG",
    "WALL_GAP_MAX",
    "ActorAgent",
    "ActorEvidence",
    "ActorOutput",
    "Archetype",
    "ArchetypeAgent",
    "ArchetypeOutput",
    "CriticAgent",
    "CriticEvidence",
    "CriticOutput",
    "EvolutionReport",
    "EvolveState",
    "Finding",
    "LayoutMemory",
    "LayoutResult",
    "LayoutRule",
    "PhysicalCheck",
    "PoseAgent",
    "PoseOutput",
    "PosePlacement",
    "PoseState",
    "RoundInput",
    "RoundRecord",
    "RoundState",
    "RuleArchetype",
    "SeatSlot",
    "Target",
    "UnitContext",
    "UnitEvolution",
    "WallLine",
    "alternative_counts",
    "evolve_layout",
    "evolve_scene",
    "find_problems",
    "instantiate",
    "max_alternatives",
    "merged_fixes",
    "named_objects",
    "parts_in_the_way",
    "physical_check",
    "rule_archetypes",
    "rule_violations",
    "screens_put_behind",
    "seat_slots",
    "seating_breaches",
    "unit_context",
    "unit_obstacles",
    "unit_view",
    "unit_view_png",
    "windows_in_the_way",
]

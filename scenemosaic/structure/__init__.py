"""Relation-guided structuring (stage 2 of the method): the manager and the structuring agents.

:func:`structure_scene` runs the whole stage: the manager agent plans which structuring agents
to run (room and walls, support, containment, wall attachment, semantic refinement, simulation
attributes, cross-unit constraints, verification), and the task-graph runtime runs them. Every
agent has a prompt beside it (``structure/prompts/<name>.md``), a bounded pydantic output, a
deterministic rule solver (the offline answer), a ``check`` that turns inconsistent outputs into
repair requests, and an ``apply``.
"""

from scenemosaic.structure._attributes import (
    ATTRIBUTE_TABLE,
    AttributesAgent,
    AttributesOutput,
    ObjectAttributes,
    attribute_row,
)
from scenemosaic.structure._constraints import (
    FUNCTIONAL_PAIRS,
    WEAK_PAIRS,
    ConstraintsAgent,
    ConstraintsOutput,
)
from scenemosaic.structure._containment import ContainedItem, ContainmentAgent, ContainmentOutput
from scenemosaic.structure._manager import (
    DEFAULT_AGENTS,
    REQUIRED_AGENTS,
    ManagerAgent,
    PlannedAgent,
    SceneSummary,
    StructuringPlan,
    plan_structuring,
    select_agents,
)
from scenemosaic.structure._room import RoomAgent, RoomOutput, WallSpec
from scenemosaic.structure._semantics import SemanticItem, SemanticsAgent, SemanticsOutput
from scenemosaic.structure._structure import structure_scene
from scenemosaic.structure._support import SupportAgent, SupportAssignment, SupportOutput
from scenemosaic.structure._verify import PLAUSIBLE_P, ParentFix, VerificationAgent, VerificationOutput
from scenemosaic.structure._walls import WallAttachmentAgent, WallItem, WallOutput

__all__ = [
    "ATTRIBUTE_TABLE",
    "DEFAULT_AGENTS",
    "FUNCTIONAL_PAIRS",
    "PLAUSIBLE_P",
    "REQUIRED_AGENTS",
    "WEAK_PAIRS",
    "AttributesAgent",
    "AttributesOutput",
    "ConstraintsAgent",
    "ConstraintsOutput",
    "ContainedItem",
    "ContainmentAgent",
    "ContainmentOutput",
    "ManagerAgent",
    "ObjectAttributes",
    "ParentFix",
    "PlannedAgent",
    "RoomAgent",
    "RoomOutput",
    "SceneSummary",
    "SemanticItem",
    "SemanticsAgent",
    "SemanticsOutput",
    "StructuringPlan",
    "SupportAgent",
    "SupportAssignment",
    "SupportOutput",
    "VerificationAgent",
    "VerificationOutput",
    "WallAttachmentAgent",
    "WallItem",
    "WallOutput",
    "WallSpec",
    "attribute_row",
    "plan_structuring",
    "select_agents",
    "structure_scene",
]

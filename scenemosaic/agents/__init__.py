"""Task agents: the base class, the scheduler adapter, the manager and the structuring agents.

:func:`structure_scene` runs the whole relation-guided structuring stage: the manager agent
plans which of the eight structuring agents to run (room and walls, support, containment,
wall attachment, semantic refinement, simulation attributes, cross-unit constraints,
verification), and the task-graph runtime runs them. Every agent has a prompt under
``prompts/``, a bounded pydantic output, a deterministic rule solver (the ``rules`` model's
answer), a ``check`` that turns inconsistent outputs into repair requests, and an ``apply``.
"""

from scenemosaic.agents._attributes import (
    ATTRIBUTE_TABLE,
    AttributesAgent,
    AttributesOutput,
    ObjectAttributes,
)
from scenemosaic.agents._base import PROMPTS_DIR, SceneState, TaskAgent, load_prompt
from scenemosaic.agents._categories import (
    PRIORS_ENV,
    CategoryTraits,
    SupportPriors,
    load_priors,
    normalize_category,
)
from scenemosaic.agents._constraints import FUNCTIONAL_PAIRS, WEAK_PAIRS, ConstraintsAgent, ConstraintsOutput
from scenemosaic.agents._containment import ContainedItem, ContainmentAgent, ContainmentOutput
from scenemosaic.agents._manager import (
    AGENT_NAMES,
    ManagerAgent,
    PlannedAgent,
    SceneSummary,
    StructuringPlan,
    build_agents,
    plan_structuring,
)
from scenemosaic.agents._node import add_agent_nodes, agent_node, run_agents
from scenemosaic.agents._room import RoomAgent, RoomOutput, WallSpec
from scenemosaic.agents._semantics import SemanticItem, SemanticsAgent, SemanticsOutput
from scenemosaic.agents._structure import structure_scene
from scenemosaic.agents._support import SupportAgent, SupportAssignment, SupportOutput
from scenemosaic.agents._verify import ParentFix, VerificationAgent, VerificationOutput
from scenemosaic.agents._walls import WallAttachmentAgent, WallItem, WallOutput

__all__ = [
    "AGENT_NAMES",
    "ATTRIBUTE_TABLE",
    "FUNCTIONAL_PAIRS",
    "PRIORS_ENV",
    "PROMPTS_DIR",
    "WEAK_PAIRS",
    "AttributesAgent",
    "AttributesOutput",
    "CategoryTraits",
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
    "SceneState",
    "SceneSummary",
    "SemanticItem",
    "SemanticsAgent",
    "SemanticsOutput",
    "StructuringPlan",
    "SupportAgent",
    "SupportAssignment",
    "SupportOutput",
    "SupportPriors",
    "TaskAgent",
    "VerificationAgent",
    "VerificationOutput",
    "WallAttachmentAgent",
    "WallItem",
    "WallOutput",
    "WallSpec",
    "add_agent_nodes",
    "agent_node",
    "build_agents",
    "load_priors",
    "load_prompt",
    "normalize_category",
    "plan_structuring",
    "run_agents",
    "structure_scene",
]

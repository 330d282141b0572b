"""The task-agent framework: the base class, the shared scene state and the scheduler adapter.

A task agent is a typed unit of work (``TaskAgent[StateT, EvidenceT, OutputT]``): it gathers
evidence from its state (a :class:`SceneState` or a subclass), asks a model (or answers with its
own rule solver offline), checks the answer against the scene (unknown and repeated object ids
by the base class), repairs it within one retry budget, and returns an :class:`AgentResult`
without changing the state. The runner applies it: :func:`run_agent` calls the agent's ``apply``
(an agent that changes the state has one, :class:`AppliesOutput`; one that only judges has none)
and hands the result to an :class:`AgentLog`, the one collector of outcomes, fallbacks and usage.
:func:`run_agents` runs a set of agents as a task graph (:mod:`scenemosaic.dag`) through it. The
structuring agents live in :mod:`scenemosaic.structure`; plugins are plain subclasses passed in by
the caller.
"""

from scenemosaic.agents._base import (
    MAX_ITEMS,
    PROMPTS_FOLDER,
    AgentOutcome,
    AgentOutput,
    AgentPolicy,
    AgentResult,
    AppliesOutput,
    FallbackRecord,
    Need,
    SceneState,
    TaskAgent,
    calls_of,
    load_prompt,
    prompt_paths,
    run_blocking,
)
from scenemosaic.agents._evidence import NESTED_ROWS_NOTE, TABLE_NOTE, evidence_legend, evidence_text
from scenemosaic.agents._log import AgentLog
from scenemosaic.agents._node import (
    add_agent_nodes,
    agent_dependencies,
    agent_node,
    apply_result,
    run_agent,
    run_agents,
)

__all__ = [
    "MAX_ITEMS",
    "NESTED_ROWS_NOTE",
    "PROMPTS_FOLDER",
    "TABLE_NOTE",
    "AgentLog",
    "AgentOutcome",
    "AgentOutput",
    "AgentPolicy",
    "AgentResult",
    "AppliesOutput",
    "FallbackRecord",
    "Need",
    "SceneState",
    "TaskAgent",
    "add_agent_nodes",
    "agent_dependencies",
    "agent_node",
    "apply_result",
    "calls_of",
    "evidence_legend",
    "evidence_text",
    "load_prompt",
    "prompt_paths",
    "run_agent",
    "run_agents",
    "run_blocking",
]

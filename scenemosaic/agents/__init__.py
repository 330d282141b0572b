"""The task-agent framework: the base class, the shared scene state and the scheduler adapter.

A task agent is a typed unit of work (``TaskAgent[StateT, EvidenceT, OutputT]``): it gathers
evidence from its state (a :class:`SceneState` or a subclass), asks a model (or answers with its
own rule solver offline), checks the answer against the scene (unknown and repeated object ids
by the base class), repairs it within one retry budget, applies it, and returns an
:class:`AgentResult`. :func:`run_agents` runs a set of agents as a task graph
(:mod:`scenemosaic.dag`) and hands each result to its ``on_result`` callback. The structuring agents live in
:mod:`scenemosaic.structure`; plugins are plain subclasses passed in by the caller.
"""

from scenemosaic.agents._base import (
    MAX_ITEMS,
    PROMPTS_FOLDER,
    AgentOutcome,
    AgentOutput,
    AgentPolicy,
    AgentResult,
    FallbackRecord,
    SceneState,
    TaskAgent,
    load_prompt,
    prompt_paths,
    run_blocking,
)
from scenemosaic.agents._evidence import TABLE_NOTE, evidence_legend, evidence_text
from scenemosaic.agents._node import (
    ResultListener,
    add_agent_nodes,
    agent_dependencies,
    agent_node,
    run_agents,
)

__all__ = [
    "MAX_ITEMS",
    "PROMPTS_FOLDER",
    "TABLE_NOTE",
    "AgentOutcome",
    "AgentOutput",
    "AgentPolicy",
    "AgentResult",
    "FallbackRecord",
    "ResultListener",
    "SceneState",
    "TaskAgent",
    "add_agent_nodes",
    "agent_dependencies",
    "agent_node",
    "evidence_legend",
    "evidence_text",
    "load_prompt",
    "prompt_paths",
    "run_agents",
    "run_blocking",
]

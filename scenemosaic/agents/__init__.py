"""The task-agent framework: the base class, the shared scene state and the scheduler adapter.

A task agent is a typed unit of work: it gathers evidence from a :class:`SceneState`, asks a
model (or answers with its own rule solver offline), checks the answer against the scene,
repairs it within one retry budget, and applies it. :func:`run_agents` runs a set of agents
as a task graph (:mod:`scenemosaic.dag`). The structuring agents live in
:mod:`scenemosaic.structure`; plugins are plain subclasses passed in by the caller.
"""

from scenemosaic.agents._base import (
    MAX_ITEMS,
    PROMPTS_FOLDER,
    AgentOutcome,
    AgentOutput,
    AgentPolicy,
    FallbackRecord,
    SceneState,
    TaskAgent,
    load_prompt,
    prompt_paths,
    run_blocking,
)
from scenemosaic.agents._evidence import TABLE_NOTE, evidence_legend, evidence_text
from scenemosaic.agents._node import add_agent_nodes, agent_dependencies, agent_node, run_agents

__all__ = [
    "MAX_ITEMS",
    "PROMPTS_FOLDER",
    "TABLE_NOTE",
    "AgentOutcome",
    "AgentOutput",
    "AgentPolicy",
    "FallbackRecord",
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

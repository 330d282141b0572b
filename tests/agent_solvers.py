"""A test stand-in for a VLM that answers like the rules would: the asking agent's own solver.

Models in the package never call agent code; a test model may, to script "a model that happens
to give the rule answer" except where a test wants a bad reply.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from scenemosaic.agents import TaskAgent
from scenemosaic.evolve import ActorAgent, ArchetypeAgent, CriticAgent, PoseAgent
from scenemosaic.models import Message, RequestContext
from scenemosaic.structure import DEFAULT_AGENTS, ManagerAgent

SOLVERS: dict[str, TaskAgent[Any, Any, Any]] = {
    a.name: a for a in (ManagerAgent(), *DEFAULT_AGENTS, CriticAgent(), ActorAgent(), ArchetypeAgent(), PoseAgent())
}


def solver_answer(messages: list[Message], context: RequestContext | None) -> BaseModel:
    """The rule answer of the agent named in ``context`` to the evidence it sent."""
    assert context is not None and context.evidence is not None
    agent = SOLVERS[context.agent]
    answer: BaseModel = agent.solve(context.evidence)
    return answer

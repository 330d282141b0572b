"""Adapter from :class:`~scenemosaic.agents.TaskAgent` to scheduler nodes.

* :func:`agent_node` — one agent as a :class:`~scenemosaic.dag.Node`.
* :func:`run_agents` — a graph from the agents' ``name`` / ``depends_on``, run to the end.
* :func:`add_agent_nodes` — from inside a running node (a manager agent), schedule more agents.

An agent writes its output into the shared :class:`~scenemosaic.agents.SceneState` and returns
an :class:`~scenemosaic.agents.AgentResult`; the node hands that result to the runner's
``on_result`` callback (how each agent was answered, its fallback, its usage) and outputs the
agent's output. When a run store supplies a stored output instead of running the agent, the
node's ``restore`` hook applies that output to the state again, so a resumed run ends in the
same state (and reports no result: the agent did not run).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar, cast

import structlog
from pydantic import BaseModel

from scenemosaic.agents._base import AgentResult, SceneState, TaskAgent, run_blocking
from scenemosaic.dag import (
    EventListener,
    Node,
    NodeContext,
    NodePolicy,
    Runner,
    RunStore,
    current_context,
)
from scenemosaic.models import Model, ModelSettings, UsageTracker

__all__ = ["add_agent_nodes", "agent_dependencies", "agent_node", "run_agents"]

_log = structlog.get_logger(__name__)

S = TypeVar("S", bound=SceneState)

ResultListener = Callable[[AgentResult[Any]], None]
"""Receives each agent's :class:`~scenemosaic.agents.AgentResult` as the agent finishes."""


def _definition_key(agent: TaskAgent[Any, Any, Any]) -> str:
    cls = type(agent)
    version = getattr(agent, "version", None)
    key = f"{cls.__module__}:{cls.__qualname__}"
    return f"{key}@{version}" if version is not None else key


def agent_dependencies(agents: Sequence[TaskAgent[Any, Any, Any]]) -> dict[str, tuple[str, ...]]:
    """Each agent's dependencies within ``agents``: its ``depends_on`` trimmed to the agents
    present, or, for an agent that ``runs_last``, every agent that does not run last."""
    names = [a.name for a in agents]
    present = set(names)
    ordinary = [a.name for a in agents if not getattr(a, "runs_last", False)]
    deps: dict[str, tuple[str, ...]] = {}
    for agent in agents:
        if getattr(agent, "runs_last", False):
            wanted = [n for n in ordinary if n != agent.name]
        else:
            wanted = [d for d in agent.depends_on if d in present]
            absent = [d for d in agent.depends_on if d not in present]
            if absent:
                _log.debug("agent_dependency_absent", agent=agent.name, absent=absent)
        deps[agent.name] = tuple(dict.fromkeys(wanted))
    return deps


def agent_node(
    agent: TaskAgent[S, Any, Any],
    state: S,
    model: Model,
    settings: ModelSettings | None = None,
    policy: NodePolicy | None = None,
    *,
    depends_on: Sequence[str] | None = None,
    on_result: ResultListener | None = None,
) -> Node:
    """A node named ``agent.name``, depending on ``depends_on`` (default ``agent.depends_on``), that runs
    ``agent.run(state, model, settings, node=name)``, gives its result to ``on_result`` and
    outputs the agent's validated output.

    The definition key (part of the run store's input hash) is the agent's class path plus its
    ``version`` attribute when it has one: bump ``version`` when a prompt or solver changes.
    """

    async def run_agent(ctx: NodeContext) -> BaseModel:
        result = await agent.run(state, model, settings, node=ctx.name)
        # Token accounting belongs to the instrumented model; this is only a trace.
        _log.debug("agent_done", agent=agent.name, node=ctx.name, requests=result.usage.requests)
        if on_result is not None:
            on_result(result)
        return cast(BaseModel, result.output)

    def reapply(output: Any) -> None:
        agent.apply(output, state)
        state.outputs[agent.name] = output

    async def restore(output: Any) -> None:
        async with state.lock:
            await run_blocking(reapply, output, offload=getattr(agent, "offload", True))

    run_agent.__qualname__ = f"agent_node[{agent.name}]"
    return Node(
        agent.name,
        run_agent,
        depends_on=tuple(agent.depends_on if depends_on is None else depends_on),
        policy=policy or NodePolicy(),
        version=_definition_key(agent),
        restore=restore,
    )


def add_agent_nodes(
    agents: Iterable[TaskAgent[S, Any, Any]],
    state: S,
    model: Model,
    settings: ModelSettings | None = None,
    policy: NodePolicy | None = None,
    *,
    on_result: ResultListener | None = None,
) -> None:
    """Add ``agents`` as nodes to the run of the node calling this (e.g. a manager agent).

    Dependencies may name agents already in the graph or among ``agents``; ``on_result``
    receives each one's :class:`~scenemosaic.agents.AgentResult`.
    """
    current_context().add_nodes(agent_node(a, state, model, settings, policy, on_result=on_result) for a in agents)


def _config_key(state: SceneState, model: Model, settings: ModelSettings | None) -> str:
    h = hashlib.sha256()
    h.update(state.scene.model_dump_json().encode())
    h.update(f"\x00{model.name}\x00{settings!r}\x00{state.seed}\x00{state.policy!r}".encode())
    return h.hexdigest()


async def run_agents(
    agents: Sequence[TaskAgent[S, Any, Any]],
    state: S,
    model: Model,
    *,
    settings: ModelSettings | None = None,
    store: RunStore | None = None,
    max_concurrency: int | None = 8,
    events: EventListener | None = None,
    usage: UsageTracker | None = None,
    defaults: NodePolicy | None = None,
    on_result: ResultListener | None = None,
) -> dict[str, BaseModel]:
    """Run ``agents`` as a task graph over ``state``; return each agent's output by name.

    Args:
        agents: the agents; each one's ``depends_on`` is trimmed to agents in this list
            (:func:`agent_dependencies`), and one that ``runs_last`` waits for all the others.
        state: the shared scene state the agents read and write (its ``seed`` is the run seed).
        model: the model every agent asks.
        settings: per-request model settings.
        store: run store for resuming; the config key covers the input scene, model name,
            settings and seed, so a different input never reuses stored outputs.
        max_concurrency: most agents running at once.
        events: callback receiving every run event.
        usage: usage tracker (also pass it to the instrumented model as ``on_call``).
        defaults: graph-wide node policies.
        on_result: receives each agent's :class:`~scenemosaic.agents.AgentResult` as it finishes
            (how it was answered, its solver fallback, its usage); agents restored from
            ``store`` did not run and give none.

    Raises the run errors of :class:`~scenemosaic.dag.Runner` (``NodeFailedError`` whose
    ``cause`` is, e.g., an ``AgentOutputError``; ``RunCancelledError``; ``UsageLimitExceeded``)
    and ``GraphDefinitionError`` for duplicate names, unknown dependencies or cycles.
    """
    deps = agent_dependencies(agents)
    nodes = [
        agent_node(agent, state, model, settings, depends_on=deps[agent.name], on_result=on_result)
        for agent in agents
    ]
    runner = Runner(
        nodes,
        max_concurrency=max_concurrency,
        defaults=defaults,
        store=store,
        config_key=_config_key(state, model, settings) if store is not None else "",
        seed=state.seed,
        usage=usage,
        listeners=(events,) if events is not None else (),
    )
    outputs = await runner.run()
    return cast(dict[str, BaseModel], outputs)

"""Running task agents: the runner that applies their results, alone or as scheduler nodes.

* :func:`run_agent` — run one agent, apply its result to the state, hand it to an
  :class:`~scenemosaic.agents.AgentLog`: the one runner every caller goes through (the nodes
  below, the evolve loop, perception, the judge).
* :func:`apply_result` — the write itself: the agent's ``apply`` (agents that only judge have
  none), ``state.outputs``, the result's provenance notes.
* :func:`agent_node` — one agent as a :class:`~scenemosaic.dag.Node`.
* :func:`run_agents` — a graph from the agents' ``name`` / ``depends_on``, run to the end.
* :func:`add_agent_nodes` — from inside a running node (a manager agent), schedule more agents.

An agent's ``run`` returns an :class:`~scenemosaic.agents.AgentResult` and changes nothing; the
node applies it to the shared :class:`~scenemosaic.agents.SceneState`, records it in the run's
log (how each agent was answered, its fallback, its requests) and outputs the agent's output.
When a run store supplies a stored output instead of running the agent, the node's ``restore``
hook applies that output to the state again, so a resumed run ends in the same state (and logs
no result: the agent did not run).
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Iterable, Sequence
from typing import Any, TypeVar, cast

import structlog
from pydantic import BaseModel

from scenemosaic.agents._base import AgentResult, AppliesOutput, SceneState, TaskAgent, run_blocking
from scenemosaic.agents._log import AgentLog
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

__all__ = ["add_agent_nodes", "agent_dependencies", "agent_node", "apply_result", "run_agent", "run_agents"]

_log = structlog.get_logger(__name__)

S = TypeVar("S", bound=SceneState)
OutT = TypeVar("OutT", bound=BaseModel)


def apply_result(agent: TaskAgent[S, Any, OutT], output: OutT, state: S, notes: Sequence[str] = ()) -> None:
    """Write an agent's output into ``state`` (the caller holds ``state.lock``): through the agent's
    ``apply`` when it has one (:class:`~scenemosaic.agents.AppliesOutput`; an agent that only judges
    has none), under ``state.outputs[agent.name]``, and ``notes`` into the scene's provenance notes."""
    if isinstance(agent, AppliesOutput):
        agent.apply(output, state)
    state.outputs[agent.name] = output
    if notes:
        state.scene.provenance.notes.extend(notes)
    state.revision += 1


def _apply_if_usable(agent: TaskAgent[S, Any, Any], result: AgentResult[Any], state: S, checked_at: int) -> list[str]:
    """Apply ``result`` unless other results were applied since ``checked_at`` (the revision when
    the agent began) and its output no longer fits the state (then its problems; nothing applied)."""
    if state.revision != checked_at:
        problems = agent.problems(result.output, state)
        if problems:
            return problems
    apply_result(agent, result.output, state, result.notes)
    return []


def _joined(earlier: AgentResult[Any], later: AgentResult[OutT], problems: list[str]) -> AgentResult[OutT]:
    """One result for an agent run twice (its first answer went stale): the second answer, the
    requests, usage and refused answers of both."""
    outcome = dataclasses.replace(
        later.outcome,
        requests=earlier.outcome.requests + later.outcome.requests,
        repairs=earlier.outcome.repairs + later.outcome.repairs,
    )
    return dataclasses.replace(
        later,
        outcome=outcome,
        usage=earlier.usage + later.usage,
        problems=(*earlier.problems, tuple(problems), *later.problems),
        calls=(*earlier.calls, *later.calls),
    )


async def run_agent(
    agent: TaskAgent[S, Any, OutT],
    state: S,
    model: Model,
    settings: ModelSettings | None = None,
    *,
    node: str | None = None,
    log: AgentLog | None = None,
) -> AgentResult[OutT]:
    """Run ``agent`` over ``state``, apply its result, hand it to ``log``; return the result.

    ``agent.run`` answers without changing the state; this applies the answer under
    ``state.lock`` (in a worker thread unless the agent's ``offload`` is off, see
    :func:`apply_result`). When other agents' results were applied while this one ran (agents
    running concurrently on one state, :attr:`SceneState.revision`), its answer is checked again
    against the state as it is now; one that no longer fits is asked for again, and the one result
    returned covers both runs. When the run raises, ``log`` still gets its model requests.
    """
    earlier: AgentResult[Any] | None = None
    stale: list[str] = []
    while True:
        checked_at = state.revision
        try:
            answer = await agent.run(state, model, settings, node=node)
        except BaseException as exc:
            if log is not None:
                log.record_failure(exc, earlier.calls if earlier is not None else ())
            raise
        result = answer if earlier is None else _joined(earlier, answer, stale)
        async with state.lock:
            stale = await run_blocking(
                _apply_if_usable, agent, answer, state, checked_at, offload=getattr(agent, "offload", True)
            )
        if not stale:
            break
        _log.info("agent_answer_stale", agent=agent.name, problems=stale[:5])
        earlier = result
    if log is not None:
        log.record(result)
    return result


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
    log: AgentLog | None = None,
) -> Node:
    """A node named ``agent.name``, depending on ``depends_on`` (default ``agent.depends_on``), that runs
    the agent (:func:`run_agent`: applied to ``state``, recorded in ``log``) and outputs the
    agent's validated output.

    The definition key (part of the run store's input hash) is the agent's class path plus its
    ``version`` attribute when it has one: bump ``version`` when a prompt or solver changes.
    """

    async def run_node(ctx: NodeContext) -> BaseModel:
        result = await run_agent(agent, state, model, settings, node=ctx.name, log=log)
        _log.debug("agent_done", agent=agent.name, node=ctx.name, requests=result.usage.requests)
        return cast(BaseModel, result.output)

    async def restore(output: Any) -> None:
        async with state.lock:
            await run_blocking(apply_result, agent, output, state, offload=getattr(agent, "offload", True))

    run_node.__qualname__ = f"agent_node[{agent.name}]"
    return Node(
        agent.name,
        run_node,
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
    log: AgentLog | None = None,
) -> None:
    """Add ``agents`` as nodes to the run of the node calling this (e.g. a manager agent).

    Dependencies may name agents already in the graph or among ``agents``; ``log`` receives
    each one's :class:`~scenemosaic.agents.AgentResult`.
    """
    current_context().add_nodes(agent_node(a, state, model, settings, policy, log=log) for a in agents)


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
    log: AgentLog | None = None,
) -> dict[str, BaseModel]:
    """Run ``agents`` as a task graph over ``state``; return each agent's output by name.

    Args:
        agents: the agents; each one's ``depends_on`` is trimmed to agents in this list
            (:func:`agent_dependencies`), and one that ``runs_last`` waits for all the others.
        state: the shared scene state the agents read and their nodes write (its ``seed`` is the run seed).
        model: the model every agent asks.
        settings: per-request model settings.
        store: run store for resuming; the config key covers the input scene, model name,
            settings and seed, so a different input never reuses stored outputs.
        max_concurrency: most agents running at once. Agents answered by rule solvers
            (``model.uses_rule_solvers``) run one at a time: they ask nothing, so there is nothing
            to overlap, and each one's answer is applied before the next one gathers its evidence.
        events: callback receiving every run event.
        usage: usage tracker (also pass it to the instrumented model as ``on_call``).
        defaults: graph-wide node policies.
        log: receives each agent's :class:`~scenemosaic.agents.AgentResult` as it finishes
            (how it was answered, its solver fallback, its requests); agents restored from
            ``store`` did not run and give none.

    Raises the run errors of :class:`~scenemosaic.dag.Runner` (``NodeFailedError`` whose
    ``cause`` is, e.g., an ``AgentOutputError``; ``RunCancelledError``; ``UsageLimitExceeded``)
    and ``GraphDefinitionError`` for duplicate names, unknown dependencies or cycles.
    """
    deps = agent_dependencies(agents)
    nodes = [
        agent_node(agent, state, model, settings, depends_on=deps[agent.name], log=log) for agent in agents
    ]
    runner = Runner(
        nodes,
        max_concurrency=1 if model.uses_rule_solvers else max_concurrency,
        defaults=defaults,
        store=store,
        config_key=_config_key(state, model, settings) if store is not None else "",
        seed=state.seed,
        usage=usage,
        listeners=(events,) if events is not None else (),
    )
    outputs = await runner.run()
    return cast(dict[str, BaseModel], outputs)

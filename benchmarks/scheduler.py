"""Scheduler benchmark: how close a scene run gets to its critical path, and per-node overhead.

1. A realistic scene DAG over a model whose every call sleeps ``L`` seconds: a manager
   agent that schedules the structuring agents at run time, then per local unit x variant a
   chain of critic/actor rounds, then compose. Reports wall time / critical-path time
   (the longest dependency path, summing call latencies); target <= 1.10.
2. 10,000 no-op nodes (a wide fan-out/fan-in plus chains): wall time / 10,000 in ms;
   target <= 0.5 ms per node.

Run: ``.venv/bin/python benchmarks/scheduler.py [--latency 0.05] [--units 6] [--variants 4]
[--rounds 3] [--nodes 10000] [--repeats 3]``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import statistics
import time
from typing import Any

import networkx as nx
import structlog
from pydantic import BaseModel

from scenemosaic.dag import Node, NodeContext, Runner, TaskGraph
from scenemosaic.dag._graph import NodeFn
from scenemosaic.models import InstrumentedModel, UsageTracker
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage

STRUCTURING: dict[str, tuple[str, ...]] = {
    "room": ("manager",),
    "walls": ("room",),
    "support": ("room", "walls"),
    "containment": ("support",),
    "semantics": ("support",),
    "attributes": ("manager",),
    "constraints": ("support", "containment", "walls", "semantics"),
    "verify": ("constraints", "attributes", "containment"),
}
"""Structuring agents and their dependencies (the manager schedules all of them)."""


class Reply(BaseModel):
    text: str


class LatencyModel(Model):
    """Every request sleeps ``latency_s`` (a remote VLM's round trip) and answers at once."""

    name = "latency-sim"

    def __init__(self, latency_s: float) -> None:
        self.latency_s = latency_s

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        await asyncio.sleep(self.latency_s)
        agent = context.agent if context else "?"
        return output_type.model_validate({"text": agent}), Usage(
            requests=1, input_tokens=50, output_tokens=10
        )


def asking(model: Model, agent: str) -> NodeFn:
    async def fn(ctx: NodeContext) -> str:
        out, _ = await model.request(
            [Message.text("user", agent)], Reply, context=RequestContext(agent=agent, node=ctx.name)
        )
        return out.text

    return fn


def scene_run(model: Model, units: int, variants: int, rounds: int) -> list[Node]:
    """The initial graph: only the manager; the rest is added while it runs."""
    call_verify = asking(model, "verify")

    async def verify(ctx: NodeContext) -> str:
        reply = str(await call_verify(ctx))
        # After verification the scene tree is known: one evolution chain per unit x variant.
        tails: list[str] = []
        chain: list[Node] = []
        for unit in range(units):
            for variant in range(variants):
                previous = "verify"
                for step in range(rounds):
                    for role in ("critic", "actor"):
                        name = f"unit{unit}/v{variant}/r{step}/{role}"
                        chain.append(Node(name, asking(model, role), depends_on=(previous,)))
                        previous = name
                tails.append(previous)
        chain.append(Node("compose", _noop, depends_on=tuple(tails)))
        ctx.add_nodes(chain)
        return reply

    call_manager = asking(model, "manager")

    async def manager(ctx: NodeContext) -> str:
        reply = str(await call_manager(ctx))
        ctx.add_nodes(
            Node(name, verify if name == "verify" else asking(model, name), depends_on=deps)
            for name, deps in STRUCTURING.items()
        )
        return reply

    return [Node("manager", manager)]


async def _noop(ctx: NodeContext) -> None:
    return None


def critical_path_s(graph: TaskGraph, latency_s: float) -> float:
    """Longest path through the graph, each model-calling node costing ``latency_s``."""
    g = graph.nx_graph
    cost = {n: (0.0 if n == "compose" else latency_s) for n in g}
    finish: dict[str, float] = {}
    for n in nx.topological_sort(g):
        finish[n] = cost[n] + max((finish[p] for p in g.predecessors(n)), default=0.0)
    return max(finish.values())


async def bench_scene(latency_s: float, units: int, variants: int, rounds: int) -> dict[str, Any]:
    tracker = UsageTracker()
    model = InstrumentedModel(LatencyModel(latency_s), tracker)
    runner = Runner(scene_run(model, units, variants, rounds), usage=tracker)
    start = time.perf_counter()
    await runner.run()
    wall = time.perf_counter() - start
    critical = critical_path_s(runner.graph, latency_s)
    return {
        "nodes": len(runner.graph),
        "model_calls": tracker.total.requests,
        "wall_s": wall,
        "critical_s": critical,
        "wall_over_critical": wall / critical,
    }


def overhead_graph(total: int, chains: int = 100, chain_length: int = 20) -> TaskGraph:
    """``total`` no-op nodes: root -> (wide fan-out + chains) -> sink."""
    nodes = [Node("root", _noop)]
    tails: list[str] = []
    for c in range(chains):
        previous = "root"
        for i in range(chain_length):
            name = f"chain{c}/{i}"
            nodes.append(Node(name, _noop, depends_on=(previous,)))
            previous = name
        tails.append(previous)
    wide = total - len(nodes) - 1
    nodes.extend(Node(f"wide{i}", _noop, depends_on=("root",)) for i in range(wide))
    nodes.append(Node("sink", _noop, depends_on=(*tails, *(f"wide{i}" for i in range(wide)))))
    return TaskGraph(nodes)


async def bench_overhead(total: int) -> dict[str, float]:
    start = time.perf_counter()
    graph = overhead_graph(total)
    build = time.perf_counter() - start
    assert len(graph) == total
    start = time.perf_counter()
    out = await Runner(graph).run()
    wall = time.perf_counter() - start
    assert len(out) == total
    return {"build_s": build, "run_s": wall, "ms_per_node": wall / total * 1000}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--latency", type=float, default=0.05, help="seconds per simulated model call")
    parser.add_argument("--units", type=int, default=6)
    parser.add_argument("--variants", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3, help="critic/actor rounds (2 calls each)")
    parser.add_argument("--nodes", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=3, help="runs per measurement; the median is reported")
    args = parser.parse_args()
    # Node events are logged at debug level; an application decides what to show.
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))

    scenes = [
        asyncio.run(bench_scene(args.latency, args.units, args.variants, args.rounds))
        for _ in range(args.repeats)
    ]
    for s in scenes:
        print(
            f"scene DAG: {s['nodes']} nodes, {s['model_calls']} calls, wall {s['wall_s']:.3f} s, "
            f"critical path {s['critical_s']:.3f} s, ratio {s['wall_over_critical']:.3f}"
        )
    overheads = [asyncio.run(bench_overhead(args.nodes)) for _ in range(args.repeats)]
    for o in overheads:
        print(
            f"overhead: {args.nodes} no-op nodes, build {o['build_s']:.3f} s, run {o['run_s']:.3f} s, "
            f"{o['ms_per_node']:.4f} ms/node"
        )
    result = {
        "wall_over_critical": round(statistics.median(s["wall_over_critical"] for s in scenes), 4),
        "overhead_ms_per_node": round(statistics.median(o["ms_per_node"] for o in overheads), 4),
    }
    print(json.dumps(result))


if __name__ == "__main__":
    main()

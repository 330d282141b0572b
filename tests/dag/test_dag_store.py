"""Run stores: resume skips finished nodes, changes recompute downstream, graph changes are caught."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

from scenemosaic.dag import (
    CachePolicy,
    FileRunStore,
    GraphChangedError,
    MemoryRunStore,
    Node,
    NodeContext,
    NodeFinished,
    NodePolicy,
    Runner,
    RunStore,
)
from scenemosaic.dag._graph import NodeFn
from scenemosaic.exceptions import NodeFailedError


class RoomOutput(BaseModel):
    """A pydantic output that must round-trip through the file store."""

    walls: list[str]
    height_m: float
    label: tuple[str, int]


def counted(counter: Counter[str], value: Callable[[NodeContext], Any]) -> NodeFn:
    async def fn(ctx: NodeContext) -> Any:
        counter[ctx.name] += 1
        return value(ctx)

    return fn


def scene_graph(counter: Counter[str], *, support_version: str = "1") -> list[Node]:
    return [
        Node(
            "room",
            counted(counter, lambda c: RoomOutput(walls=["w0", "w1"], height_m=2.5, label=("r", 1))),
            version="1",
        ),
        Node("walls", counted(counter, lambda c: {"n": len(c["room"].walls)}), ("room",), version="1"),
        Node(
            "support",
            counted(counter, lambda c: [c["walls"]["n"], support_version]),
            ("walls",),
            version=support_version,
        ),
        Node("verify", counted(counter, lambda c: (c["support"], "ok")), ("support",), version="1"),
        Node("attributes", counted(counter, lambda c: {1, 2}), version="1"),
    ]


@pytest.fixture(params=["file", "memory"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> RunStore:
    return FileRunStore(tmp_path / "run") if request.param == "file" else MemoryRunStore()


async def test_resume_skips_finished_nodes(store: RunStore) -> None:
    counter: Counter[str] = Counter()
    first = await Runner(scene_graph(counter), store=store).run()
    assert counter == Counter({"room": 1, "walls": 1, "support": 1, "verify": 1, "attributes": 1})

    counter.clear()
    runner = Runner(scene_graph(counter), store=store)
    second = await runner.run()
    assert counter == Counter()  # nothing ran again
    assert second == first
    assert isinstance(second["room"], RoomOutput) and second["room"].label == ("r", 1)
    assert second["attributes"] == {1, 2} and second["verify"] == ([2, "1"], "ok")
    cached = {e.node for e in runner.history if isinstance(e, NodeFinished) and e.cached}
    assert cached == set(first) and sorted(runner.cached) == sorted(first)


async def test_resume_after_failure_runs_only_what_is_left(store: RunStore) -> None:
    counter: Counter[str] = Counter()
    nodes = scene_graph(counter)

    async def broken(ctx: NodeContext) -> None:
        raise RuntimeError("crash")

    crashing = [*nodes[:3], Node("verify", broken, ("support",), version="1"), nodes[4]]
    with pytest.raises(NodeFailedError) as info:
        await Runner(crashing, store=store).run()
    assert set(info.value.partial) == {"room", "walls", "support", "attributes"}

    counter.clear()
    out = await Runner(scene_graph(counter), store=store).run()
    assert counter == Counter({"verify": 1})
    assert out["verify"] == ([2, "1"], "ok")


async def test_changed_graph_is_detected(store: RunStore) -> None:
    counter: Counter[str] = Counter()
    await Runner(scene_graph(counter), store=store).run()
    with pytest.raises(GraphChangedError, match="node 'support' definition changed") as info:
        await Runner(scene_graph(counter, support_version="2"), store=store).run()
    assert info.value.differences == ["node 'support' definition changed ('1' -> '2')"]

    extra = [*scene_graph(counter), Node("semantics", counted(counter, lambda c: 0), ("room",))]
    with pytest.raises(GraphChangedError, match="node 'semantics' added"):
        await Runner(extra, store=store).run()


async def test_recompute_runs_a_changed_node_and_everything_downstream(store: RunStore) -> None:
    counter: Counter[str] = Counter()
    await Runner(scene_graph(counter), store=store).run()
    counter.clear()
    out = await Runner(
        scene_graph(counter, support_version="2"), store=store, on_graph_change="recompute"
    ).run()
    assert counter == Counter({"support": 1, "verify": 1})
    assert out["verify"] == ([2, "2"], "ok")
    # The new definition is now the stored one: running it again computes nothing.
    counter.clear()
    await Runner(scene_graph(counter, support_version="2"), store=store).run()
    assert counter == Counter()


async def test_resume_false_starts_over(store: RunStore) -> None:
    counter: Counter[str] = Counter()
    await Runner(scene_graph(counter), store=store).run()
    counter.clear()
    await Runner(scene_graph(counter, support_version="2"), store=store, resume=False).run()
    assert sum(counter.values()) == 5


async def test_a_changed_upstream_output_recomputes_only_its_dependents(store: RunStore) -> None:
    """``key_fn`` brings an outside input into the hash; a new value reruns the node, and its
    dependents run again only because its output changed."""
    counter: Counter[str] = Counter()
    setting = {"ceiling": 2.5}

    def graph() -> list[Node]:
        return [
            Node(
                "room",
                counted(counter, lambda c: {"height": setting["ceiling"]}),
                version="1",
                policy=NodePolicy(cache=CachePolicy(key_fn=lambda inputs: str(setting["ceiling"]))),
            ),
            Node("lights", counted(counter, lambda c: c["room"]["height"] - 0.3), ("room",), version="1"),
            Node("walls", counted(counter, lambda c: "w"), version="1"),
        ]

    await Runner(graph(), store=store).run()
    counter.clear()
    setting["ceiling"] = 3.0
    out = await Runner(graph(), store=store).run()
    assert counter == Counter({"room": 1, "lights": 1})
    assert out["lights"] == pytest.approx(2.7)


async def test_config_key_separates_runs(store: RunStore) -> None:
    counter: Counter[str] = Counter()
    await Runner(scene_graph(counter), store=store, config_key="scene-a").run()
    counter.clear()
    await Runner(scene_graph(counter), store=store, config_key="scene-b").run()
    assert sum(counter.values()) == 5


async def test_cached_nodes_restore_side_effects(store: RunStore) -> None:
    state: dict[str, Any] = {}

    async def write(ctx: NodeContext) -> int:
        state["written"] = 42
        return 42

    async def restore(output: Any) -> None:
        state["written"] = output

    def graph() -> list[Node]:
        return [Node("writer", write, version="1", restore=restore)]

    await Runner(graph(), store=store).run()
    state.clear()
    runner = Runner(graph(), store=store)
    await runner.run()
    assert runner.cached == ["writer"] and state == {"written": 42}


async def test_nodes_that_add_nodes_rerun_and_their_children_are_cached(store: RunStore) -> None:
    counter: Counter[str] = Counter()

    async def manager(ctx: NodeContext) -> str:
        counter["manager"] += 1
        ctx.add_node(Node("child", counted(counter, lambda c: c["manager"] + "!"), ("manager",), version="1"))
        return "m"

    await Runner([Node("manager", manager, version="1")], store=store).run()
    counter.clear()
    out = await Runner([Node("manager", manager, version="1")], store=store).run()
    assert counter == Counter({"manager": 1})
    assert out == {"manager": "m", "child": "m!"}


async def test_file_store_layout_is_json(tmp_path: Path) -> None:
    counter: Counter[str] = Counter()
    store = FileRunStore(tmp_path / "run")
    await Runner(scene_graph(counter), store=store).run()
    fingerprint = json.loads((tmp_path / "run" / "graph.json").read_text())
    assert set(fingerprint["nodes"]) == {"room", "walls", "support", "verify", "attributes"}
    (room_file,) = (tmp_path / "run" / "nodes" / "room").glob("*.json")
    record = json.loads(room_file.read_text())
    assert record["kind"] == "pydantic" and record["type"].endswith(":RoomOutput")
    assert record["value"] == {"walls": ["w0", "w1"], "height_m": 2.5, "label": ["r", 1]}
    (verify_file,) = (tmp_path / "run" / "nodes" / "verify").glob("*.json")
    assert json.loads(verify_file.read_text())["kind"] == "pickle"  # a tuple does not survive JSON
    (walls_file,) = (tmp_path / "run" / "nodes" / "walls").glob("*.json")
    assert json.loads(walls_file.read_text())["kind"] == "json"

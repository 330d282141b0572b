"""Graph definition: validation errors name what is wrong; fingerprints see changes."""

from __future__ import annotations

import pytest

from scenemosaic.dag import Node, NodeContext, TaskGraph
from scenemosaic.exceptions import GraphDefinitionError


async def noop(ctx: NodeContext) -> None:
    return None


def test_cycle_is_rejected_with_its_path() -> None:
    with pytest.raises(GraphDefinitionError, match="cycle") as info:
        TaskGraph(
            [
                Node("start", noop),
                Node("a", noop, depends_on=("start", "c")),
                Node("b", noop, depends_on=("a",)),
                Node("c", noop, depends_on=("b",)),
            ]
        )
    message = str(info.value)
    path = message.split("cycle: ", 1)[1].split(" -> ")
    assert path[0] == path[-1]
    assert set(path) == {"a", "b", "c"}
    assert "start" not in path


def test_self_dependency_is_a_cycle() -> None:
    with pytest.raises(GraphDefinitionError, match=r"cycle: solo -> solo"):
        Node("solo", noop, depends_on=("solo",))


def test_missing_dependency_names_it_and_who_needs_it() -> None:
    with pytest.raises(GraphDefinitionError, match=r"'ghost' \(needed by 'support'\)"):
        TaskGraph([Node("room", noop), Node("support", noop, depends_on=("room", "ghost"))])


def test_duplicate_name_is_rejected() -> None:
    with pytest.raises(GraphDefinitionError, match="duplicate node name 'room'"):
        TaskGraph([Node("room", noop), Node("walls", noop), Node("room", noop)])
    graph = TaskGraph([Node("room", noop)])
    with pytest.raises(GraphDefinitionError, match="duplicate node name 'room'"):
        graph.add_node(Node("room", noop))


def test_failed_batch_adds_nothing_and_order_does_not_matter() -> None:
    graph = TaskGraph([Node("b", noop, depends_on=("a",)), Node("a", noop)])
    assert graph.topological_order() == ["a", "b"]
    with pytest.raises(GraphDefinitionError):
        graph.add_nodes([Node("c", noop, depends_on=("b",)), Node("d", noop, depends_on=("nope",))])
    assert "c" not in graph and len(graph) == 2


def test_fingerprint_changes_with_versions_and_edges() -> None:
    base = TaskGraph([Node("a", noop, version="1"), Node("b", noop, depends_on=("a",), version="1")])
    same = TaskGraph([Node("a", noop, version="1"), Node("b", noop, depends_on=("a",), version="1")])
    bumped = TaskGraph([Node("a", noop, version="2"), Node("b", noop, depends_on=("a",), version="1")])
    rewired = TaskGraph([Node("a", noop, version="1"), Node("b", noop, version="1")])
    fp = base.fingerprint()
    assert fp.digest == same.fingerprint().digest
    assert fp.digest != bumped.fingerprint().digest
    assert fp.digest != rewired.fingerprint().digest
    assert fp.differences(bumped.fingerprint()) == ["node 'a' definition changed ('1' -> '2')"]
    assert fp.differences(rewired.fingerprint()) == ["node 'b' dependencies changed (['a'] -> [])"]


def test_default_definition_key_is_the_function_path() -> None:
    assert Node("a", noop).definition_key == f"{__name__}:noop"

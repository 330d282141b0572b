"""Task-graph definition: :class:`Node` and :class:`TaskGraph` (a validated networkx DAG)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Awaitable, Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import networkx as nx

from scenemosaic.dag._policies import NodePolicy
from scenemosaic.exceptions import GraphDefinitionError

if TYPE_CHECKING:
    from scenemosaic.dag._context import NodeContext

__all__ = ["GraphFingerprint", "Node", "NodeFn", "TaskGraph"]

NodeFn = Callable[["NodeContext"], Awaitable[Any]]
"""A node's work: an async callable taking the node's :class:`NodeContext`, returning its output."""


@dataclass(frozen=True, slots=True)
class Node:
    """One unit of work in a task graph.

    ``fn`` is awaited with a :class:`~scenemosaic.dag.NodeContext` once every name in
    ``depends_on`` has finished; its return value is the node's output.
    """

    name: str
    """Unique name in the graph."""
    fn: NodeFn
    """The async callable doing the work."""
    depends_on: tuple[str, ...] = ()
    """Names of the nodes whose outputs this one needs."""
    policy: NodePolicy = field(default_factory=NodePolicy)
    """Retry / timeout / cache policies; unset fields use the run's defaults."""
    version: str | None = None
    """Definition key of the node, part of its input hash and of the graph fingerprint.
    Bump it when the node's behaviour changes so stored outputs are not reused.
    ``None`` uses the function's ``module:qualname``."""
    restore: Callable[[Any], Awaitable[None]] | None = None
    """Called with the stored output when the node is skipped because the run store holds
    its output, so side effects of the original run (e.g. writing into shared state) are redone."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise GraphDefinitionError(f"node name must be a non-empty string, got {self.name!r}")
        if isinstance(self.depends_on, str):  # a bare string would be read as its characters
            object.__setattr__(self, "depends_on", (self.depends_on,))
        else:
            object.__setattr__(self, "depends_on", tuple(self.depends_on))
        if len(set(self.depends_on)) != len(self.depends_on):
            raise GraphDefinitionError(
                f"node {self.name!r} lists a dependency twice: {list(self.depends_on)}"
            )
        if self.name in self.depends_on:
            raise GraphDefinitionError(
                f"node {self.name!r} depends on itself (cycle: {self.name} -> {self.name})"
            )

    @property
    def definition_key(self) -> str:
        """``version`` if set, else the function's ``module:qualname``."""
        if self.version is not None:
            return self.version
        module = getattr(self.fn, "__module__", None) or "?"
        qualname = getattr(self.fn, "__qualname__", None) or type(self.fn).__qualname__
        return f"{module}:{qualname}"


@dataclass(frozen=True)
class GraphFingerprint:
    """What identifies a graph definition: node names, their definition keys, their edges."""

    nodes: dict[str, tuple[str, tuple[str, ...]]]
    """Node name -> (definition key, sorted dependency names)."""

    @property
    def digest(self) -> str:
        """SHA-256 of the canonical JSON of :attr:`nodes`."""
        payload = json.dumps({k: [v, list(d)] for k, (v, d) in sorted(self.nodes.items())}, sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()

    def to_json(self) -> dict[str, Any]:
        """JSON-ready form (what a file store writes)."""
        return {"digest": self.digest, "nodes": {k: [v, list(d)] for k, (v, d) in sorted(self.nodes.items())}}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> GraphFingerprint:
        """Inverse of :meth:`to_json`."""
        return cls({k: (str(v[0]), tuple(v[1])) for k, v in data["nodes"].items()})

    def differences(self, new: GraphFingerprint) -> list[str]:
        """Human-readable list of what changed from ``self`` (stored) to ``new``."""
        out: list[str] = []
        for name in sorted(new.nodes.keys() - self.nodes.keys()):
            out.append(f"node {name!r} added")
        for name in sorted(self.nodes.keys() - new.nodes.keys()):
            out.append(f"node {name!r} removed")
        for name in sorted(self.nodes.keys() & new.nodes.keys()):
            (old_v, old_d), (new_v, new_d) = self.nodes[name], new.nodes[name]
            if old_v != new_v:
                out.append(f"node {name!r} definition changed ({old_v!r} -> {new_v!r})")
            if old_d != new_d:
                out.append(f"node {name!r} dependencies changed ({list(old_d)} -> {list(new_d)})")
        return out


class TaskGraph:
    """A validated DAG of :class:`Node` s, stored in a :class:`networkx.DiGraph`.

    Edges point from a dependency to its dependent. Construction (and :meth:`add_nodes`)
    rejects duplicate names, dependencies on unknown nodes and cycles with a
    :class:`~scenemosaic.exceptions.GraphDefinitionError` naming them.
    """

    def __init__(self, nodes: Iterable[Node] = ()) -> None:
        self._nx: nx.DiGraph[str] = nx.DiGraph()
        self._nodes: dict[str, Node] = {}
        self.add_nodes(nodes)

    # -- building ------------------------------------------------------------------------------
    def add_node(self, node: Node) -> None:
        """Add one node; its dependencies must already be in the graph."""
        self.add_nodes((node,))

    def add_nodes(self, nodes: Iterable[Node]) -> None:
        """Add several nodes at once; they may depend on each other and on existing nodes.

        Either all are added or, on a :class:`~scenemosaic.exceptions.GraphDefinitionError`, none.
        """
        batch = list(nodes)
        names: dict[str, Node] = {}
        for node in batch:
            if not isinstance(node, Node):
                raise GraphDefinitionError(f"expected a Node, got {type(node).__name__}: {node!r}")
            if node.name in self._nodes or node.name in names:
                raise GraphDefinitionError(f"duplicate node name {node.name!r}")
            names[node.name] = node
        missing = [
            f"{dep!r} (needed by {node.name!r})"
            for node in batch
            for dep in node.depends_on
            if dep not in self._nodes and dep not in names
        ]
        if missing:
            raise GraphDefinitionError("missing dependency: " + ", ".join(missing))
        # Existing nodes never depend on new ones, so a cycle can only run through the batch.
        sub: nx.DiGraph[str] = nx.DiGraph()
        sub.add_nodes_from(names)
        sub.add_edges_from((dep, n.name) for n in batch for dep in n.depends_on if dep in names)
        try:
            cycle = nx.find_cycle(sub)
        except nx.NetworkXNoCycle:
            cycle = None
        if cycle:
            path = [edge[0] for edge in cycle] + [cycle[0][0]]
            raise GraphDefinitionError("dependency cycle: " + " -> ".join(path))
        self._nx.add_nodes_from(names)
        self._nx.add_edges_from((dep, n.name) for n in batch for dep in n.depends_on)
        self._nodes.update(names)

    def copy(self) -> TaskGraph:
        """A shallow copy (same Node objects, new graph), so a run can grow it privately."""
        new = TaskGraph.__new__(TaskGraph)
        new._nx = self._nx.copy()
        new._nodes = dict(self._nodes)
        return new

    # -- reading -------------------------------------------------------------------------------
    def __contains__(self, name: object) -> bool:
        return name in self._nodes

    def __len__(self) -> int:
        return len(self._nodes)

    def __iter__(self) -> Iterator[Node]:
        return iter(self._nodes.values())

    def __getitem__(self, name: str) -> Node:
        return self._nodes[name]

    @property
    def nx_graph(self) -> nx.DiGraph[str]:
        """The underlying networkx graph (edges dependency -> dependent). Do not mutate."""
        return self._nx

    def dependents(self, name: str) -> Iterator[str]:
        """Names of nodes that depend directly on ``name``."""
        return iter(self._nx.successors(name))

    def topological_order(self) -> list[str]:
        """Node names, every dependency before its dependents."""
        return list(nx.topological_sort(self._nx))

    def fingerprint(self) -> GraphFingerprint:
        """The definition fingerprint (names, definition keys, edges)."""
        return GraphFingerprint({n.name: (n.definition_key, tuple(sorted(n.depends_on))) for n in self})

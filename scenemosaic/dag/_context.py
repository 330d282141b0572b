"""What a running node sees: :class:`NodeContext`, reachable also through :func:`current_context`."""

from __future__ import annotations

import asyncio
import contextvars
import functools
import hashlib
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import Executor
from typing import TYPE_CHECKING, Any, ParamSpec, Protocol, TypeVar

from scenemosaic.dag._events import RunEvent

if TYPE_CHECKING:
    from scenemosaic.dag._graph import Node

__all__ = ["NodeContext", "current_context", "derive_seed"]

P = ParamSpec("P")
R = TypeVar("R")

_CURRENT: contextvars.ContextVar[NodeContext] = contextvars.ContextVar("scenemosaic_node_context")


def derive_seed(run_seed: int, name: str) -> int:
    """A 63-bit seed for ``name`` derived from the run seed (stable across processes)."""
    digest = hashlib.sha256(f"{run_seed}\x00{name}".encode()).digest()
    return int.from_bytes(digest[:8], "big") >> 1


def current_context() -> NodeContext:
    """The :class:`NodeContext` of the node running in the current task.

    Lets code that cannot take a context argument (e.g. a manager agent's ``run``) add
    nodes or emit events. Raises ``LookupError`` outside a node.
    """
    return _CURRENT.get()


class _RunHooks(Protocol):
    def _add_nodes(self, nodes: list[Node], added_by: str) -> None: ...

    def _emit(self, event: RunEvent) -> None: ...

    def _process_pool(self) -> Executor: ...


class NodeContext:
    """Everything a node function receives.

    ``inputs`` maps each dependency's name to its output (``ctx["room"]`` is a shortcut).
    """

    __slots__ = ("_hooks", "attempt", "inputs", "name", "node_seed", "run_seed")

    def __init__(
        self, hooks: _RunHooks, name: str, inputs: Mapping[str, Any], run_seed: int, attempt: int = 1
    ) -> None:
        self._hooks = hooks
        self.name = name
        """This node's name."""
        self.inputs = inputs
        """Outputs of the node's dependencies, by node name."""
        self.run_seed = run_seed
        """The run's seed."""
        self.node_seed = derive_seed(run_seed, name)
        """A seed for this node's random choices, derived from the run seed and the node name."""
        self.attempt = attempt
        """1 on the first try, 2 on the first retry, ..."""

    def __getitem__(self, dependency: str) -> Any:
        return self.inputs[dependency]

    def add_node(self, node: Node) -> None:
        """Add a node to the running graph; it is validated and scheduled at once.

        Its dependencies may be any existing node, including this one (it then starts
        after this node returns).
        """
        self._hooks._add_nodes([node], self.name)

    def add_nodes(self, nodes: Iterable[Node]) -> None:
        """Add several nodes at once; they may depend on each other."""
        self._hooks._add_nodes(list(nodes), self.name)

    def emit(self, event: RunEvent) -> None:
        """Send an event to the run's event stream."""
        self._hooks._emit(event)

    async def run_in_thread(self, fn: Callable[P, R], *args: P.args, **kwargs: P.kwargs) -> R:
        """Run blocking ``fn`` in a worker thread (I/O, or CPU work that releases the GIL).

        If the run is cancelled the await ends at once; the thread itself runs to its end.
        """
        return await asyncio.to_thread(fn, *args, **kwargs)

    async def run_in_process(self, fn: Callable[P, R], *args: P.args, **kwargs: P.kwargs) -> R:
        """Run CPU-bound ``fn`` in the run's process pool; ``fn`` and its arguments must pickle."""
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self._hooks._process_pool(), functools.partial(fn, *args, **kwargs))

    def __repr__(self) -> str:
        return f"NodeContext(name={self.name!r}, inputs={sorted(self.inputs)!r}, attempt={self.attempt})"


def _set_current(ctx: NodeContext) -> contextvars.Token[NodeContext]:
    return _CURRENT.set(ctx)

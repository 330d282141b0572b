"""Task graphs and their async scheduler.

Build a :class:`TaskGraph` of :class:`Node` s (async functions taking a :class:`NodeContext`),
then run it with :class:`Runner` / :func:`run_graph`: every node starts as soon as its
dependencies finish, under per-node :class:`RetryPolicy`, :class:`TimeoutPolicy` and
:class:`CachePolicy`. A :class:`RunStore` (:class:`FileRunStore`, :class:`MemoryRunStore`)
lets a run resume; typed events (:class:`NodeStarted`, :class:`NodeFinished`, ...) are
streamed and logged; a :class:`RunMonitor` (the models layer's ``UsageTracker``) may join a
run to emit events and stop it at a limit. The scheduler knows nothing about models or scenes.
See ``docs/runtime.md``.
"""

from scenemosaic.dag._context import NodeContext, current_context, derive_seed
from scenemosaic.dag._events import (
    EventListener,
    ModelRequest,
    NodeAdded,
    NodeFailed,
    NodeFinished,
    NodeRetried,
    NodeStarted,
    RunEvent,
    RunFinished,
)
from scenemosaic.dag._graph import GraphFingerprint, Node, NodeFn, TaskGraph
from scenemosaic.dag._monitor import ModelCallReport, RunMonitor
from scenemosaic.dag._policies import CachePolicy, NodePolicy, RetryPolicy, TimeoutPolicy
from scenemosaic.dag._runner import Runner, run_graph
from scenemosaic.dag._store import (
    FileRunStore,
    GraphChangedError,
    MemoryRunStore,
    RunStore,
    StoredOutput,
    output_hash,
)

__all__ = [
    "CachePolicy",
    "EventListener",
    "FileRunStore",
    "GraphChangedError",
    "GraphFingerprint",
    "MemoryRunStore",
    "ModelCallReport",
    "ModelRequest",
    "Node",
    "NodeAdded",
    "NodeContext",
    "NodeFailed",
    "NodeFinished",
    "NodeFn",
    "NodePolicy",
    "NodeRetried",
    "NodeStarted",
    "RetryPolicy",
    "RunEvent",
    "RunFinished",
    "RunMonitor",
    "RunStore",
    "Runner",
    "StoredOutput",
    "TaskGraph",
    "TimeoutPolicy",
    "current_context",
    "derive_seed",
    "output_hash",
    "run_graph",
]

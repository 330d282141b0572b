"""The async scheduler: :class:`Runner` and :func:`run_graph`.

Every node starts as soon as its last dependency finishes (bounded by ``max_concurrency``),
inside one ``asyncio.TaskGroup``: when the run ends, for whatever reason, no node task is
left behind. Bookkeeping is O(1) per node plus O(degree) per finished node, so scheduling
overhead does not grow with the graph.
"""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import random
import time
import uuid
from collections import deque
from collections.abc import AsyncIterator, Iterable
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, Literal

import structlog

from scenemosaic.dag._context import _CURRENT, NodeContext
from scenemosaic.dag._events import (
    EventListener,
    EventStream,
    ModelRequest,
    NodeAdded,
    NodeFailed,
    NodeFinished,
    NodeRetried,
    NodeStarted,
    RunEvent,
    RunFinished,
)
from scenemosaic.dag._graph import Node, TaskGraph
from scenemosaic.dag._monitor import RunMonitor
from scenemosaic.dag._policies import (
    DEFAULT_CACHE,
    DEFAULT_RETRY,
    DEFAULT_TIMEOUT,
    CachePolicy,
    NodePolicy,
    RetryPolicy,
)
from scenemosaic.dag._store import RunStore, StoredOutput, input_hash
from scenemosaic.exceptions import (
    GraphChangedError,
    NodeFailedError,
    NodeTimeoutError,
    RunCancelledError,
    UsageError,
    UsageLimitExceeded,
)

__all__ = ["Runner", "run_graph"]

_log = structlog.get_logger(__name__)

_NEVER_RETRY = (UsageLimitExceeded, UsageError)
"""Errors another attempt cannot fix: a spent budget, a programming or configuration mistake."""


class Runner:
    """Runs a :class:`TaskGraph` once.

    Usage::

        runner = Runner(graph, max_concurrency=8, store=FileRunStore("runs/a"))
        task = asyncio.create_task(runner.run())
        async for event in runner.events():
            ...
        outputs = await task

    ``run()`` returns every node's output by name. It raises

    * :class:`~scenemosaic.exceptions.NodeFailedError` when a node fails after its retries
      (:class:`~scenemosaic.exceptions.NodeTimeoutError` when its last attempt timed out);
    * :class:`~scenemosaic.exceptions.RunCancelledError` when the task running ``run()`` is
      cancelled, :meth:`cancel` is called or ``cancel_event`` is set;
    * :class:`~scenemosaic.exceptions.UsageLimitExceeded` when the usage tracker's limits stop it;
    * :class:`~scenemosaic.dag.GraphChangedError` when the store belongs to another graph definition.

    Each of these run errors carries ``partial``: the outputs of every node that finished.
    Converting a cancellation into ``RunCancelledError`` is deliberate, so the partial results
    reach the caller; it means ``run()`` should not be wrapped in ``asyncio.timeout`` (set a
    cancel event or node timeouts instead).
    """

    def __init__(
        self,
        graph: TaskGraph | Iterable[Node],
        *,
        max_concurrency: int | None = None,
        defaults: NodePolicy | None = None,
        store: RunStore | None = None,
        resume: bool = True,
        on_graph_change: Literal["error", "recompute"] = "error",
        config_key: str = "",
        seed: int = 0,
        usage: RunMonitor | None = None,
        listeners: Iterable[EventListener] = (),
        cancel_event: asyncio.Event | None = None,
        process_pool: Executor | None = None,
    ) -> None:
        """Prepare a run.

        Args:
            graph: the graph (copied; nodes added at run time go into the copy, :attr:`graph`).
            max_concurrency: most nodes running at once; ``None`` for no bound.
            defaults: graph-wide policies for the fields a node's policy leaves ``None``.
            store: where outputs are kept for resuming; ``None`` keeps nothing.
            resume: reuse outputs in ``store``; ``False`` clears the store first.
            on_graph_change: what to do when ``store`` was written by another graph definition:
                ``"error"`` raises :class:`~scenemosaic.dag.GraphChangedError`; ``"recompute"``
                accepts the new definition and reuses only outputs whose input hash still matches
                (changed nodes and everything downstream of them run again).
            config_key: the run's configuration key (e.g. a hash of the input scene and model
                settings); part of every input hash.
            seed: run seed; each node gets ``derive_seed(seed, name)``.
            usage: a run monitor (e.g. the models layer's ``UsageTracker``) bound to this run while it
                runs: it may emit events (``ModelRequest``) and stop the run when a limit is crossed.
            listeners: callbacks receiving every event.
            cancel_event: setting it cancels the run.
            process_pool: executor for ``ctx.run_in_process``; default: a spawn-based process
                pool created on first use and shut down when the run ends.
        """
        if max_concurrency is not None and max_concurrency < 1:
            raise UsageError(f"max_concurrency must be >= 1 or None, got {max_concurrency}")
        self._graph = graph.copy() if isinstance(graph, TaskGraph) else TaskGraph(graph)
        self._limit = max_concurrency
        base = defaults or NodePolicy()
        self._default_retry: RetryPolicy = base.retry or DEFAULT_RETRY
        self._default_timeout_s = (base.timeout or DEFAULT_TIMEOUT).timeout_s
        self._default_cache: CachePolicy = base.cache or DEFAULT_CACHE
        self._store = store
        self._resume = resume
        self._on_graph_change = on_graph_change
        self._config_key = config_key
        self._seed = seed
        self._usage = usage
        self._cancel_event = cancel_event
        self._pool = process_pool
        self._own_pool: ProcessPoolExecutor | None = None
        self._stream = EventStream(tuple(listeners))

        self._outputs: dict[str, Any] = {}
        self._hashes: dict[str, str] = {}
        self._remaining: dict[str, int] = {}
        self._ready: deque[str] = deque()
        self._running = 0
        self._added_by: dict[str, list[str]] = {}
        self._failure: BaseException | None = None
        self._tg: asyncio.TaskGroup | None = None
        self._task: asyncio.Task[Any] | None = None
        self._done: asyncio.Event | None = None
        self._started = False
        self._finished = False
        self._cancel_requested = False
        self.executed: list[str] = []
        """Names of nodes whose function ran to completion, in finishing order."""
        self.cached: list[str] = []
        """Names of nodes whose output came from the store."""

    # -- public ------------------------------------------------------------------------------
    @property
    def graph(self) -> TaskGraph:
        """The run's graph, including nodes added while it runs."""
        return self._graph

    @property
    def outputs(self) -> dict[str, Any]:
        """Outputs of the nodes finished so far (a copy)."""
        return dict(self._outputs)

    @property
    def history(self) -> list[RunEvent]:
        """Every event emitted so far."""
        return self._stream.history

    def events(self) -> AsyncIterator[RunEvent]:
        """Iterate over the run's events, from its first; ends after :class:`~scenemosaic.dag.RunFinished`."""
        return self._stream.__aiter__()

    def cancel(self) -> None:
        """Cancel the run: running nodes are cancelled and ``run()`` raises ``RunCancelledError``."""
        self._cancel_requested = True
        if self._task is not None and not self._finished:
            self._task.cancel()

    async def run(self) -> dict[str, Any]:
        """Run the graph to the end and return every node's output by name."""
        if self._started:
            raise UsageError("a Runner runs once; make a new Runner to run the graph again")
        self._started = True
        self._task = asyncio.current_task()
        self._done = asyncio.Event()
        start = time.perf_counter()
        error: BaseException | None = None
        if self._usage is not None:
            self._usage.bind(self._report_model_call, self._stop_for_usage)
        try:
            self._prepare_store()
            if self._cancel_requested:
                raise asyncio.CancelledError
            for node in self._graph:
                count = len(node.depends_on)
                self._remaining[node.name] = count
                if count == 0:
                    self._ready.append(node.name)
            async with asyncio.TaskGroup() as tg:
                self._tg = tg
                watcher = tg.create_task(self._watch(self._cancel_event)) if self._cancel_event else None
                if len(self._graph) == 0:
                    self._done.set()
                self._pump()
                await self._done.wait()
                if watcher is not None:
                    watcher.cancel()
        except asyncio.CancelledError:
            if isinstance(self._failure, UsageLimitExceeded):
                error = UsageLimitExceeded(str(self._failure), partial=self._outputs)
                error.__cause__ = self._failure
            else:
                error = RunCancelledError(
                    f"run cancelled with {len(self._outputs)} of {len(self._graph)} nodes finished",
                    partial=self._outputs,
                )
        except BaseExceptionGroup as group:
            error = self._translate(group)
        except GraphChangedError as exc:
            error = exc
        finally:
            self._tg = None
            self._finished = True
            if self._usage is not None:
                self._usage.bind(None)
            await self._close_pool(wait=error is None)
        self._emit(
            RunFinished(
                ok=error is None,
                duration_s=time.perf_counter() - start,
                executed=len(self.executed),
                cached=len(self.cached),
                error=_describe(error) if error is not None else None,
            )
        )
        if error is not None:
            raise error
        return dict(self._outputs)

    # -- hooks used by NodeContext -------------------------------------------------------------
    def _emit(self, event: RunEvent) -> None:
        self._stream.emit(event)

    def _report_model_call(self, call: Any) -> None:
        """A bound monitor's model call (see :data:`~scenemosaic.dag.ModelCallReport`), as an event."""
        usage = call.usage
        self._emit(
            ModelRequest(
                agent=call.agent,
                node=call.node,
                model=call.model,
                input_tokens=usage.input_tokens,
                output_tokens=usage.output_tokens,
                image_tokens=usage.image_tokens,
                latency_s=call.latency_s,
                ok=call.ok,
                cost=call.cost,
            )
        )

    def _add_nodes(self, nodes: list[Node], added_by: str) -> None:
        if self._tg is None or self._finished:
            raise UsageError("nodes can only be added while the run is active")
        self._graph.add_nodes(nodes)
        outputs = self._outputs
        for node in nodes:
            count = sum(1 for dep in node.depends_on if dep not in outputs)
            self._remaining[node.name] = count
            self._emit(NodeAdded(node=node.name, added_by=added_by, depends_on=node.depends_on))
            if count == 0:
                self._ready.append(node.name)
        self._added_by.setdefault(added_by, []).extend(n.name for n in nodes)
        self._pump()

    def _process_pool(self) -> Executor:
        if self._pool is not None:
            return self._pool
        if self._own_pool is None:
            workers = max(1, min(4, os.cpu_count() or 1))
            self._own_pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
        return self._own_pool

    # -- scheduling ----------------------------------------------------------------------------
    def _pump(self) -> None:
        """Start ready nodes while there is room under ``max_concurrency``."""
        tg = self._tg
        if tg is None:
            return
        ready, limit = self._ready, self._limit
        while ready and (limit is None or self._running < limit):
            name = ready.popleft()
            coro = self._node_task(name)
            try:
                tg.create_task(coro, name=name)
            except RuntimeError:  # the group is shutting down: a failure or a cancel is under way
                coro.close()
                return
            self._running += 1

    async def _node_task(self, name: str) -> None:
        node = self._graph[name]
        outputs = self._outputs
        try:
            output = await self._execute(node, {dep: outputs[dep] for dep in node.depends_on})
        except asyncio.CancelledError as exc:
            task = asyncio.current_task()
            if task is not None and task.cancelling() == 0:
                # Nobody cancelled this task: the node's own code let a CancelledError out.
                # Treat it as a failure, or the run would wait forever for this node.
                failure = NodeFailedError(name, exc)
                if self._failure is None:
                    self._failure = failure
                raise failure from exc
            raise
        except BaseException as exc:
            if self._failure is None:
                self._failure = exc
            raise
        finally:
            self._running -= 1
        outputs[name] = output
        remaining, ready = self._remaining, self._ready
        for dependent in self._graph.dependents(name):
            left = remaining[dependent] - 1
            remaining[dependent] = left
            if left == 0:
                ready.append(dependent)
        if len(outputs) == len(self._graph):
            assert self._done is not None
            self._done.set()
        else:
            self._pump()

    async def _execute(self, node: Node, inputs: dict[str, Any]) -> Any:
        """Output of ``node``: from the store when its input hash is there, else by running it."""
        name, policy, store = node.name, node.policy, self._store
        start = time.perf_counter()
        key: str | None = None
        if store is not None:
            cache = policy.cache or self._default_cache
            if cache.enabled:
                extra = cache.key_fn(inputs) if cache.key_fn is not None else ""
                deps = {dep: self._hashes[dep] for dep in node.depends_on}
                key = input_hash(name, node.definition_key, deps, self._config_key, extra)
                record = store.get(name, key) if self._resume else None
                # A node that added nodes must run again: only its function can rebuild them.
                if record is not None and not record.added_nodes:
                    if node.restore is not None:
                        try:
                            await node.restore(record.output)
                        except Exception as exc:
                            self._emit(NodeFailed(node=name, attempts=0, error=_describe(exc)))
                            raise NodeFailedError(name, exc) from exc
                    self._hashes[name] = record.output_hash
                    self.cached.append(name)
                    self._emit(NodeFinished(node=name, duration_s=time.perf_counter() - start, cached=True))
                    return record.output
        output = await self._attempt_all(node, inputs)
        if store is not None:
            try:
                stored = StoredOutput.of(output, tuple(self._added_by.get(name, ())))
            except Exception as exc:  # e.g. an output that cannot be pickled
                _log.warning("node_output_not_storable", node=name, error=_describe(exc))
                self._hashes[name] = "unstorable-" + uuid.uuid4().hex
            else:
                self._hashes[name] = stored.output_hash
                if key is not None:
                    store.put(name, key, stored)
        self.executed.append(name)
        self._emit(NodeFinished(node=name, duration_s=time.perf_counter() - start, cached=False))
        return output

    async def _attempt_all(self, node: Node, inputs: dict[str, Any]) -> Any:
        """Await the node's function under its timeout, retrying as its policy says."""
        name, policy = node.name, node.policy
        retry = policy.retry or self._default_retry
        timeout_s = policy.timeout.timeout_s if policy.timeout is not None else self._default_timeout_s
        rng: random.Random | None = None
        attempt = 1
        while True:
            ctx = NodeContext(self, name, inputs, self._seed, attempt)
            self._emit(NodeStarted(node=name, attempt=attempt))
            token = _CURRENT.set(ctx)
            try:
                if timeout_s is None:
                    return await node.fn(ctx)
                return await _with_timeout(node, ctx, timeout_s)
            except Exception as exc:
                retryable = isinstance(exc, retry.retry_on) and not isinstance(exc, _NEVER_RETRY)
                if attempt < retry.attempts and retryable:
                    rng = rng or random.Random(ctx.node_seed)
                    delay = retry.delay_s(attempt, rng)
                    self._emit(NodeRetried(node=name, attempt=attempt, error=_describe(exc), delay_s=delay))
                    await asyncio.sleep(delay)
                    attempt += 1
                    continue
                self._emit(NodeFailed(node=name, attempts=attempt, error=_describe(exc)))
                if isinstance(exc, NodeTimeoutError | UsageLimitExceeded):
                    raise
                raise NodeFailedError(name, exc) from exc
            finally:
                _CURRENT.reset(token)

    # -- run edges -----------------------------------------------------------------------------
    def _prepare_store(self) -> None:
        store = self._store
        if store is None:
            return
        fingerprint = self._graph.fingerprint()
        if not self._resume:
            store.clear()
        else:
            old = store.get_fingerprint()
            if old is not None and old.digest != fingerprint.digest and self._on_graph_change == "error":
                changes = old.differences(fingerprint)
                raise GraphChangedError(
                    "the run store holds outputs of a different graph definition: "
                    + "; ".join(changes)
                    + ". Pass on_graph_change='recompute' to reuse what still matches, "
                    "resume=False to start over, or use a fresh store.",
                    differences=changes,
                )
        store.set_fingerprint(fingerprint)

    def _stop_for_usage(self, exc: UsageLimitExceeded) -> None:
        """The usage tracker's limit was crossed: stop the run (``run()`` raises ``UsageLimitExceeded``)."""
        if self._failure is None:
            self._failure = exc
        if self._task is not None and not self._finished:
            self._task.cancel()

    async def _watch(self, event: asyncio.Event | None) -> None:
        if event is not None:
            await event.wait()
            self.cancel()

    def _translate(self, group: BaseExceptionGroup[Any]) -> BaseException:
        """The run error for a task group that stopped because a node failed."""
        failure = self._failure
        if failure is None:
            raise group
        partial = dict(self._outputs)
        if isinstance(failure, UsageLimitExceeded):
            error = UsageLimitExceeded(str(failure), partial=partial)
            error.__cause__ = failure
            return error
        if not isinstance(failure, NodeFailedError | NodeTimeoutError):
            failure = NodeFailedError("?", failure)
        failure.partial = partial
        return failure

    async def _close_pool(self, *, wait: bool) -> None:
        pool, self._own_pool = self._own_pool, None
        if pool is None:
            return
        if wait:
            await asyncio.to_thread(pool.shutdown, True)
        else:
            pool.shutdown(wait=False, cancel_futures=True)


async def _with_timeout(node: Node, ctx: NodeContext, timeout_s: float) -> Any:
    try:
        async with asyncio.timeout(timeout_s) as scope:
            return await node.fn(ctx)
    except TimeoutError as exc:
        if scope.expired():
            raise NodeTimeoutError(node.name, timeout_s) from exc
        raise


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


async def run_graph(graph: TaskGraph | Iterable[Node], **options: Any) -> dict[str, Any]:
    """Run ``graph`` with :class:`Runner` (``options`` are its keyword arguments); return the outputs."""
    return await Runner(graph, **options).run()

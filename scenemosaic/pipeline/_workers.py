"""The parent's side of a run's worker processes (``python -m scenemosaic.pipeline._house_worker``):
how many a run gets, the typed messages sent as one JSON line each way (``pipeline/_house_jobs.py``),
one call of the run's :class:`~scenemosaic._processes.WorkerPool` over a list or a queue of jobs,
and the end of the pool (kept, idle and forgetful, for the next house run in this process, or
closed). The worker's side, which runs a room or writes part of a delivery, is
``pipeline/_house.py``'s :func:`~scenemosaic.pipeline._house.room_worker`.
"""

from __future__ import annotations

import asyncio
import functools
import json
import os
import threading
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from pydantic import BaseModel

from scenemosaic._processes import STOP_GRACE_S, JobEnd, JobQueue, WorkerJob, WorkerPool
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.exchange import plugin_formats
from scenemosaic.pipeline._config import GenerateConfig
from scenemosaic.pipeline._house_jobs import ExportJob, ForgetJob, RoomJob
from scenemosaic.pipeline._state import PipelineRun

__all__ = ["WORKER_MODULE", "encode", "in_processes", "in_workers", "release_workers", "sent"]

WORKER_MODULE = "scenemosaic.pipeline._house_worker"
"""The module a house run's worker processes run (``python -m``)."""


_M = TypeVar("_M", bound=BaseModel)


def sent(message: _M) -> _M:
    """``message`` as the other end of a worker's pipe reads it (:func:`encode`, then validated)."""
    return type(message).model_validate(json.loads(encode(message)))


def encode(message: BaseModel) -> bytes:
    """One line of a message (the standard library's JSON of its JSON-ready dump: a float that is
    not finite, in a stage's figures, travels as ``Infinity`` and comes back a float)."""
    return json.dumps(message.model_dump(mode="json")).encode() + b"\n"


def in_processes(config: GenerateConfig, rooms: int) -> int:
    """How many worker processes the rooms get (0: run them in this process)."""
    workers = config.room_workers or min(os.cpu_count() or 1, rooms)
    # what a worker process cannot know: a model stack, plugin agents, rules or formats of the user's process
    portable = config.model == "rules" and config.agents is None and not config.layout_rules and not plugin_formats()
    return min(workers, rooms) if workers > 1 and portable and rooms > 1 else 0


async def in_workers(
    run: PipelineRun,
    jobs: Sequence[tuple[str, RoomJob | ExportJob]] | JobQueue,
    count: int,
    on_reply: Callable[[str, dict[str, Any]], None] | None = None,
) -> dict[str, dict[str, Any]]:
    """Run every job (``(name, job)``, or the :class:`JobQueue` of a call that takes jobs while it
    runs) in ``count`` worker processes of the run's pool (:attr:`PipelineRun.workers`, a
    ``scenemosaic._processes.WorkerPool`` started on first use and kept from stage to stage: the
    rooms' workers, warm, deliver the houses); their replies by name, each also given to
    ``on_reply`` (in the pool's thread) as it comes (a job whose worker died: ``{"error"}``).
    A worker that dies fails the stage; a cancel stops every worker at once."""
    replies: dict[str, dict[str, Any]] = {}
    failures: list[str] = []

    def ended(job: WorkerJob, end: JobEnd) -> None:
        if end.reply is None:
            failures.append(f"{job.name}: {end.failure()}")
            reply = {"error": end.failure()}
        else:
            reply = replies[job.name] = json.loads(end.reply)
        if on_reply is not None:
            on_reply(job.name, reply)

    if run.workers is None:  # in a thread: closing kept workers that do not fit waits for them
        run.workers = await asyncio.to_thread(_take_workers)
    stop = threading.Event()
    queue = jobs if isinstance(jobs, JobQueue) else JobQueue([WorkerJob(name, encode(job)) for name, job in jobs], closed=True)
    pool = functools.partial(run.workers.run, queue, workers=count, on_end=ended, stop=stop)
    running = asyncio.ensure_future(asyncio.to_thread(pool))
    try:
        await asyncio.shield(running)
    except asyncio.CancelledError:
        stop.set()  # the workers are stopped (they leave at SIGTERM) before the cancel goes on
        await asyncio.wait([running], timeout=STOP_GRACE_S + 1)
        raise
    if failures:
        raise SceneMosaicError("worker process(es) stopped: " + "; ".join(failures))
    return replies


def _take_workers() -> WorkerPool:
    """The room workers a house run before kept (``WorkerPool.take_kept``: started as this run
    would start them, alive and idle), else a new pool."""
    return WorkerPool.take_kept(WORKER_MODULE, orphan="kill")


def release_workers(pool: WorkerPool, *, keep: bool) -> None:
    """The end of a house run's workers: with ``keep`` (the run ended well) and every worker idle
    and alive, each forgets what the run derived (its memos: a pool kept holds the package's
    imports only) and the pool is kept for the next house run in this process
    (``WorkerPool.keep``); else, or when a worker fails to forget, the workers leave."""
    if keep:
        pool.keep(_forget)
    else:
        pool.close()


def _forget(pool: WorkerPool) -> bool:
    """Every worker of ``pool`` drops its memos (:class:`ForgetJob`); whether all did."""
    failed: list[str] = []
    forget = [WorkerJob(f"forget#{k}", encode(ForgetJob()), limit_s=STOP_GRACE_S, slot=k) for k in range(pool.size)]
    try:
        pool.run(forget, workers=pool.size, on_end=lambda job, end: failed.extend([] if end.reply else [job.name]))
    except Exception:  # a pool that cannot forget is not kept (run() has closed it)
        return False
    return not failed

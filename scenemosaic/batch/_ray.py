"""The ``ray`` executor: the job function as Ray tasks, on a local Ray or on a cluster.

When Ray is not initialised yet, a local instance is started for the batch (``num_cpus`` =
``workers``) and shut down after it; with ``RAY_ADDRESS`` set, or after the caller's own
``ray.init(address=...)``, the jobs go to that cluster instead. At most ``workers`` tasks are
in flight, so a job's time-out counts from its start, not from its wait in Ray's queue. A task
past its time-out is cancelled with ``ray.cancel(force=True)``, which kills its worker process.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import structlog

from scenemosaic.batch._job import JobOutcome, JobSpec, execute_job
from scenemosaic.exceptions import MissingExtraError

__all__ = ["RAY_INSTALL_HINT", "require_ray", "run_ray"]

log = structlog.get_logger(__name__)

RAY_INSTALL_HINT = "pip install 'scenemosaic[ray]'"

Started = Callable[[JobSpec], None]
Finished = Callable[[JobSpec, JobOutcome, float], None]


def require_ray() -> Any:
    """The ``ray`` module; raises :class:`~scenemosaic.exceptions.MissingExtraError` when it is not installed."""
    try:
        import ray
    except ImportError as exc:
        raise MissingExtraError(f"the ray executor needs Ray, which is not installed: {RAY_INSTALL_HINT}") from exc
    return ray


def _ray_job(spec: JobSpec, log_level: str) -> dict[str, Any]:
    """The body of a Ray task: :func:`execute_job` with the batch's log level."""
    from scenemosaic._logging import configure_logging

    configure_logging(log_level, json_lines=True)
    return execute_job(spec).model_dump()


def _failure(exc: BaseException) -> JobOutcome:
    text = str(exc).strip().splitlines()
    detail = text[-1] if text else ""
    return JobOutcome(status="failed", error=f"Ray task failed: {type(exc).__name__}: {detail}")


def run_ray(
    specs: list[JobSpec],
    *,
    workers: int,
    timeout_s: float | None,
    log_level: str,
    on_start: Started,
    on_finish: Finished,
) -> None:
    """Run ``specs`` as Ray tasks, at most ``workers`` in flight, in order. With nothing to run
    (every job of a re-run already finished) Ray is not started."""
    if not specs:
        return
    ray = require_ray()
    started_here = False
    if not ray.is_initialized():
        if os.environ.get("RAY_ADDRESS"):
            ray.init(log_to_driver=False)
        else:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        started_here = True
    remote = ray.remote(num_cpus=1, max_retries=0)(_ray_job)
    queue = deque(specs)
    running: dict[Any, tuple[JobSpec, float, float | None]] = {}
    try:
        while queue or running:
            while queue and len(running) < workers:
                spec = queue.popleft()
                on_start(spec)
                started = time.monotonic()
                limit = spec.job.timeout_s if spec.job.timeout_s is not None else timeout_s
                running[remote.remote(spec, log_level)] = (spec, started, limit)
            deadlines = [begun + lim for _, begun, lim in running.values() if lim is not None]
            wait_s = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
            ready, _ = ray.wait(list(running), num_returns=1, timeout=wait_s)
            now = time.monotonic()
            for ref in ready:
                spec, started, _ = running.pop(ref)
                try:
                    outcome = JobOutcome.model_validate(ray.get(ref))
                except Exception as exc:  # the task raised or its worker died
                    outcome = _failure(exc)
                on_finish(spec, outcome, now - started)
            for ref, (spec, started, limit) in list(running.items()):
                if limit is not None and now >= started + limit:
                    log.warning("batch_job_timeout", job=spec.job.id, seconds=round(now - started, 2))
                    ray.cancel(ref, force=True)
                    del running[ref]
                    on_finish(spec, JobOutcome(status="timeout", error=f"stopped after its time-out of {limit:g} s"), now - started)
    finally:
        for ref in running:
            ray.cancel(ref, force=True)
        if started_here:
            ray.shutdown()

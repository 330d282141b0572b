"""The ``local`` executor: each job in its own worker process, at most ``workers`` at a time.

The jobs go through the package's one worker pool (``scenemosaic._processes.run_jobs``, shared
with a house run's rooms): a job gets a fresh interpreter (``python -m scenemosaic.batch._worker``,
see there), so nothing of the batch process leaks into it and the caller's script needs no
``__main__`` guard. It reads the job as JSON from stdin and sends its outcome back through a pipe;
its output goes to the job's log file. A crash of that process (a segfault in native code,
running out of memory) fails that job only. At its time-out the worker gets SIGTERM, which
cancels the pipeline (it writes its report of the stopped run), and when it has not left
:data:`STOP_GRACE_S` later its whole process group (the CoACD workers it started included) gets
SIGKILL.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import structlog

from scenemosaic._processes import STOP_GRACE_S, JobEnd, WorkerJob, run_jobs
from scenemosaic.batch._job import JobOutcome, JobSpec

__all__ = ["STOP_GRACE_S", "run_local"]

log = structlog.get_logger(__name__)

Started = Callable[[JobSpec], None]
Finished = Callable[[JobSpec, JobOutcome, float], None]

_WORKER_MODULE = "scenemosaic.batch._worker"


def _outcome(end: JobEnd, limit: float | None) -> JobOutcome:
    sent: JobOutcome | None = None
    if end.reply:
        try:
            sent = JobOutcome.model_validate_json(end.reply)
        except ValueError as exc:
            sent = JobOutcome(status="failed", error=f"worker sent an unreadable outcome: {exc}")
    if sent is not None and (not end.timed_out or sent.status != "failed"):
        return sent  # it finished, even if its time-out came as it did
    if end.timed_out:
        return JobOutcome(status="timeout", error=f"stopped after its time-out of {limit:g} s")
    if sent is not None:
        return sent
    return JobOutcome(status="failed", error=end.failure())


def run_local(
    specs: list[JobSpec],
    *,
    workers: int,
    timeout_s: float | None,
    log_dir: Path,
    log_level: str,
    on_start: Started,
    on_finish: Finished,
) -> None:
    """Run ``specs`` in worker processes, at most ``workers`` at once, in order.

    ``on_start`` and ``on_finish`` are called in this thread. When the batch itself stops (an
    exception here, Ctrl-C), every running worker is stopped before the exception propagates.
    """
    log_dir.mkdir(parents=True, exist_ok=True)
    by_name = {spec.job.id: spec for spec in specs}
    jobs = [
        WorkerJob(
            name=spec.job.id,
            payload=spec.model_dump_json().encode("utf-8"),
            limit_s=spec.job.timeout_s if spec.job.timeout_s is not None else timeout_s,
            log_path=log_dir / f"{spec.job.id}.log",
        )
        for spec in specs
    ]

    def ended(job: WorkerJob, end: JobEnd) -> None:
        if end.timed_out and end.reply is None:
            log.warning("batch_job_timeout", job=job.name, seconds=round(end.seconds, 2))
        on_finish(by_name[job.name], _outcome(end, job.limit_s), end.seconds)

    run_jobs(
        jobs, module=_WORKER_MODULE, args=[log_level], workers=workers, reuse=False,
        on_start=lambda job: on_start(by_name[job.name]), on_end=ended,
    )  # fmt: skip

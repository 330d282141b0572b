"""The ``local`` executor: each job in its own worker process, at most ``workers`` at a time.

A job gets a fresh interpreter (``python -m scenemosaic.batch._worker``, see there), so nothing
of the batch process leaks into it and the caller's script needs no ``__main__`` guard. It
reads the job as JSON from stdin and sends its outcome back through a pipe; its output goes to
the job's log file. A crash of that process (a segfault in native code, running out of memory)
fails that job only. At its time-out the worker gets SIGTERM, which cancels the pipeline (it
writes its report of the stopped run), and when it has not left :data:`STOP_GRACE_S` later its
whole process group (the CoACD workers it started included) gets SIGKILL.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from pathlib import Path

import structlog

from scenemosaic._processes import STOP_GRACE_S, kill_group, worker_environment
from scenemosaic.batch._job import JobOutcome, JobSpec

__all__ = ["STOP_GRACE_S", "run_local"]

log = structlog.get_logger(__name__)

Started = Callable[[JobSpec], None]
Finished = Callable[[JobSpec, JobOutcome, float], None]

_WORKER_MODULE = "scenemosaic.batch._worker"
_EXIT_POLL_S = 0.05


@dataclass
class _Running:
    spec: JobSpec
    process: subprocess.Popen[bytes]
    pipe: int
    """Read end of the outcome pipe; readable when the worker wrote its outcome or is gone."""
    started: float
    limit: float | None
    received: bytearray = field(default_factory=bytearray)
    closed: bool = False
    """The pipe reached its end: the worker has sent all it will send."""
    kill_at: float | None = None
    """Set once the worker was told to stop (at its time-out, or when it lingers after its
    pipe ended): when it is killed if still there."""
    killed: bool = False
    timed_out: bool = False
    reported: bool = False
    """``on_finish`` was called for it (it may still be leaving)."""

    def next_check(self, now: float) -> float | None:
        """When the loop must look at this worker even if its pipe stays quiet."""
        if self.closed:  # leaving: its exit makes no noise on the pipe, so look again soon
            return now + _EXIT_POLL_S
        if self.kill_at is not None:
            return None if self.killed else self.kill_at
        return self.started + self.limit if self.limit is not None else None


def _start(spec: JobSpec, log_dir: Path, log_level: str, limit: float | None) -> _Running:
    log_dir.mkdir(parents=True, exist_ok=True)
    read_end, write_end = os.pipe()
    try:
        with open(log_dir / f"{spec.job.id}.log", "ab") as log_file:
            process = subprocess.Popen(
                [sys.executable, "-m", _WORKER_MODULE, str(write_end), str(os.getpid()), log_level],
                stdin=subprocess.PIPE,
                stdout=log_file,
                stderr=log_file,
                pass_fds=(write_end,),
                env=worker_environment(),
                start_new_session=True,  # its own process group: one signal reaches its helpers too
            )
    except BaseException:
        os.close(read_end)
        raise
    finally:
        os.close(write_end)
    started = time.monotonic()
    assert process.stdin is not None
    try:
        process.stdin.write(spec.model_dump_json().encode("utf-8"))
        process.stdin.close()
    except OSError:  # it died at once; the pipe's end and its exit code say so
        pass
    return _Running(spec, process, read_end, started, limit)


def _read(run: _Running) -> None:
    """Take what the worker wrote; notes the pipe's end."""
    while not run.closed:
        try:
            chunk = os.read(run.pipe, 65536)
        except BlockingIOError:
            return
        if not chunk:
            run.closed = True
            return
        run.received.extend(chunk)


def _stop(run: _Running, now: float) -> None:
    """SIGTERM now (the pipeline writes its report), SIGKILL to the group at ``kill_at``."""
    if run.kill_at is None:
        run.kill_at = now + STOP_GRACE_S
        with contextlib.suppress(OSError):
            run.process.send_signal(signal.SIGTERM)


def _kill(run: _Running) -> None:
    """SIGKILL the worker and everything in its process group."""
    run.killed = True
    kill_group(run.process.pid)


def _outcome(run: _Running) -> JobOutcome:
    sent: JobOutcome | None = None
    if run.received:
        try:
            sent = JobOutcome.model_validate_json(bytes(run.received))
        except ValueError as exc:
            sent = JobOutcome(status="failed", error=f"worker sent an unreadable outcome: {exc}")
    if sent is not None and (not run.timed_out or sent.status != "failed"):
        return sent  # it finished, even if its time-out came as it did
    if run.timed_out:
        return JobOutcome(status="timeout", error=f"stopped after its time-out of {run.limit:g} s")
    if sent is not None:
        return sent
    code = run.process.returncode
    if code is not None and code < 0:
        with contextlib.suppress(ValueError):
            return JobOutcome(status="failed", error=f"worker process died from {signal.Signals(-code).name}")
    return JobOutcome(status="failed", error=f"worker process ended (exit code {code}) without a result")


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
    queue = deque(specs)
    running: list[_Running] = []
    try:
        while queue or running:
            while queue and len(running) < workers:
                spec = queue.popleft()
                on_start(spec)
                limit = spec.job.timeout_s if spec.job.timeout_s is not None else timeout_s
                run = _start(spec, log_dir, log_level, limit)
                os.set_blocking(run.pipe, False)
                running.append(run)
            now = time.monotonic()
            wakes = [t for t in (r.next_check(now) for r in running) if t is not None]
            wait([r.pipe for r in running if not r.closed], timeout=max(0.0, min(wakes) - now) if wakes else None)
            now = time.monotonic()
            for run in list(running):
                _read(run)
                if run.closed:
                    exited = run.process.poll() is not None
                    if not run.reported and (exited or (run.received and not run.timed_out)):
                        run.reported = True  # the outcome is in: report it while the process leaves
                        on_finish(run.spec, _outcome(run), now - run.started)
                    if exited:
                        running.remove(run)
                        os.close(run.pipe)
                    elif run.kill_at is None:
                        run.kill_at = now + STOP_GRACE_S
                    elif now >= run.kill_at and not run.killed:
                        _kill(run)
                elif run.kill_at is not None:
                    if now >= run.kill_at and not run.killed:
                        _kill(run)
                elif run.limit is not None and now >= run.started + run.limit:
                    log.warning("batch_job_timeout", job=run.spec.job.id, seconds=round(now - run.started, 2))
                    run.timed_out = True
                    _stop(run, now)
    finally:
        _stop_all(running)


def _stop_all(running: list[_Running]) -> None:
    """Stop every worker still running: SIGTERM, then SIGKILL after the grace period."""
    if not running:
        return
    now = time.monotonic()
    for run in running:
        _stop(run, now)
    deadline = now + STOP_GRACE_S
    for run in running:
        try:
            run.process.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            _kill(run)
            run.process.wait()
        os.close(run.pipe)
        log.warning("batch_job_stopped", job=run.spec.job.id)

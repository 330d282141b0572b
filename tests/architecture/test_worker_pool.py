"""The package's one worker pool (``scenemosaic._processes.run_jobs``), which a batch's jobs and a
house's rooms both go through: reuse, fresh workers, a worker that dies, time-outs, a stop."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from scenemosaic._processes import STOP_GRACE_S, JobEnd, WorkerJob, run_jobs

TESTS = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _echo_worker_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PYTHONPATH", str(TESTS))


def _run(jobs: list[WorkerJob], **kwargs: object) -> dict[str, JobEnd]:
    ends: dict[str, JobEnd] = {}
    run_jobs(jobs, module="process_echo_worker", on_end=lambda job, end: ends.__setitem__(job.name, end), **kwargs)  # type: ignore[arg-type]
    return ends


def _pid(end: JobEnd) -> int:
    assert end.reply is not None
    return int(end.reply.split()[0])


def test_reused_workers_take_job_after_job() -> None:
    jobs = [WorkerJob(f"j{i}", f"job {i}".encode()) for i in range(6)]
    ends = _run(jobs, workers=2, reuse=True)
    assert sorted(ends) == [j.name for j in jobs]
    assert all(e.reply is not None and e.reply.endswith(f"job {n[1:]}".encode()) for n, e in ends.items())
    assert len({_pid(e) for e in ends.values()}) <= 2


def test_without_reuse_every_job_gets_a_fresh_worker() -> None:
    ends = _run([WorkerJob(f"j{i}", b"x") for i in range(4)], workers=2, reuse=False)
    assert len({_pid(e) for e in ends.values()}) == 4


@pytest.mark.parametrize("reuse", [True, False])
def test_a_worker_that_dies_fails_its_job_only(reuse: bool) -> None:
    jobs = [WorkerJob("a", b"one"), WorkerJob("dead", b"die 3"), WorkerJob("b", b"two"), WorkerJob("c", b"three")]
    ends = _run(jobs, workers=1, reuse=reuse)
    assert ends["dead"].reply is None and ends["dead"].exit_code == 3
    assert "exit code 3" in ends["dead"].failure()
    assert all(ends[n].reply is not None for n in ("a", "b", "c"))


def test_a_job_past_its_limit_is_stopped_and_the_next_runs() -> None:
    started = time.monotonic()
    jobs = [WorkerJob("slow", b"sleep 60", limit_s=0.5), WorkerJob("next", b"fine")]
    ends = _run(jobs, workers=1, reuse=True)
    assert ends["slow"].timed_out and ends["slow"].reply is None
    assert ends["next"].reply is not None
    assert time.monotonic() - started < 10


def test_a_worker_deaf_to_sigterm_is_killed_after_the_grace_period() -> None:
    started = time.monotonic()
    ends = _run([WorkerJob("deaf", b"hang", limit_s=0.5)], workers=1, reuse=False)
    assert ends["deaf"].timed_out
    assert STOP_GRACE_S <= time.monotonic() - started < STOP_GRACE_S + 5


def test_a_stop_ends_the_pool_and_its_workers() -> None:
    stop = threading.Event()
    threading.Timer(0.5, stop.set).start()
    started = time.monotonic()
    ends = _run([WorkerJob("long", b"sleep 60"), WorkerJob("never", b"x")], workers=1, reuse=True, stop=stop)
    assert time.monotonic() - started < 5
    assert "never" not in ends

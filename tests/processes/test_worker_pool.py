"""The package's one worker pool (``scenemosaic._processes.run_jobs``, and ``WorkerPool``, its
workers kept from call to call), which a batch's jobs and a house's rooms both go through: reuse,
fresh workers, a worker that dies, time-outs, a stop, workers that outlive a call."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest

from scenemosaic._processes import STOP_GRACE_S, JobEnd, JobQueue, WorkerJob, WorkerPool, run_jobs

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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _pool_run(pool: WorkerPool, jobs: list[WorkerJob], **kwargs: object) -> dict[str, JobEnd]:
    ends: dict[str, JobEnd] = {}
    pool.run(jobs, on_end=lambda job, end: ends.__setitem__(job.name, end), **kwargs)  # type: ignore[arg-type]
    return ends


def test_a_pool_keeps_its_workers_for_the_next_call_until_closed() -> None:
    pool = WorkerPool("process_echo_worker")
    try:
        first = _pool_run(pool, [WorkerJob(f"a{i}", b"sleep 0.2") for i in range(2)], workers=2)
        pids = {_pid(e) for e in first.values()}
        assert len(pids) == 2 and pool.size == 2
        second = _pool_run(pool, [WorkerJob(f"b{i}", f"job {i}".encode()) for i in range(4)], workers=2)
        assert {_pid(e) for e in second.values()} <= pids  # no new start-up: the same processes
        assert all(
            e.reply is not None and e.reply.endswith(f"job {n[1:]}".encode()) for n, e in second.items()
        )
    finally:
        pool.close()
    assert pool.size == 0
    deadline = time.monotonic() + 5
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(p) for p in pids)


def test_a_stopped_call_ends_the_pools_workers() -> None:
    pool = WorkerPool("process_echo_worker")
    try:
        warm = _pool_run(pool, [WorkerJob("warm", b"x")], workers=1)
        stop = threading.Event()
        threading.Timer(0.5, stop.set).start()
        ends = _pool_run(
            pool, [WorkerJob("long", b"sleep 60"), WorkerJob("never", b"x")], workers=1, stop=stop
        )
        assert "never" not in ends and pool.size == 0
        after = _pool_run(pool, [WorkerJob("fresh", b"y")], workers=1)  # the next call starts anew
        assert _pid(after["fresh"]) != _pid(warm["warm"])
    finally:
        pool.close()


def test_jobs_of_a_slot_run_in_that_worker_whatever_else_is_idle() -> None:
    pool = WorkerPool("process_echo_worker")
    try:
        # slot 0's first job is slow: its next jobs wait for it rather than take the idle worker
        jobs = [WorkerJob("a0", b"sleep 0.5", slot=0), *(WorkerJob(f"a{i}", b"x", slot=0) for i in (1, 2))]
        jobs += [WorkerJob(f"b{i}", b"y", slot=1) for i in range(3)]
        ends = _pool_run(pool, jobs, workers=2)
        assert len({_pid(ends[f"a{i}"]) for i in range(3)}) == 1
        assert len({_pid(ends[f"b{i}"]) for i in range(3)}) == 1
        assert _pid(ends["a0"]) != _pid(ends["b0"])
        again = _pool_run(pool, [WorkerJob("b", b"z", slot=1), WorkerJob("a", b"z", slot=0)], workers=2)
        assert _pid(again["a"]) == _pid(ends["a0"]) and _pid(again["b"]) == _pid(ends["b0"])  # kept their places
    finally:
        pool.close()


def test_a_slot_past_the_first_starts_the_workers_before_it() -> None:
    pool = WorkerPool("process_echo_worker")
    try:
        first = _pool_run(pool, [WorkerJob("late", b"x", slot=1)], workers=2)
        assert pool.size == 2
        then = _pool_run(pool, [WorkerJob("late", b"x", slot=1), WorkerJob("wrapped", b"x", slot=3)], workers=2)
        assert _pid(then["late"]) == _pid(first["late"]) == _pid(then["wrapped"])
    finally:
        pool.close()


def test_a_queue_takes_jobs_while_its_call_runs_and_ends_when_closed() -> None:
    pool = WorkerPool("process_echo_worker")
    queue = JobQueue([WorkerJob("first", b"sleep 0.2")])
    ends: dict[str, JobEnd] = {}
    call = threading.Thread(target=pool.run, args=(queue,), kwargs={"workers": 2, "on_end": lambda j, e: ends.__setitem__(j.name, e)})
    try:
        call.start()
        time.sleep(0.6)
        assert "first" in ends and call.is_alive()  # its jobs are done, but the queue is open: it waits
        queue.put([WorkerJob("later", b"later", slot=1), WorkerJob("last", b"last")])
        time.sleep(0.3)
        assert call.is_alive()
        queue.close()
        call.join(10)
        assert not call.is_alive()
        assert ends["later"].reply is not None and ends["later"].reply.endswith(b"later")
        assert ends["last"].reply is not None
        with pytest.raises(RuntimeError, match="closed"):
            queue.put([WorkerJob("too late", b"x")])
    finally:
        queue.close()
        call.join(10)
        pool.close()


def test_a_stop_ends_a_call_whose_queue_is_still_open() -> None:
    pool = WorkerPool("process_echo_worker")
    stop = threading.Event()
    threading.Timer(0.5, stop.set).start()
    started = time.monotonic()
    try:
        _pool_run(pool, JobQueue([WorkerJob("quick", b"x")]), workers=1, stop=stop)  # type: ignore[arg-type]
        assert time.monotonic() - started < 5 and pool.size == 0
    finally:
        pool.close()


def test_a_worker_outlives_the_thread_that_started_it() -> None:
    # the kernel's orphan signal follows the thread that started a worker: a house run starts its
    # workers from a short-lived thread of its event loop, and keeps them for the next run
    pool = WorkerPool("process_echo_worker")
    try:
        first: dict[str, JobEnd] = {}
        starter = threading.Thread(target=lambda: first.update(_pool_run(pool, [WorkerJob("a", b"x")], workers=1)))
        starter.start()
        starter.join()
        time.sleep(0.3)  # the signal, had it come, is delivered by now
        pid = _pid(first["a"])
        assert pool.ready()  # alive (not a zombie killed by the signal) and idle
        again = _pool_run(pool, [WorkerJob("b", b"y")], workers=1)
        assert _pid(again["b"]) == pid
    finally:
        pool.close()


def test_a_call_with_fewer_workers_than_the_pool_holds_runs_that_many_at_once() -> None:
    pool = WorkerPool("process_echo_worker")
    try:
        warm = _pool_run(pool, [WorkerJob(f"w{i}", b"sleep 0.2") for i in range(2)], workers=2)
        assert pool.size == 2 and len({_pid(e) for e in warm.values()}) == 2
        one = _pool_run(pool, [WorkerJob(f"j{i}", b"sleep 0.1") for i in range(3)], workers=1)
        assert len({_pid(e) for e in one.values()}) == 1  # one at a time, in the pool's first worker
        assert pool.size == 2 and pool.ready()
    finally:
        pool.close()
    assert not pool.ready()


# -- the executor: one job at a time from any thread (CoACD's workers) ------------------------------


def test_an_executor_answers_jobs_from_many_threads_on_reused_workers() -> None:
    from concurrent.futures import ThreadPoolExecutor

    from scenemosaic._processes import WorkerExecutor

    executor = WorkerExecutor("process_echo_worker", workers=2)
    try:
        with ThreadPoolExecutor(4) as threads:
            futures = list(threads.map(lambda k: executor.submit(f"job {k}".encode()), range(8)))
        replies = [f.result(timeout=60) for f in futures]
        assert [r.split(b" ", 1)[1] for r in replies] == [f"job {k}".encode() for k in range(8)]
        assert len({r.split()[0] for r in replies}) <= 2  # two processes, each taking job after job
        assert executor.started
    finally:
        executor.close()
    assert not executor.started
    with pytest.raises(RuntimeError, match="closed"):
        executor.submit(b"job late")


def test_an_executor_fails_the_job_of_a_worker_that_died_and_goes_on() -> None:
    from scenemosaic._processes import WorkerError, WorkerExecutor

    executor = WorkerExecutor("process_echo_worker", workers=1)
    try:
        with pytest.raises(WorkerError, match="exit code 3"):
            executor.submit(b"die 3").result(timeout=60)
        assert executor.submit(b"job after").result(timeout=60).endswith(b"job after")  # a new worker
    finally:
        executor.close()


def test_closing_an_executor_with_cancel_stops_a_busy_worker_and_fails_its_job() -> None:
    from scenemosaic._processes import WorkerError, WorkerExecutor

    executor = WorkerExecutor("process_echo_worker", workers=1)
    busy = executor.submit(b"sleep 30")
    time.sleep(1.0)
    started = time.monotonic()
    executor.close(cancel=True)
    assert time.monotonic() - started < STOP_GRACE_S + 2
    with pytest.raises(WorkerError):
        busy.result(timeout=1)

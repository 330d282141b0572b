"""Worker processes of the package (a batch's jobs, a house run's rooms): how they are started,
how they notice that the process that started them is gone, and how they are stopped.

A worker is a fresh interpreter (``python -m <module>``, through a few lines of bootstrap) in its
own process group, so one signal reaches whatever it started (CoACD's processes) and the caller's
script needs no ``__main__`` guard. It gets the environment of :func:`worker_environment` (it
imports this very package). When its parent dies (SIGKILL included) it goes too, as the pool
says (``orphan``): ``"stop"`` — SIGTERM, so a pipeline writes its report (a batch job, in a folder
of its own) — or ``"kill"`` — SIGKILL at once (a house's room worker, which writes into the house's
folder, whose lock died with the parent). On Linux the kernel sends that signal
(``PR_SET_PDEATHSIG``, set before the worker imports anything), so it comes within milliseconds
even while the worker's Python is busy in native code or still loading; everywhere,
:func:`watch_parent` also looks every 0.2 s and stops the worker itself.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import contextlib
import os
import queue
import signal
import subprocess
import sys
import sysconfig
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any, ClassVar, Literal

__all__ = [
    "STOP_GRACE_S",
    "JobEnd",
    "JobQueue",
    "Orphan",
    "WorkerError",
    "WorkerExecutor",
    "WorkerJob",
    "WorkerPool",
    "kill_group",
    "run_jobs",
    "serve_lines",
    "watch_parent",
    "worker_environment",
]

STOP_GRACE_S = 5.0
"""Seconds a worker told to stop (SIGTERM) has to leave before its process group is killed."""
_ORPHAN_POLL_S = 0.2

Orphan = Literal["stop", "kill"]
"""What a worker does when the process that started it dies (see the module docstring)."""
_ORPHAN_SIGNALS: dict[str, int] = {"stop": signal.SIGTERM, "kill": signal.SIGKILL}

_BOOTSTRAP = """\
import os, sys
orphan, module, parent = int(sys.argv[1]), sys.argv[2], int(sys.argv[4])
if sys.platform.startswith("linux"):
    import ctypes
    ctypes.CDLL(None, use_errno=True).prctl(1, orphan)  # PR_SET_PDEATHSIG
if os.getppid() != parent:  # the parent died before that
    os._exit(1)
import runpy
sys.argv = sys.argv[2:]
runpy.run_module(module, run_name="__main__", alter_sys=True)
"""
"""What a worker runs first (``python -c``): the signal the kernel sends it when the thread that
started it ends (:class:`_Spawner`'s, which lives as long as this process), then ``python -m module``."""


def worker_environment() -> dict[str, str]:
    """A worker's environment: this one, so that the worker imports this very scenemosaic.

    When scenemosaic was imported from a folder outside the interpreter's site-packages (a
    checkout put on ``sys.path`` by a script), that folder goes first on ``PYTHONPATH``.
    """
    env = dict(os.environ)
    root = Path(__file__).resolve().parents[1]
    site_dirs = {Path(sysconfig.get_path(name)).resolve() for name in ("purelib", "platlib")}
    if root not in site_dirs:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), env.get("PYTHONPATH")) if p)
    return env


def _watch(parent_pid: int, orphan: Orphan) -> None:
    while os.getppid() == parent_pid:
        time.sleep(_ORPHAN_POLL_S)
    if orphan == "stop":
        with contextlib.suppress(OSError):
            os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(STOP_GRACE_S)
    with contextlib.suppress(OSError):  # this worker and what it started (its own process group)
        os.killpg(os.getpgrp(), signal.SIGKILL)
    os._exit(1)


def watch_parent(parent_pid: int, orphan: Orphan = "stop") -> None:
    """In a worker: stop this process when ``parent_pid`` is no longer its parent (the parent
    died). ``"stop"``: SIGTERM to itself at once, and its process group killed
    :data:`STOP_GRACE_S` later if still here; ``"kill"``: its process group killed at once."""
    threading.Thread(target=_watch, args=(parent_pid, orphan), name="parent-watch", daemon=True).start()


def kill_group(pid: int) -> None:
    """SIGKILL the process ``pid`` and everything in its process group (a worker started with
    ``start_new_session=True``, not reaped yet, so the group id is its own)."""
    with contextlib.suppress(OSError):
        os.killpg(pid, signal.SIGKILL)
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGKILL)


# -- the pool -------------------------------------------------------------------------------------

_EXIT_POLL_S = 0.05


@dataclass(frozen=True)
class WorkerJob:
    """One job for a worker process: its ``payload`` (one line, sent on the worker's stdin), its
    time limit and, for a worker of its own, the file its output goes to."""

    name: str
    payload: bytes
    limit_s: float | None = None
    """Seconds the job may run; then its worker is stopped (SIGTERM, then its group killed)."""
    log_path: Path | None = None
    """Where the worker's stdout and stderr go (appended); ``None``: this process's own."""
    slot: int | None = None
    """The worker that must run it, by its place among the call's workers (``0`` .. ``workers - 1``,
    in the order they were started; a larger number wraps around): jobs of one slot run one after
    another in the same reused process, whose in-process memos suit them. ``None``: any worker."""


class JobQueue:
    """The jobs of one :meth:`WorkerPool.run` call that may grow while it runs: :meth:`put` more
    jobs (from any thread), then :meth:`close`; the call returns once the queue is closed and every
    job in it has ended. A plain list of jobs is a queue closed from the start."""

    def __init__(self, jobs: list[WorkerJob] | None = None, *, closed: bool = False) -> None:
        self._jobs: deque[WorkerJob] = deque(jobs or [])
        self._lock = threading.Lock()
        self._closed = closed
        self._wake: Callable[[], None] | None = None

    def put(self, jobs: list[WorkerJob]) -> None:
        """Add ``jobs`` at the end (after :meth:`close`: an error)."""
        with self._lock:
            if self._closed:
                raise RuntimeError("no job can join a closed queue")
            self._jobs.extend(jobs)
            wake = self._wake
        if wake is not None:
            wake()

    def close(self) -> None:
        """No more jobs: the call serving the queue ends with the last of them."""
        with self._lock:
            self._closed = True
            wake = self._wake
        if wake is not None:
            wake()

    def _take(self, ready: Callable[[WorkerJob], bool]) -> WorkerJob | None:
        """The first job ``ready`` accepts, taken out of the queue; ``None``: none."""
        with self._lock:
            for k, job in enumerate(self._jobs):
                if ready(job):
                    del self._jobs[k]
                    return job
        return None

    def _done(self) -> bool:
        with self._lock:
            return self._closed and not self._jobs

    def _serve_with(self, wake: Callable[[], None] | None) -> None:
        with self._lock:
            self._wake = wake


@dataclass(frozen=True)
class JobEnd:
    """How a job ended: the worker's reply (one line, without its newline), or why there is none."""

    reply: bytes | None
    seconds: float
    timed_out: bool = False
    exit_code: int | None = None
    """The worker's exit status when it left without a reply (negative: the signal that killed it)."""

    def failure(self) -> str:
        """Why there is no reply, in words."""
        if self.timed_out:
            return f"stopped after its time-out of {self.seconds:.0f} s"
        code = self.exit_code
        if code is not None and code < 0:
            with contextlib.suppress(ValueError):
                return f"worker process died from {signal.Signals(-code).name}"
        return f"worker process ended (exit code {code}) without a result"


@dataclass
class _Worker:
    process: subprocess.Popen[bytes]
    pipe: int
    """Read end of the reply pipe; readable when the worker replied or is gone."""
    job: WorkerJob | None = None
    """The job it works on (a worker without reuse keeps it while it leaves)."""
    started: float = 0.0
    received: bytearray = field(default_factory=bytearray)
    closed: bool = False
    """The pipe reached its end: the worker has sent all it will send."""
    kill_at: float | None = None
    """Set once it was told to stop (its time-out, or lingering after its pipe ended)."""
    killed: bool = False
    timed_out: bool = False
    ended: bool = False
    """Its job was reported (it may still be leaving)."""

    @property
    def busy(self) -> bool:
        return self.job is not None and not self.ended

    def next_check(self, now: float) -> float | None:
        """When the loop must look at this worker even if its pipe stays quiet."""
        if self.closed:  # leaving: its exit makes no noise on the pipe, so look again soon
            return now + _EXIT_POLL_S
        if self.kill_at is not None:
            return None if self.killed else self.kill_at
        if self.busy and self.job is not None and self.job.limit_s is not None:
            return self.started + self.job.limit_s
        return None


class _Spawner:
    """The one thread every worker is started from. The kernel's orphan signal
    (``PR_SET_PDEATHSIG``) comes when the *thread* that started a worker ends, not its process: a
    worker started by a run's short-lived thread (an ``asyncio.to_thread`` of its event loop)
    would be killed when that loop closes. This thread is a daemon that lives as long as the
    process, so a worker lives until it is told to leave or this process dies (and then at once)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._jobs: queue.SimpleQueue[tuple[Callable[[], Any], concurrent.futures.Future[Any]]] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._pid = 0

    def run(self, make: Callable[[], Any]) -> Any:
        """``make()`` called in the spawner thread; its result (or its exception) here."""
        with self._lock:
            if self._thread is None or self._pid != os.getpid() or not self._thread.is_alive():
                self._jobs, self._pid = queue.SimpleQueue(), os.getpid()  # a forked child has no such thread
                self._thread = threading.Thread(target=self._serve, args=(self._jobs,), name="worker-spawner", daemon=True)
                self._thread.start()
            jobs = self._jobs
        done: concurrent.futures.Future[Any] = concurrent.futures.Future()
        jobs.put((make, done))
        return done.result()

    @staticmethod
    def _serve(jobs: queue.SimpleQueue[tuple[Callable[[], Any], concurrent.futures.Future[Any]]]) -> None:
        while True:
            make, done = jobs.get()
            if done.set_running_or_notify_cancel():
                try:
                    done.set_result(make())
                except BaseException as exc:  # handed to the caller, who raises it
                    done.set_exception(exc)


_SPAWNER = _Spawner()


def _spawn(module: str, args: list[str], log_path: Path | None, orphan: Orphan) -> _Worker:
    read_end, write_end = os.pipe()
    try:
        out = open(log_path, "ab") if log_path is not None else None  # noqa: SIM115 - handed to the child, closed below
        try:
            boot = [sys.executable, "-c", _BOOTSTRAP, str(int(_ORPHAN_SIGNALS[orphan]))]
            process: subprocess.Popen[bytes] = _SPAWNER.run(
                lambda: subprocess.Popen(
                    [*boot, module, str(write_end), str(os.getpid()), *args],
                    stdin=subprocess.PIPE, stdout=out, stderr=out, pass_fds=(write_end,), env=worker_environment(),
                    start_new_session=True,  # its own process group: one signal reaches its helpers too
                )
            )  # fmt: skip
        finally:
            if out is not None:
                out.close()
    except BaseException:
        os.close(read_end)
        raise
    finally:
        os.close(write_end)
    os.set_blocking(read_end, False)
    return _Worker(process, read_end)


def _send(worker: _Worker, job: WorkerJob, reuse: bool) -> None:
    worker.job, worker.started, worker.received = job, time.monotonic(), bytearray()
    assert worker.process.stdin is not None
    try:
        worker.process.stdin.write(job.payload.rstrip(b"\n") + b"\n")
        worker.process.stdin.flush()
        if not reuse:
            worker.process.stdin.close()  # one job: the worker leaves when it is done
    except OSError:  # it died at once; the pipe's end and its exit code say so
        pass


def _read(worker: _Worker) -> None:
    while not worker.closed:
        try:
            chunk = os.read(worker.pipe, 65536)
        except BlockingIOError:
            return
        if not chunk:
            worker.closed = True
            return
        worker.received.extend(chunk)


def _stop(worker: _Worker, now: float) -> None:
    """SIGTERM now (a pipeline writes its report), SIGKILL to the group at ``kill_at``."""
    if worker.kill_at is None:
        worker.kill_at = now + STOP_GRACE_S
        with contextlib.suppress(OSError):
            worker.process.send_signal(signal.SIGTERM)


def run_jobs(
    jobs: list[WorkerJob],
    *,
    module: str,
    args: list[str] | None = None,
    workers: int,
    reuse: bool,
    on_start: Callable[[WorkerJob], None] | None = None,
    on_end: Callable[[WorkerJob, JobEnd], None],
    stop: threading.Event | None = None,
    orphan: Orphan = "stop",
) -> None:
    """Run ``jobs`` in worker processes (``python -m module REPLY_FD PARENT_PID *args``), at most
    ``workers`` at once, in order; ``on_start`` and ``on_end`` are called in this thread
    (``orphan`` says what a worker does should this process die: see the module docstring; the
    worker module calls :func:`watch_parent` with the same).

    A worker reads one job a line on stdin and writes one reply a line to the pipe ``REPLY_FD``.
    With ``reuse`` a worker takes the next job when it replied (a house's rooms: one start-up per
    worker); without, every job gets a fresh worker that leaves after it (a batch's jobs: nothing
    of one job lives on in the next). A job past its ``limit_s`` gets SIGTERM, and its worker's
    process group SIGKILL :data:`STOP_GRACE_S` later; a worker that dies fails its job only (the
    next job gets a new worker). When this call stops (an exception, ``stop`` set), every worker
    still running is stopped the same way before it returns or raises; when it ends, every worker
    leaves (:class:`WorkerPool` keeps them for the next call instead).
    """
    running: list[_Worker] = []
    try:
        _serve(JobQueue(jobs, closed=True), running, module, args or [], workers, reuse, on_start, on_end, stop, orphan)
    finally:
        _stop_all(running, reuse)


class WorkerPool:
    """Reused worker processes that outlive one batch of jobs: a house run's room workers go on to
    deliver its houses, with the package imported and their in-process memos (meshes, hulls,
    exported texts) already warm. :meth:`run` is :func:`run_jobs` with ``reuse`` over the workers
    left idle by the previous call; :meth:`close` makes them leave (call it once the run is over).
    One call of :meth:`run` at a time."""

    def __init__(self, module: str, *, args: list[str] | None = None, orphan: Orphan = "stop") -> None:
        self.module, self.args, self.orphan = module, list(args or []), orphan
        self._running: list[_Worker] = []
        self._lock = threading.Lock()

    @property
    def size(self) -> int:
        """Worker processes held now."""
        return len(self._running)

    def ready(self) -> bool:
        """Whether the pool holds workers and every one is alive and waiting for a job (none
        busy, stopping, leaving or gone): a pool that may be kept for later."""
        with self._lock:
            return bool(self._running) and all(
                w.job is None and w.kill_at is None and not w.closed and w.process.poll() is None for w in self._running
            )

    def run(
        self,
        jobs: list[WorkerJob] | JobQueue,
        *,
        workers: int,
        on_start: Callable[[WorkerJob], None] | None = None,
        on_end: Callable[[WorkerJob, JobEnd], None],
        stop: threading.Event | None = None,
    ) -> None:
        """Run ``jobs`` as :func:`run_jobs` does (``reuse``), at most ``workers`` at once; the
        workers idle at the end stay for the next call. ``jobs`` may be a :class:`JobQueue` that
        grows while the call runs (it returns once the queue is closed and emptied). A call that
        stops (an exception, ``stop`` set) stops every worker of the pool, as :func:`run_jobs` would."""
        queue = jobs if isinstance(jobs, JobQueue) else JobQueue(jobs, closed=True)
        with self._lock:
            try:
                stopped = _serve(queue, self._running, self.module, self.args, workers, True, on_start, on_end, stop, self.orphan)
            except BaseException:
                self._close()
                raise
            if stopped:
                self._close()

    def close(self) -> None:
        """Every worker leaves (idle ones at the end of their stdin; any still busy are stopped)."""
        with self._lock:
            self._close()

    # -- kept between runs: one idle pool per module, owned by the class, closed at exit ------------

    _kept: ClassVar[dict[str, tuple[WorkerPool, tuple[object, ...]]]] = {}
    _kept_lock: ClassVar[threading.Lock] = threading.Lock()

    @staticmethod
    def _start_key() -> tuple[object, ...]:
        """What a worker keeps from when it started, which a later run must share to take it (and
        the process: a forked child's kept workers are not its own)."""
        return os.getpid(), os.getcwd(), tuple(sorted(worker_environment().items()))

    @classmethod
    def take_kept(cls, module: str, *, orphan: Orphan = "stop") -> WorkerPool:
        """The idle pool of ``module`` a run before kept (:meth:`keep`) when its workers were started
        as they would be now and are all alive and idle, else a new pool (the kept one is closed)."""
        with cls._kept_lock:
            kept = cls._kept.pop(module, None)
        if kept is not None:
            pool, key = kept
            if key == cls._start_key() and pool.orphan == orphan and pool.ready():
                return pool
            pool.close()
        return cls(module, orphan=orphan)

    @classmethod
    def kept(cls, module: str) -> WorkerPool | None:
        """The pool of ``module`` kept for the next run, if any."""
        with cls._kept_lock:
            kept = cls._kept.get(module)
        return kept[0] if kept is not None else None

    def keep(self, prepare: Callable[[WorkerPool], bool] | None = None) -> bool:
        """Keep this pool for the next run of its module in this process when every worker is idle
        and alive and ``prepare(pool)`` (the workers forget the run) succeeds; else close it. One
        pool a module: one kept before is closed. Returns whether it was kept."""
        if self.ready() and (prepare is None or prepare(self)) and self.ready():
            with WorkerPool._kept_lock:
                previous = WorkerPool._kept.get(self.module)
                WorkerPool._kept[self.module] = (self, self._start_key())
            if previous is not None and previous[0] is not self:
                previous[0].close()
            return True
        self.close()
        return False

    @classmethod
    def close_kept(cls) -> None:
        """Close every kept pool (at the interpreter's exit; the kernel would stop their workers anyway)."""
        with cls._kept_lock:
            kept, cls._kept = dict(cls._kept), {}
        for pool, _ in kept.values():
            pool.close()

    def _close(self) -> None:
        try:
            _stop_all(self._running, True)
        finally:
            self._running.clear()



atexit.register(WorkerPool.close_kept)

def _serve(
    queue: JobQueue,
    running: list[_Worker],
    module: str,
    args: list[str],
    workers: int,
    reuse: bool,
    on_start: Callable[[WorkerJob], None] | None,
    on_end: Callable[[WorkerJob, JobEnd], None],
    stop: threading.Event | None,
    orphan: Orphan,
) -> bool:
    """The loop of :func:`run_jobs` over the workers ``running`` (those it starts are added):
    returns when the queue is closed and every job in it has ended (``False``) or ``stop`` is set
    (``True``), leaving the workers to the caller. A job with a :attr:`WorkerJob.slot` waits for
    that worker; the others take the first idle one."""
    wake_r, wake_w = os.pipe()
    os.set_blocking(wake_r, False)
    os.set_blocking(wake_w, False)  # a full pipe already says "look again"
    wake_lock, ended = threading.Lock(), [False]

    def wake() -> None:
        with wake_lock, contextlib.suppress(OSError):
            if not ended[0]:  # never into a closed pipe, whose number may be another file's by now
                os.write(wake_w, b"x")

    waker: threading.Thread | None = None
    if stop is not None:
        def _wake() -> None:
            stop.wait()
            wake()

        waker = threading.Thread(target=_wake, name="pool-stop", daemon=True)
        waker.start()
    queue._serve_with(wake)
    try:
        while True:
            with contextlib.suppress(BlockingIOError):
                os.read(wake_r, 4096)  # whatever woke the loop (a job put, the queue closed, a stop) is looked at below
            if stop is not None and stop.is_set():
                return True
            while True:
                # at most ``workers`` at once: a pool kept from a larger call uses its first ones only
                idle = [
                    k for k, w in enumerate(running[:workers]) if reuse and w.job is None and w.kill_at is None and not w.closed
                ]
                room = len(running) < workers

                def ready(job: WorkerJob, idle: list[int] = idle, room: bool = room) -> bool:
                    if job.slot is None:
                        return bool(idle) or room
                    slot = job.slot % workers
                    return slot in idle or (slot >= len(running) and room)

                job = queue._take(ready)
                if job is None:
                    break
                slot = None if job.slot is None else job.slot % workers
                if slot is None:
                    slot = idle[0] if idle else len(running)
                while len(running) <= slot:  # the slots before it are started too: each keeps its place
                    running.append(_spawn(module, args, job.log_path, orphan))
                worker = running[slot]
                if on_start is not None:
                    on_start(job)
                _send(worker, job, reuse)
            if queue._done() and not any(w.busy or not reuse for w in running):
                return False
            now = time.monotonic()
            wakes = [t for t in (w.next_check(now) for w in running) if t is not None]
            wait([*(w.pipe for w in running if not w.closed), wake_r], timeout=max(0.0, min(wakes) - now) if wakes else None)
            now = time.monotonic()
            for worker in list(running):
                _tend(worker, now, reuse, running, on_end)
    finally:
        queue._serve_with(None)
        if stop is not None and waker is not None:
            stop.set()  # lets the waker leave; it is gone before its pipe is closed
            waker.join()
        with wake_lock:
            ended[0] = True
            os.close(wake_r)
            os.close(wake_w)


def _tend(worker: _Worker, now: float, reuse: bool, running: list[_Worker], on_end: Callable[[WorkerJob, JobEnd], None]) -> None:
    """Take what ``worker`` sent and act on its state: report its job, reap it, stop or kill it."""
    _read(worker)
    job = worker.job
    if job is not None and worker.busy and (b"\n" in worker.received or (worker.closed and worker.received)):
        line, _, rest = bytes(worker.received).partition(b"\n")
        worker.received = bytearray(rest)
        worker.ended = True
        on_end(job, JobEnd(line, now - worker.started, worker.timed_out))
        if reuse and not worker.timed_out:
            worker.job, worker.ended = None, False  # ready for the next job
            return
    exited = worker.process.poll() is not None
    if exited:
        if job is not None and worker.busy:
            worker.ended = True
            on_end(job, JobEnd(None, now - worker.started, worker.timed_out, worker.process.returncode))
        running.remove(worker)
        os.close(worker.pipe)
        if worker.process.stdin is not None:
            with contextlib.suppress(OSError):
                worker.process.stdin.close()
    elif worker.closed:  # leaving: give it the grace period, then kill it
        if worker.kill_at is None:
            worker.kill_at = now + STOP_GRACE_S
        elif now >= worker.kill_at and not worker.killed:
            worker.killed = True
            kill_group(worker.process.pid)
    elif worker.kill_at is not None:
        if now >= worker.kill_at and not worker.killed:
            worker.killed = True
            kill_group(worker.process.pid)
    elif job is not None and worker.busy and job.limit_s is not None and now >= worker.started + job.limit_s:
        worker.timed_out = True
        _stop(worker, now)


def _stop_all(running: list[_Worker], reuse: bool) -> None:
    """Every worker still here leaves: idle reused workers by the end of their stdin, the others
    SIGTERM, then SIGKILL of their group after the grace period."""
    now = time.monotonic()
    for worker in running:
        if reuse and not worker.busy and worker.process.stdin is not None:
            with contextlib.suppress(OSError):
                worker.process.stdin.close()
        elif worker.process.poll() is None:
            _stop(worker, now)
    deadline = now + STOP_GRACE_S
    for worker in running:
        try:
            worker.process.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            kill_group(worker.process.pid)
            worker.process.wait()
        with contextlib.suppress(OSError):
            os.close(worker.pipe)
        if worker.process.stdin is not None:
            with contextlib.suppress(OSError):
                worker.process.stdin.close()


# -- one job at a time, from any thread ------------------------------------------------------------


class WorkerError(RuntimeError):
    """A job handed to a :class:`WorkerExecutor` got no reply: its worker died, timed out or the
    executor was closed first."""


class WorkerExecutor:
    """Reused worker processes (``python -m module``) served by a thread of their own: any thread
    :meth:`submit` s one job's payload and gets a future of its reply. The processes start on the
    first job, at most ``workers`` of them, and stay until :meth:`close` (they leave at once, SIGKILL
    by the kernel, should this process die: ``orphan``). The executor owns its processes and
    thread: nothing of it is global, and a closed one refuses new jobs.

    This is how the package hands CPU-bound native work (CoACD) to other cores without
    ``multiprocessing``, whose ``spawn`` children import the caller's ``__main__`` again.
    """

    def __init__(self, module: str, *, workers: int, orphan: Orphan = "kill", args: list[str] | None = None) -> None:
        self.module, self.workers = module, max(1, workers)
        self._pool = WorkerPool(module, args=args, orphan=orphan)
        self._lock = threading.Lock()
        self._queue: JobQueue | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._futures: dict[str, concurrent.futures.Future[bytes]] = {}
        self._count = 0
        self._closed = False

    @property
    def started(self) -> bool:
        """Whether its serving thread (and so, maybe, its processes) is running."""
        with self._lock:
            return self._thread is not None and self._thread.is_alive()

    def submit(self, payload: bytes, *, limit_s: float | None = None) -> concurrent.futures.Future[bytes]:
        """Hand ``payload`` (one line) to the next idle worker; the future gets its reply line, or a
        :class:`WorkerError` naming why there is none."""
        future: concurrent.futures.Future[bytes] = concurrent.futures.Future()
        future.set_running_or_notify_cancel()  # a job sent to a process is not taken back
        with self._lock:
            if self._closed:
                raise WorkerError(f"the {self.module} workers are closed")
            if self._thread is None or not self._thread.is_alive():
                self._queue = JobQueue()
                self._thread = threading.Thread(
                    target=self._serve, args=(self._queue,), name=f"workers:{self.module}", daemon=True
                )  # fmt: skip
                self._thread.start()
            self._count += 1
            name = f"job-{self._count}"
            self._futures[name] = future
            queue = self._queue
        assert queue is not None
        queue.put([WorkerJob(name, payload, limit_s=limit_s)])
        return future

    def _serve(self, queue: JobQueue) -> None:
        problem = "the workers were closed before it ended"
        try:
            self._pool.run(queue, workers=self.workers, on_end=self._ended, stop=self._stop)
        except BaseException as exc:  # the pool broke: every job still waiting hears why
            problem = f"the worker pool failed: {type(exc).__name__}: {exc}"
        finally:
            self._pool.close()
            with self._lock:
                left, self._futures = self._futures, {}
            for future in left.values():
                if not future.done():
                    future.set_exception(WorkerError(problem))

    def _ended(self, job: WorkerJob, end: JobEnd) -> None:
        with self._lock:
            future = self._futures.pop(job.name, None)
        if future is None or future.done():
            return
        if end.reply is None:
            future.set_exception(WorkerError(end.failure()))
        else:
            future.set_result(end.reply)

    def close(self, *, cancel: bool = False) -> None:
        """No more jobs; the processes leave once the jobs already handed over are done, or at once
        with ``cancel`` (those jobs then fail). Returns when they are gone; safe to call twice."""
        with self._lock:
            self._closed = True
            queue, thread = self._queue, self._thread
        if cancel:
            self._stop.set()
        if queue is not None:
            queue.close()
        if thread is not None and thread is not threading.current_thread():
            thread.join()


def serve_lines(argv: list[str], handle: Callable[[bytes], bytes], *, orphan: Orphan = "kill") -> None:
    """The loop of a worker module's ``main`` (``python -m module REPLY_FD PARENT_PID``, as
    :class:`WorkerPool` starts it): watch the parent, then answer each line of stdin with
    ``handle(line)`` (one line, no newline in it) on the reply pipe until stdin ends; then leave
    at once, without tearing the interpreter down."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the group: the parent stops its workers
    reply_fd, parent_pid = int(argv[1]), int(argv[2])
    os.set_inheritable(reply_fd, False)
    watch_parent(parent_pid, orphan)
    with os.fdopen(reply_fd, "wb") as replies:
        for line in sys.stdin.buffer:
            if line.strip():
                replies.write(handle(line).rstrip(b"\n") + b"\n")
                replies.flush()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)

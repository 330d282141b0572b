"""Worker processes of the package (a batch's jobs, a house run's rooms): how they are started,
how they notice that the process that started them is gone, and how they are stopped.

A worker is a fresh interpreter (``python -m <module>``) in its own process group, so one signal
reaches whatever it started (CoACD's processes) and the caller's script needs no ``__main__``
guard. It gets the environment of :func:`worker_environment` (it imports this very package) and
runs :func:`watch_parent` in a thread: when its parent dies (SIGKILL included), it stops itself,
first gently (SIGTERM: the pipeline writes what it must), then for good.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sysconfig
import threading
import time
from pathlib import Path

__all__ = ["STOP_GRACE_S", "kill_group", "watch_parent", "worker_environment"]

STOP_GRACE_S = 5.0
"""Seconds a worker told to stop (SIGTERM) has to leave before its process group is killed."""
_ORPHAN_POLL_S = 0.2


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


def _watch(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(_ORPHAN_POLL_S)
    with contextlib.suppress(OSError):
        os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(STOP_GRACE_S)
    os._exit(1)


def watch_parent(parent_pid: int) -> None:
    """In a worker: stop this process when ``parent_pid`` is no longer its parent (the parent
    died): SIGTERM to itself at once, and an exit :data:`STOP_GRACE_S` later if still here."""
    threading.Thread(target=_watch, args=(parent_pid,), name="parent-watch", daemon=True).start()


def kill_group(pid: int) -> None:
    """SIGKILL the process ``pid`` and everything in its process group (a worker started with
    ``start_new_session=True``, not reaped yet, so the group id is its own)."""
    with contextlib.suppress(OSError):
        os.killpg(pid, signal.SIGKILL)
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGKILL)

"""Entry point of a house run's worker process: ``python -m scenemosaic.pipeline._house_worker REPLY_FD PARENT_PID``.

Started by the package's worker pool (``scenemosaic._processes.run_jobs``), it runs one job per
line of its stdin (``pipeline/_house.py``: :func:`room_worker`: a room, or one half of a house's
delivery) and writes each reply as one line to the pipe ``REPLY_FD``, so a house uses several cores
without ``multiprocessing`` re-importing the caller's ``__main__``. When the house run
``PARENT_PID`` is gone (even killed), the worker and what it started are killed at once
(``orphan="kill"``: it writes into the house's folder, whose lock died with the run;
``scenemosaic._processes``).
"""

from __future__ import annotations

import os
import signal
import sys

from scenemosaic._processes import watch_parent


def main(argv: list[str]) -> int:
    # Ctrl-C reaches the whole process group: the parent run stops the workers itself, so a
    # worker does not die on its own with a traceback of its own
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    reply_fd, parent_pid = int(argv[1]), int(argv[2])
    os.set_inheritable(reply_fd, False)  # processes a room starts must not hold the pipe open
    watch_parent(parent_pid, "kill")  # before the pipeline's imports: they take seconds
    from scenemosaic._logging import configure_logging
    from scenemosaic.pipeline._house import room_worker
    from scenemosaic.pipeline._plan import room_plan

    configure_logging("warning")
    room_worker(reply_fd, lambda config: room_plan(config, in_house=True))
    # its stdin ended: every job is answered and its files written. The run waits for its workers
    # to leave, and tearing down an interpreter full of meshes and memos costs up to a second
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main(sys.argv))

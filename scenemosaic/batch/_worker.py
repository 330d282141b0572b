"""The worker process of the ``local`` executor: ``python -m scenemosaic.batch._worker FD PARENT_PID LEVEL``.

It reads its :class:`~scenemosaic.batch.JobSpec` as one JSON line from stdin, runs the job, and
writes the :class:`~scenemosaic.batch.JobOutcome` as one JSON line to the pipe ``FD`` (the
package's worker pool, ``scenemosaic._processes.run_jobs``); stdout and stderr are
the job's log file. SIGTERM or SIGINT cancel the pipeline, which writes its report (the run
stopped) before the process leaves without an outcome. When the batch process ``PARENT_PID`` is
gone, the worker stops itself the same way (and for good ``STOP_GRACE_S`` later).

Nothing imports this module; only ``-m`` runs it (the package imports the rest).
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import threading

from scenemosaic._logging import configure_logging
from scenemosaic._processes import watch_parent
from scenemosaic.batch._job import JobOutcome, JobSpec, aexecute_job

__all__ = ["main"]

def main(argv: list[str]) -> int:
    """Run the job given on stdin; the exit status is 0 when an outcome was sent."""
    fd, parent_pid, level = int(argv[0]), int(argv[1]), argv[2]
    os.set_inheritable(fd, False)  # processes this job starts must not hold the pipe open
    watch_parent(parent_pid)
    configure_logging(level, json_lines=True)
    spec = JobSpec.model_validate_json(sys.stdin.buffer.readline())

    stopped = threading.Event()

    async def run() -> JobOutcome | None:
        loop = asyncio.get_running_loop()
        task = asyncio.current_task()
        assert task is not None

        def stop() -> None:
            stopped.set()
            task.cancel()

        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop)
        try:
            outcome = await aexecute_job(spec)
        except asyncio.CancelledError:
            return None
        # a cancel may surface as the task graph's RunCancelledError: a stopped job sends nothing,
        # the batch records why it stopped it
        return None if stopped.is_set() else outcome

    outcome = asyncio.run(run())
    if outcome is None:
        os.close(fd)
        return 1
    with os.fdopen(fd, "wb") as pipe:
        pipe.write(outcome.model_dump_json().encode("utf-8") + b"\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

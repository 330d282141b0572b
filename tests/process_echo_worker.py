"""A worker for the pool's tests (``python -m process_echo_worker REPLY_FD PARENT_PID``): one job a
line on stdin, one reply a line on the pipe: ``<pid> <job>``; ``sleep S`` sleeps first, ``die N``
exits with status N without a reply, ``hang`` ignores SIGTERM and sleeps."""

from __future__ import annotations

import os
import signal
import sys
import time


def main() -> None:
    fd = int(sys.argv[1])
    with os.fdopen(fd, "wb") as replies:
        for raw in sys.stdin.buffer:
            job = raw.decode().strip()
            if job.startswith("die"):
                sys.exit(int(job.split()[1]))
            if job.startswith("sleep"):
                time.sleep(float(job.split()[1]))
            if job == "hang":
                signal.signal(signal.SIGTERM, signal.SIG_IGN)
                time.sleep(600)
            replies.write(f"{os.getpid()} {job}\n".encode())
            replies.flush()


if __name__ == "__main__":
    main()

"""Entry point of a house run's worker process: ``python -m scenemosaic.pipeline._house_worker INPUT OUT BASE_DIR``.

It reads the run's settings from ``OUT/.checkpoint/run.json``, then runs one room per line of its
stdin (``pipeline/_house.py``: :func:`room_worker`), so a house's rooms use several cores without
``multiprocessing`` re-importing the caller's ``__main__``.
"""

from __future__ import annotations

import asyncio
import signal
import sys
from pathlib import Path

from scenemosaic._logging import configure_logging
from scenemosaic.pipeline._house import room_worker


def main(argv: list[str]) -> int:
    # Ctrl-C reaches the whole process group: the parent run stops the workers itself (it kills
    # them), so a worker does not die on its own with a traceback of its own
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    configure_logging("warning")
    input_path, root, base_dir = (Path(a) for a in argv[1:4])
    asyncio.run(room_worker(input_path, root, base_dir))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

"""Finding the worker processes a test's run started (Linux: reads /proc)."""

from __future__ import annotations

from pathlib import Path


def worker_pids(module: str, parent_pid: int) -> list[int]:
    """Live processes running ``python -m module`` whose command line names ``parent_pid`` (the
    package's workers are given their parent's pid), zombies left out."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if module.encode() in argv and str(parent_pid).encode() in argv and state != "Z":
            found.append(int(entry.name))
    return found

"""A notebook's interrupt stops a synchronous ``generate()``: the cell runs in a running event loop
(as in Jupyter), the interrupt reaches the waiting caller as ``KeyboardInterrupt``, and the run
stops there (report ``interrupted``, partial result kept) instead of finishing unseen."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ROOM = ROOT / "data" / "layouts" / "physcene" / "LivingDiningRoom-13536_livingroom.json"

CELL = textwrap.dedent(
    """
    import asyncio, sys
    import scenemosaic as sm
    from scenemosaic.pipeline import _stages

    original = {s.name: s for s in _stages.STAGES}

    async def slow_evolve(run, rec):
        print("EVOLVE-STARTED", flush=True)
        await asyncio.sleep(600)

    from scenemosaic.pipeline import Stage, _plan
    _plan.STAGES = tuple(Stage(s.name, slow_evolve) if s.name == "evolve" else s for s in _stages.STAGES)

    async def cell():  # a notebook cell: a loop runs, and generate() is called synchronously
        sm.generate(sys.argv[1], sys.argv[2], sm.GenerateConfig(variants=2))

    try:
        asyncio.new_event_loop().run_until_complete(cell())
    except KeyboardInterrupt:
        print("INTERRUPTED", flush=True)
    """
)


def _ctrl_c_as_in_a_kernel() -> None:
    """The cell's process starts with Ctrl-C at its default, as a notebook's kernel does: a
    pytest-xdist worker ignores SIGINT, and a child inherits an ignored signal (Python then never
    raises KeyboardInterrupt), so the test passed or hung by which tests its worker ran before."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sends SIGINT")
def test_an_interrupt_stops_a_synchronous_generate_in_a_running_loop(tmp_path: Path) -> None:
    out = tmp_path / "o"
    proc = subprocess.Popen(
        [sys.executable, "-c", CELL, str(ROOM), str(out)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
        env={**os.environ, "MUJOCO_GL": "egl"}, preexec_fn=_ctrl_c_as_in_a_kernel,
    )  # fmt: skip
    assert proc.stdout is not None
    try:
        deadline = time.monotonic() + 120
        for line in proc.stdout:
            if "EVOLVE-STARTED" in line:
                break
            assert time.monotonic() < deadline
        t0 = time.monotonic()
        os.kill(proc.pid, signal.SIGINT)
        rest, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:  # a run that went on: not left behind
            proc.kill()
            proc.wait()
        proc.stdout.close()  # closed here, not by the garbage collector during another test
    assert "INTERRUPTED" in rest
    assert time.monotonic() - t0 < 20, "the run went on after the interrupt"
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "interrupted" and report["failed_stage"] == "evolve"
    assert (out / "base" / "partial.json").is_file()

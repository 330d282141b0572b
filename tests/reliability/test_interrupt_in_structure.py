"""A signal while the structuring agents wait on a model is an interruption, not a failure.

The task graph that runs the agents turns the cancel into a ``RunCancelledError`` (with its
partial results); the run must still end ``interrupted`` with exit 143, the stage named, and
``--resume`` must continue it.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

from cli_helpers import cli_env, report
from fault_server import FaultServer


def test_sigterm_while_the_agents_wait_on_a_hung_model_is_an_interruption(tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    with FaultServer("hang") as server:
        cmd = [
            sys.executable, "-m", "scenemosaic.cli", "generate", str(dining), "--out", str(out),
            "--model", f"openai:fake@{server.base_url}", "--no-vision", "--log-level", "info",
        ]  # fmt: skip
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(tmp_path))
        deadline = time.monotonic() + 120
        while server.requests == 0:  # the structuring agents are waiting on the model now
            assert proc.poll() is None, proc.communicate()[1][-2000:]
            assert time.monotonic() < deadline, "no agent asked the model"
            time.sleep(0.1)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err[-2000:]
    assert time.monotonic() - t0 < 10
    rep = report(out)
    assert rep["status"] == "interrupted" and rep["failed_stage"] == "structure", rep.get("error")
    assert "RunCancelledError" not in (rep.get("error") or "")
    assert '"level": "error"' not in err and "stage_failed" not in err

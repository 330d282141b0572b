"""SIGINT/SIGTERM at each stage: a quick stop, a report, the last good scene, exit 130/143, and --resume.

Each run goes through ``cli_driver.py``, which holds one stage open so the signal lands inside it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_helpers import DINING, HERE, cli_env, report, run_cli

STAGE_SIGNALS = [
    ("import", signal.SIGINT),
    ("assets", signal.SIGTERM),
    ("structure", signal.SIGINT),
    ("stabilize", signal.SIGTERM),
    ("evolve", signal.SIGINT),
    ("validate", signal.SIGINT),
    ("evaluate", signal.SIGTERM),
    ("export", signal.SIGTERM),
]


def _start_held(stage: str, out: Path, source: Path, tmp_path: Path, action: str = "sleep") -> subprocess.Popen[str]:
    cmd = [sys.executable, str(HERE / "cli_driver.py"), stage, action, "--", "generate", str(source), "--out", str(out)]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=cli_env(tmp_path))
    assert proc.stderr is not None
    deadline = time.monotonic() + 120
    for line in proc.stderr:  # wait until the held stage is running
        if f"STAGE-STARTED {stage}" in line:
            return proc
        assert time.monotonic() < deadline, "the held stage never started"
    proc.communicate(timeout=30)
    raise AssertionError(f"the run ended before stage {stage!r}: exit {proc.returncode}")


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory, request: pytest.FixtureRequest) -> bytes:
    """The scene.json of an uninterrupted run of the dining room."""

    tmp = tmp_path_factory.mktemp("reference")
    done = run_cli(["generate", str(DINING), "--out", str(tmp / "out")], tmp)
    assert done.code == 0, done.stderr[-2000:]
    return (tmp / "out" / "base" / "scene.json").read_bytes()


@pytest.mark.parametrize(("stage", "sig"), STAGE_SIGNALS, ids=[f"{s}-{g.name}" for s, g in STAGE_SIGNALS])
def test_a_signal_in_any_stage_stops_quickly_keeps_the_report_and_resumes(
    stage: str, sig: signal.Signals, tmp_path: Path, dining: Path, reference: bytes
) -> None:
    out = tmp_path / "out"
    proc = _start_held(stage, out, dining, tmp_path)
    t0 = time.monotonic()
    os.kill(proc.pid, sig)
    proc.communicate(timeout=30)  # also closes the pipes
    code = proc.returncode
    stopped_in = time.monotonic() - t0
    assert code == (130 if sig == signal.SIGINT else 143)
    assert stopped_in < 10, f"took {stopped_in:.1f} s to stop"
    rep = report(out)
    assert rep["status"] == "interrupted" and rep["failed_stage"] == stage
    assert "resume" in rep["error"]
    if stage != "import":  # the last good scene is kept, marked partial
        assert (out / "base" / "scene.json").is_file()
        assert (out / "base" / "partial.json").is_file()

    resumed = run_cli(["generate", "--resume", str(out)], tmp_path)
    assert resumed.code == 0, resumed.stderr[-2000:]
    final = report(out)
    assert final["status"] in ("ok", "degraded")
    assert not (out / "base" / "partial.json").exists()  # delivered now
    statuses = {s["name"]: s["status"] for s in final["stages"]}
    before = ["import", "assets", "structure", "stabilize", "doors", "evolve", "compose", "validate", "evaluate", "export"]
    for name in before[: before.index(stage)]:
        # not run again (compose: no --variants; doors: the dining room has none)
        assert statuses[name] == ("skipped" if name in ("compose", "doors") else "reused"), statuses
    assert (out / "base" / "scene.json").read_bytes() == reference


def test_a_second_signal_still_leaves_the_report(tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    proc = _start_held("stabilize", out, dining, tmp_path)
    os.kill(proc.pid, signal.SIGINT)
    os.kill(proc.pid, signal.SIGINT)
    proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert report(out)["status"] == "interrupted"


def test_one_signal_does_not_wait_for_a_stages_worker_thread(tmp_path: Path, dining: Path) -> None:
    """A stage busy in a worker thread (a long compose or export) cannot be interrupted there: the
    run writes its report and leaves at once, without waiting for the thread."""
    out = tmp_path / "out"
    proc = _start_held("compose", out, dining, tmp_path, action="block")
    t0 = time.monotonic()
    os.kill(proc.pid, signal.SIGTERM)
    proc.communicate(timeout=30)
    assert proc.returncode == 143
    assert time.monotonic() - t0 < 10
    assert report(out)["status"] == "interrupted" and report(out)["failed_stage"] == "compose"


def test_resume_refuses_a_folder_without_a_run(tmp_path: Path) -> None:
    done = run_cli(["generate", "--resume", str(tmp_path / "nothing")], tmp_path)
    assert done.code == 2 and "no run to resume" in done.stderr

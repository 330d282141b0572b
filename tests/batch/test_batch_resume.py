"""A batch killed midway keeps what finished; running it again skips that and does the rest."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from batch_helpers import BEDROOM_2, write_manifest
from process_helpers import worker_pids

from scenemosaic.batch import SUMMARY_FILE, BatchSummary, run_batch


def _summary(out: Path) -> BatchSummary | None:
    try:
        return BatchSummary.model_validate_json((out / SUMMARY_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _workers_of(batch_pid: int) -> list[int]:
    """Local batch workers whose batch process is ``batch_pid``."""
    return worker_pids("scenemosaic.batch._worker", batch_pid)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc to find the orphaned worker")
def test_killed_batch_resumes(tmp_path: Path) -> None:
    manifest = write_manifest(
        tmp_path / "jobs.jsonl",
        [{"input": BEDROOM_2, "evolve": False, "seed": seed, "id": f"bed-{seed}"} for seed in range(3)],
    )
    out = tmp_path / "out"
    batch = subprocess.Popen(
        [sys.executable, "-m", "scenemosaic.cli", "batch", str(manifest), "--out", str(out), "--workers", "1"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while True:
            summary = _summary(out)
            # the first job is done and the second under way, its worker started (the summary
            # says "running" a moment before the worker process shows in /proc): kill the batch now
            if summary is not None and [j.status for j in summary.jobs[:2]] == ["ok", "running"] and _workers_of(batch.pid):
                break
            assert batch.poll() is None, "the batch ended before the first job finished"
            assert time.monotonic() < deadline, "the first job did not finish with the second's worker running in time"
            time.sleep(0.02)
        os.kill(batch.pid, signal.SIGKILL)
    finally:
        if batch.poll() is None:
            batch.kill()
        batch.wait()

    # the summary on disk keeps what finished before the kill
    stopped = _summary(out)
    assert stopped is not None and not stopped.finished
    assert stopped.jobs[0].status == "ok"
    assert [j.status for j in stopped.jobs[1:]] in (["running", "pending"], ["ok", "pending"])

    # the orphaned worker notices its batch is gone and stops by itself
    deadline = time.monotonic() + 15
    while _workers_of(batch.pid):
        assert time.monotonic() < deadline, "an orphaned worker kept running"
        time.sleep(0.1)

    again = run_batch(manifest, out, workers=1)
    statuses = [j.status for j in again.jobs]
    assert statuses[0] == "skipped"
    assert set(statuses[1:]) <= {"ok", "skipped"} and "ok" in statuses, again.model_dump_json(indent=1)
    assert again.finished and again.ok
    assert all((out / j.id / "base" / "scene.json").is_file() for j in again.jobs)

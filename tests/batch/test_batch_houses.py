"""House jobs in a batch: a finished house is skipped when the batch runs again, and a batch
worker killed while its house's rooms run leaves no room worker behind."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from batch_helpers import write_manifest
from process_helpers import worker_pids

from scenemosaic.batch import SUMMARY_FILE, run_batch

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"
TWO_ROOMS = HOUSES / "procthor10k_house3703_2room.json"
FOUR_ROOMS = HOUSES / "procthor_4room.json"
ORPHAN_BOUND_S = 2.0
"""No room worker is alive this long after its batch worker was killed (issue 41)."""


def test_a_finished_house_job_is_skipped(tmp_path: Path) -> None:
    """The skip test finds the delivered house (``base/house_scene.json``), not ``base/scene.json``."""
    manifest = write_manifest(tmp_path / "jobs.jsonl", [{"input": TWO_ROOMS, "id": "house", "evolve": False}])
    out = tmp_path / "out"
    first = run_batch(manifest, out, workers=1)
    assert [j.status for j in first.jobs] == ["ok"], first.model_dump_json(indent=1)
    assert not (out / "house" / "base" / "scene.json").exists()  # a house delivers house_scene.json
    delivered = (out / "house" / "report.json").read_bytes()
    again = run_batch(manifest, out, workers=1)
    assert [j.status for j in again.jobs] == ["skipped"] and again.ok
    assert (out / "house" / "report.json").read_bytes() == delivered  # not run again


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc to find the workers")
def test_room_workers_die_with_a_killed_batch_worker(tmp_path: Path) -> None:
    manifest = write_manifest(tmp_path / "jobs.jsonl", [{"input": FOUR_ROOMS, "id": "house", "room_workers": 2}])
    out = tmp_path / "out"
    batch = subprocess.Popen(
        [sys.executable, "-m", "scenemosaic.cli", "batch", str(manifest), "--out", str(out), "--workers", "1"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env={**os.environ, "MUJOCO_GL": "egl"},
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        rooms: list[int] = []
        job_worker = 0
        while len(rooms) < 2:
            assert batch.poll() is None and time.monotonic() < deadline, "the house job never started its two room workers"
            job_workers = worker_pids("scenemosaic.batch._worker", batch.pid)
            job_worker = job_workers[0] if job_workers else 0
            rooms = worker_pids("scenemosaic.pipeline._house_worker", job_worker) if job_worker else []
            time.sleep(0.1)
        time.sleep(1.0)  # let them take a room each
        os.kill(job_worker, signal.SIGKILL)
        gone_by = time.monotonic() + ORPHAN_BOUND_S
        while time.monotonic() < gone_by and worker_pids("scenemosaic.pipeline._house_worker", job_worker):
            time.sleep(0.05)
        assert not worker_pids("scenemosaic.pipeline._house_worker", job_worker), "room workers outlived their batch worker by 2 s"
        assert batch.wait(timeout=60) == 1  # the job failed; the batch went on to its end
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()
    summary = json.loads((out / SUMMARY_FILE).read_text(encoding="utf-8"))
    [job] = summary["jobs"]
    assert job["status"] == "failed" and "SIGKILL" in job["error"]

"""Batches over shipped PhyScene rooms: the local executor, the Ray executor, and a re-run that skips."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from batch_helpers import BEDROOM, BEDROOM_2, DINING, scene_files, write_manifest

from scenemosaic.batch import SUMMARY_FILE, BatchSummary, JobRecord, run_batch
from scenemosaic.pipeline import REPORT_FILE

JOBS = [
    {"input": DINING, "variants": 2, "id": "dining"},
    {"input": BEDROOM, "variants": 1, "seed": 3},
    {"input": BEDROOM_2, "evolve": False},
]


@pytest.fixture(scope="module")
def manifest(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_manifest(tmp_path_factory.mktemp("manifest") / "rooms.jsonl", JOBS)


@pytest.fixture(scope="module")
def local_run(manifest: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, BatchSummary, list[JobRecord]]:
    out = tmp_path_factory.mktemp("local")
    events: list[JobRecord] = []
    summary = run_batch(manifest, out, executor="local", workers=2, timeout_s=240, on_progress=events.append)
    return out, summary, events


def test_local_executor_runs_every_job(local_run: tuple[Path, BatchSummary, list[JobRecord]]) -> None:
    out, summary, events = local_run
    assert [(j.id, j.status) for j in summary.jobs] == [
        ("dining", "ok"),
        (BEDROOM.stem, "ok"),
        (BEDROOM_2.stem, "ok"),
    ], summary.model_dump_json(indent=1)
    assert [j.variants_written for j in summary.jobs] == [2, 1, 0]
    assert summary.scenes_written == 3 + 2 + 1 and summary.counts == {"ok": 3}
    assert summary.finished and summary.ok and summary.workers == 2
    assert all(j.wall_s > 0 and j.error is None for j in summary.jobs)
    # the summary on disk is the returned one
    assert BatchSummary.model_validate_json((out / SUMMARY_FILE).read_text()) == summary
    # each job: the generate layout in OUT/<id>, its report, its log
    for job in summary.jobs:
        folder = out / job.id
        assert json.loads((folder / REPORT_FILE).read_text())["status"] == "ok"
        assert (folder / "base" / "scene.json").is_file() and (folder / "base" / "scene.xml").is_file()
        assert (out / ".batch" / "logs" / f"{job.id}.log").is_file()
    assert sorted(scene_files(out)) == [
        f"{BEDROOM_2.stem}/base/scene.json",
        f"{BEDROOM.stem}/base/scene.json",
        f"{BEDROOM.stem}/variant_1/scene.json",
        "dining/base/scene.json",
        "dining/variant_1/scene.json",
        "dining/variant_2/scene.json",
    ]
    # progress: each job reported running, then its end
    assert sorted((e.id, e.status) for e in events) == sorted(
        [(j.id, "running") for j in summary.jobs] + [(j.id, "ok") for j in summary.jobs]
    )


def test_ray_executor_gives_byte_identical_scenes(
    manifest: Path, local_run: tuple[Path, BatchSummary, list[JobRecord]], tmp_path: Path
) -> None:
    import ray  # the [ray] extra is part of the dev install
    local_out, _, _ = local_run
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        summary = run_batch(manifest, tmp_path / "ray", executor="ray", workers=2, timeout_s=240)
        assert ray.is_initialized()  # the caller's Ray is left running
    finally:
        ray.shutdown()
    assert [j.status for j in summary.jobs] == ["ok", "ok", "ok"], summary.model_dump_json(indent=1)
    assert summary.executor == "ray"
    local_files, ray_files = scene_files(local_out), scene_files(tmp_path / "ray")
    assert len(local_files) == 6
    assert ray_files.keys() == local_files.keys()
    differing = [name for name in local_files if local_files[name] != ray_files[name]]
    assert not differing, f"scene files differ between executors: {differing}"


def test_a_second_run_skips_finished_jobs(manifest: Path, local_run: tuple[Path, BatchSummary, list[JobRecord]]) -> None:
    out, first, _ = local_run
    before = scene_files(out)
    events: list[JobRecord] = []
    summary = run_batch(manifest, out, workers=2, on_progress=events.append)
    assert [j.status for j in summary.jobs] == ["skipped"] * 3
    assert [j.report_status for j in summary.jobs] == ["ok"] * 3
    assert [j.variants_written for j in summary.jobs] == [2, 1, 0] and summary.scenes_written == first.scenes_written
    assert summary.ok and summary.finished
    assert [(e.id, e.status) for e in events] == [(j.id, "skipped") for j in summary.jobs]
    assert scene_files(out) == before

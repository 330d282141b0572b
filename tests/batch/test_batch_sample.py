"""Issue 26, item 7: the sample manifest the docs use loads as it ships, and a re-run with every
job finished starts no Ray."""

from __future__ import annotations

from pathlib import Path

import pytest
import ray
from batch_helpers import BEDROOM_2, write_manifest

from scenemosaic.batch import load_manifest, run_batch

SAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rooms.jsonl"


def test_the_sample_manifest_loads_with_every_input_present() -> None:
    jobs = load_manifest(SAMPLE)
    assert [job.id for job in jobs] == ["dining", "bedroom", "procthor-room-5"]
    assert all(Path(job.label).is_file() for job in jobs)
    assert "examples/rooms.jsonl" in (SAMPLE.parents[1] / "docs" / "batch.md").read_text(encoding="utf-8")


def test_a_ray_batch_with_every_job_done_does_not_start_ray(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    manifest = write_manifest(tmp_path / "rooms.jsonl", [{"input": BEDROOM_2, "evolve": False, "id": "bedroom"}])
    assert run_batch(manifest, tmp_path / "out", workers=1, timeout_s=300).job("bedroom").status == "ok"

    def no_ray(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("Ray was started for a batch with nothing to run")

    monkeypatch.setattr(ray, "init", no_ray)
    again = run_batch(manifest, tmp_path / "out", executor="ray", workers=2)
    assert again.job("bedroom").status == "skipped" and not ray.is_initialized()

"""A failing or timed-out job is recorded and stopped; the other jobs finish."""

from __future__ import annotations

import json
from pathlib import Path

from batch_helpers import BEDROOM_2, DINING, write_manifest
from typer.testing import CliRunner

from scenemosaic.batch import SUMMARY_FILE, BatchSummary, run_batch
from scenemosaic.cli import app


def test_corrupt_input_fails_and_a_slow_job_times_out_while_the_others_finish(tmp_path: Path) -> None:
    corrupt = tmp_path / "rooms" / "broken.json"
    corrupt.parent.mkdir()
    corrupt.write_text('{"ThreedFront": {"objects": [', encoding="utf-8")
    manifest = write_manifest(
        tmp_path / "jobs.jsonl",
        [
            {"input": "rooms/broken.json"},
            {"input": BEDROOM_2, "evolve": False, "id": "good"},
            {"input": DINING, "variants": 2, "id": "slow", "timeout_s": 0.3},
        ],
    )
    out = tmp_path / "out"
    summary = run_batch(manifest, out, workers=2, timeout_s=240)
    broken, good, slow = summary.jobs
    assert (broken.id, broken.status) == ("broken", "failed")
    assert broken.error is not None and "broken.json" in broken.error, broken.error
    assert broken.report_status == "failed"  # generate wrote its report
    assert broken.scenes_written == 0
    assert (good.status, good.scenes_written) == ("ok", 1)
    assert (good.error, good.report_status) == (None, "ok")
    assert slow.status == "timeout" and slow.error == "stopped after its time-out of 0.3 s"
    assert slow.wall_s < 10
    assert summary.finished and not summary.ok
    assert summary.counts == {"failed": 1, "ok": 1, "timeout": 1}
    on_disk = json.loads((out / SUMMARY_FILE).read_text())
    assert [j["status"] for j in on_disk["jobs"]] == ["failed", "ok", "timeout"]
    assert on_disk["jobs"][0]["error"] == broken.error


def test_cli_timeout_is_recorded_and_exits_1(tmp_path: Path) -> None:
    manifest = write_manifest(tmp_path / "jobs.jsonl", [{"input": DINING, "variants": 1}])
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["batch", str(manifest), "--out", str(out), "--workers", "1", "--timeout", "0.5"])
    assert result.exit_code == 1, result.output
    summary = BatchSummary.model_validate_json((out / SUMMARY_FILE).read_text())
    (job,) = summary.jobs
    assert job.status == "timeout" and job.id == DINING.stem
    assert "timeout" in result.output and DINING.stem in result.output

"""A job run again pays nothing for the model requests an earlier attempt made: the batch's
reply cache (``OUT/.batch/replies``) answers them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from batch_helpers import write_manifest

from scenemosaic.batch import BATCH_DIR, REPLY_CACHE, run_batch

REPO = Path(__file__).resolve().parents[2]
CASSETTE = REPO / "tests/fixtures/cassettes/real_qwen05b_LivingDiningRoom-8714_livingroom.cassette.json"
ROOM = REPO / "data/layouts/physcene/LivingDiningRoom-8714_livingroom.json"


def _requests(report: dict[str, object]) -> int:
    stages = report["stages"]
    assert isinstance(stages, list)
    return sum(int(s.get("detail", {}).get("usage", {}).get("requests", 0)) for s in stages)


def test_a_job_run_again_is_answered_from_the_reply_cache(tmp_path: Path) -> None:
    job = {"input": ROOM, "id": "room", "model": f"replay:{CASSETTE}", "vision": False, "evolve": False}
    manifest = write_manifest(tmp_path / "jobs.jsonl", [job])
    out = tmp_path / "out"
    first = run_batch(manifest, out)
    assert first.job("room").status in ("ok", "degraded"), first.job("room")
    paid = _requests(json.loads((out / "room" / "report.json").read_text(encoding="utf-8")))
    assert paid > 0
    cached = sorted((out / BATCH_DIR / REPLY_CACHE).rglob("*.json"))
    assert cached  # only the valid replies: the cassette's broken ones are asked again
    before = (out / "room" / "base" / "scene.json").read_bytes()
    shutil.rmtree(out / "room")  # the job is lost (a disk cleaned, a failed node): it runs again
    second = run_batch(manifest, out)
    assert second.job("room").status == first.job("room").status
    again = _requests(json.loads((out / "room" / "report.json").read_text(encoding="utf-8")))
    assert again < paid
    report = json.loads((out / "room" / "report.json").read_text(encoding="utf-8"))
    hits = sum(int(s.get("detail", {}).get("usage", {}).get("cached", 0)) for s in report["stages"])
    assert hits >= len(cached)  # every stored reply answered again (one question may come twice)
    assert (out / "room" / "base" / "scene.json").read_bytes() == before

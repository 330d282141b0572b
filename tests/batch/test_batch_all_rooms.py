"""Every shipped PhyScene room, with variants, through both executors: the same scene files, byte
for byte, from two local worker processes and from Ray tasks."""

from __future__ import annotations

from pathlib import Path

import pytest
import ray
from batch_helpers import ROOMS, scene_files, write_manifest

from scenemosaic.batch import run_batch


@pytest.mark.long  # about a minute on 2 cores: every room twice; `make test-houses` runs it
def test_local_and_ray_write_identical_scenes_for_every_room(tmp_path: Path) -> None:
    rooms = sorted(ROOMS.glob("*.json"))
    assert len(rooms) == 7
    manifest = write_manifest(tmp_path / "rooms.jsonl", [{"input": r, "variants": 2, "seed": 5} for r in rooms])
    local = run_batch(manifest, tmp_path / "local", executor="local", workers=2, timeout_s=300)
    assert local.ok and local.counts == {"ok": 7}, local.model_dump_json(indent=1)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = run_batch(manifest, tmp_path / "ray", executor="ray", workers=2, timeout_s=300)
    finally:
        ray.shutdown()
    assert remote.ok and remote.counts == {"ok": 7}
    a, b = scene_files(tmp_path / "local"), scene_files(tmp_path / "ray")
    assert len(a) == 7 * 3 and a.keys() == b.keys()
    assert [name for name in a if a[name] != b[name]] == []

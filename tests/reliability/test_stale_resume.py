"""``--resume`` re-checks: a checkpoint whose input changed since the stop is refused with exit 2
(the fix named), and ``--restart-stale`` starts the run over instead of bringing back old objects."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.pipeline import GenerateConfig, generate


class _Stop(Exception):
    """Raised by the stage callback: the run stops as a killed run would, its checkpoint kept."""


def _box(oid: str, x: float) -> dict[str, Any]:
    return {
        "id": oid,
        "category": "box",
        "asset": {"kind": "box", "extents": [0.5, 0.5, 0.5]},
        "pose": {"position": [x, 1.5, 0.0], "quaternion": [1, 0, 0, 0], "scale": [1, 1, 1]},
    }


def _write(path: Path, *objects: dict[str, Any]) -> None:
    room = {"id": "room", "floor": [[0, 0], [4, 0], [4, 4], [0, 4]], "ceiling_height": 2.6}
    path.write_text(json.dumps({"id": "stale", "room": room, "objects": list(objects)}), encoding="utf-8")


def test_a_stale_checkpoint_is_refused_and_restarted_on_request(tmp_path: Path) -> None:
    source = tmp_path / "in" / "scene.json"
    source.parent.mkdir()
    _write(source, _box("a", 1.0), _box("b", 3.0))
    out = tmp_path / "out"

    def stop(name: str, status: str) -> None:
        if name == "stabilize" and status == "started":
            raise _Stop

    with pytest.raises(_Stop):
        generate(source, out, GenerateConfig(evolve=False), on_stage=stop)
    _write(source, _box("a", 1.0))  # an object removed since the stop

    refused = CliRunner().invoke(app, ["generate", "--resume", str(out)])
    assert refused.exit_code == 2, refused.output
    flat = " ".join(refused.output.split())
    assert "changed since the stopped run" in flat and "--restart-stale" in flat

    restarted = CliRunner().invoke(app, ["generate", "--resume", str(out), "--restart-stale"])
    assert restarted.exit_code == 0, restarted.output
    delivered = json.loads((out / "base" / "scene.json").read_text())
    assert [o["id"] for o in delivered["objects"]] == ["a"]  # the removed object does not come back
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "ok" and all(s["status"] != "reused" for s in report["stages"])

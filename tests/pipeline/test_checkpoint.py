"""The run's state goes stage to stage in memory; the checkpoint is the only thing ``--resume`` reads."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from scenemosaic.exceptions import UsageError
from scenemosaic.pipeline import GenerateConfig, generate
from scenemosaic.scene import RunFolder

ROOM = Path(__file__).resolve().parents[2] / "data/layouts/physcene/DiningRoom-19325_diningroom.json"


class _Stop(Exception):
    """Raised by the stage callback to stop a run between two stages."""


def _stop_before(stage: str):  # type: ignore[no-untyped-def]
    def on_stage(name: str, status: str) -> None:
        if name == stage and status == "started":
            raise _Stop(stage)

    return on_stage


def test_compose_resumes_from_the_checkpoint_not_from_the_evolve_files(tmp_path: Path) -> None:
    room = tmp_path / "room.json"
    shutil.copy(ROOM, room)
    whole = generate(room, tmp_path / "whole", GenerateConfig(variants=2))
    out = RunFolder(tmp_path / "stopped")
    with pytest.raises(_Stop):
        generate(room, out.root, GenerateConfig(variants=2), on_stage=_stop_before("compose"))
    shutil.rmtree(out.evolve)  # an output, not state: compose must not need it
    resumed = generate(room, out.root, GenerateConfig(variants=2, resume=True))
    statuses = {s["name"]: s["status"] for s in resumed.report["stages"]}
    assert statuses["evolve"] == "reused" and statuses["compose"] == "done"
    assert resumed.report["variants_written"] == whole.report["variants_written"] == 2
    for name, folder in RunFolder(whole.out_dir).scenes():
        assert (out.root / name / "scene.json").read_bytes() == (folder / "scene.json").read_bytes(), name


def test_resume_refuses_an_input_that_changed(tmp_path: Path) -> None:
    room = tmp_path / "room.json"
    shutil.copy(ROOM, room)
    with pytest.raises(_Stop):
        generate(room, tmp_path / "out", GenerateConfig(), on_stage=_stop_before("stabilize"))
    room.write_text(room.read_text().replace("}", " }", 1))  # the same path, other bytes
    with pytest.raises(UsageError, match="changed since the stopped run"):
        generate(room, tmp_path / "out", GenerateConfig(resume=True))

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


def test_resume_refuses_a_checkpoint_naming_a_mesh_outside_the_input(tmp_path: Path) -> None:
    """A checkpoint is a file on disk like any input: one whose scene names a mesh outside the
    input's folder (tampered with) is refused, and nothing is copied from there."""
    from scenemosaic.dag import FileRunStore
    from scenemosaic.pipeline import PipelineRun, RunSetup
    from scenemosaic.pipeline._checkpoint import input_digest, load_checkpoint, save_checkpoint
    from scenemosaic.scene import AssetRef

    room = tmp_path / "in" / "room.json"
    room.parent.mkdir()
    shutil.copy(ROOM, room)
    outside = tmp_path / "secret.obj"
    outside.write_text("v 0 0 0\n", encoding="utf-8")
    out = RunFolder(tmp_path / "out")
    with pytest.raises(_Stop):
        generate(room, out.root, GenerateConfig(), on_stage=_stop_before("structure"))
    config = GenerateConfig(resume=True)
    run = PipelineRun(RunSetup(input_path=room, folder=out, config=config, base_dir=room.parent))
    run.store = FileRunStore(out.checkpoint)
    digest = input_digest(room, config)
    assert load_checkpoint(run, digest) and run.scene is not None  # the honest checkpoint resumes
    first = run.scene.objects[0]
    first.asset = AssetRef(kind="mesh", uri=str(outside), extents=first.asset.extents)
    save_checkpoint(run, digest)  # tampered: the scene now names a file outside the input's folder
    with pytest.raises(UsageError, match="names a mesh outside the input's folder"):
        generate(room, out.root, config)
    assert not any(p.name == "secret.obj" for p in out.root.rglob("*"))

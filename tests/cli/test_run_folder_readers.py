"""Every reader takes the folder ``generate`` wrote: its base by default, a variant by name or number."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from PIL import Image
from typer.testing import CliRunner

from scenemosaic import GenerateConfig, generate, load_scene
from scenemosaic.cli import app
from scenemosaic.exceptions import UsageError
from scenemosaic.exchange import read_scene
from scenemosaic.scene import RunFolder

ROOM = Path(__file__).resolve().parents[2] / "data/layouts/physcene/DiningRoom-19325_diningroom.json"
runner = CliRunner()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("runs") / "dining"
    result = generate(ROOM, out, GenerateConfig(variants=2))
    assert result.report["variants_written"] == 2
    return out


def test_load_scene_reads_the_base_or_a_variant_of_a_run(run_dir: Path) -> None:
    folder = RunFolder(run_dir)
    assert RunFolder.is_run(run_dir) and [name for name, _ in folder.scenes()] == ["base", "variant_1", "variant_2"]
    base = load_scene(run_dir)
    assert base.model_dump() == read_scene(folder.base).model_dump()
    second = load_scene(run_dir, variant=2)
    assert second.model_dump() == read_scene(folder.variant(2)).model_dump()
    assert load_scene(run_dir, variant="variant_1").model_dump() == read_scene(folder.variant(1)).model_dump()
    assert second.model_dump() != base.model_dump()  # a variant is not the base
    with pytest.raises(UsageError, match="no variant_7/ scene"):
        load_scene(run_dir, variant=7)
    with pytest.raises(UsageError, match="needs a generate output folder"):
        load_scene(ROOM, variant=1)


def test_inspect_shows_the_tree_of_the_base_or_a_variant(run_dir: Path) -> None:
    done = runner.invoke(app, ["inspect", str(run_dir), "--json"])
    assert done.exit_code == 0, done.output
    units = {u["anchor_id"] for u in json.loads(done.output)["units"]}
    assert "floor" in units
    tree = runner.invoke(app, ["inspect", str(run_dir), "--variant", "2"])
    assert tree.exit_code == 0, tree.output
    assert "floor" in tree.output
    missing = runner.invoke(app, ["inspect", str(run_dir), "--variant", "9"])
    assert missing.exit_code == 2 and "variant_9" in missing.output


def test_render_draws_a_run_folder(run_dir: Path, tmp_path: Path) -> None:
    for args, name in (([], "base.png"), (["--variant", "variant_1"], "v1.png")):
        done = runner.invoke(app, ["render", str(run_dir), "--out", str(tmp_path / name), "--size", "128", *args])
        assert done.exit_code == 0, done.output
        with Image.open(tmp_path / name) as png:
            assert png.size == (128, 128)
    assert (tmp_path / "base.png").read_bytes() != (tmp_path / "v1.png").read_bytes()


def test_edit_takes_a_run_folder(run_dir: Path, tmp_path: Path) -> None:
    base = load_scene(run_dir)
    chair = next(o for o in base.objects if "chair" in o.category)
    done = runner.invoke(
        app, ["edit", str(run_dir), f"{chair.id}.center.u = {chair.id}.center.u + 0.05", "--out", str(tmp_path / "e")]
    )
    assert done.exit_code == 0, done.output
    edited = read_scene(tmp_path / "e")
    moved = edited.get(chair.id).pose.position
    assert abs(abs(moved[0] - chair.pose.position[0]) + abs(moved[1] - chair.pose.position[1]) - 0.05) < 1e-6

"""``scenemosaic export | render | edit`` on a generated room and its variant."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from scenemosaic import GenerateConfig, generate
from scenemosaic.cli import app
from scenemosaic.exchange import read_scene
from scenemosaic.render import render_topdown

ROOM = Path(__file__).resolve().parents[2] / "data/layouts/physcene/LivingDiningRoom-8714_livingroom.json"
runner = CliRunner()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli") / "room"
    result = generate(ROOM, out, GenerateConfig(variants=1))
    assert result.report["variants_written"] == 1
    return out


def test_export_writes_every_scene_of_a_run(run_dir: Path, tmp_path: Path) -> None:
    done = runner.invoke(app, ["export", str(run_dir), "--format", "mjcf", "--out", str(tmp_path / "mj")])
    assert done.exit_code == 0, done.output
    for name in ("base", "variant_1"):
        model = mujoco.MjModel.from_xml_path(str(tmp_path / "mj" / name / "scene.xml"))
        assert model.nbody > len(read_scene(run_dir / name).objects)
    one = runner.invoke(app, ["export", str(run_dir / "variant_1"), "-f", "glb", "-o", str(tmp_path / "g")])
    assert one.exit_code == 0, one.output
    glb = trimesh.load(tmp_path / "g" / "scene.glb")
    assert {o.id for o in read_scene(run_dir / "variant_1").objects} <= set(glb.graph.nodes)


def test_export_names_the_formats_it_knows(run_dir: Path, tmp_path: Path) -> None:
    done = runner.invoke(app, ["export", str(run_dir / "base"), "--format", "obj", "--out", str(tmp_path / "x")])
    assert done.exit_code == 2
    assert "unknown output format 'obj'" in done.output and "mjcf" in done.output
    assert not (tmp_path / "x").exists()


def test_render_draws_the_plan_or_one_unit(run_dir: Path, tmp_path: Path) -> None:
    plan = tmp_path / "plan.png"
    assert runner.invoke(app, ["render", str(run_dir / "base"), "--out", str(plan)]).exit_code == 0
    base = read_scene(run_dir / "base")
    assert plan.read_bytes() == render_topdown(base, base_dir=run_dir / "base")
    floor = tmp_path / "floor.png"
    done = runner.invoke(app, ["render", str(run_dir / "base"), "--unit", "floor", "--size", "512", "--out", str(floor)])
    assert done.exit_code == 0, done.output
    assert floor.read_bytes().startswith(b"\x89PNG") and floor.read_bytes() != plan.read_bytes()
    bad = runner.invoke(app, ["render", str(run_dir / "base"), "--unit", "sofa_9", "--out", str(tmp_path / "n.png")])
    assert bad.exit_code == 2 and "no unit anchored at 'sofa_9'" in bad.output and "floor" in bad.output


def test_edit_moves_one_object_and_writes_the_scene(run_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "edited"
    done = runner.invoke(app, ["edit", str(run_dir / "base"), "armchair_0.center.u = armchair_0.center.u + 0.25", "--out", str(out)])
    assert done.exit_code == 0, done.output
    before, after = read_scene(run_dir / "base"), read_scene(out)
    moved = np.subtract(after.get("armchair_0").pose.position, before.get("armchair_0").pose.position)
    assert np.allclose(moved, [0.25, 0.0, 0.0], atol=1e-6)
    for o in before.objects:
        if o.id != "armchair_0":
            assert np.allclose(after.get(o.id).pose.position, o.pose.position, atol=1e-9), o.id
    assert (out / "scene.xml").is_file() and (out / "topdown.png").is_file()


def test_edit_refuses_a_hostile_expression_and_writes_nothing(run_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "nope"
    done = runner.invoke(app, ["edit", str(run_dir / "base"), "armchair_0.center.u = __import__('os').getpid()", "--out", str(out)])
    assert done.exit_code == 2 and "error" in done.output
    assert not out.exists()


def test_edit_beyond_the_scene_limits_is_a_refused_expression(run_dir: Path, tmp_path: Path) -> None:
    """A value inside the expression range that puts an object beyond the scene's coordinate
    limits is an ExpressionError (exit 2, one clear line), not a leaked validation error."""
    from scenemosaic.exceptions import ExpressionError

    out = tmp_path / "far"
    done = runner.invoke(app, ["edit", str(run_dir / "base"), "armchair_0.center.u = 5000", "--out", str(out)])
    assert done.exit_code == 2, done.output
    assert "beyond its limits" in " ".join(done.output.split()) and "Traceback" not in done.output
    assert not out.exists()
    with pytest.raises(ExpressionError, match="beyond its limits"):
        read_scene(run_dir / "base").edit("armchair_0.center.u = 5000")


def test_brackets_in_paths_are_printed_not_read_as_markup(run_dir: Path, tmp_path: Path) -> None:
    """Rich markup in a path (``[/x]``) must not crash the CLI: the path is printed as it is."""
    odd = tmp_path / "o[/x]"
    done = runner.invoke(app, ["demo", "--out", str(odd)])
    assert done.exit_code == 0, done.output
    assert "[/x]" in done.output and (odd / "base" / "scene.json").is_file()
    missing = runner.invoke(app, ["inspect", str(tmp_path / "no[/such]")])
    assert missing.exit_code == 2 and "[/such]" in missing.output


def test_an_output_folder_that_cannot_be_written_is_a_usage_error(tmp_path: Path) -> None:
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder", encoding="utf-8")
    done = runner.invoke(app, ["generate", str(ROOM), "--out", str(a_file / "out")])
    assert done.exit_code == 2, done.output
    assert "cannot write the output folder" in " ".join(done.output.split()) and "Traceback" not in done.output
    assert a_file.read_text(encoding="utf-8") == "not a folder"


def test_an_output_folder_holding_the_input_is_refused_and_the_input_kept(run_dir: Path, tmp_path: Path) -> None:
    """``generate OUT/base --out OUT --overwrite`` would delete its own input before reading it."""
    before = (run_dir / "base" / "scene.json").read_bytes()
    done = runner.invoke(app, ["generate", str(run_dir / "base"), "--out", str(run_dir), "--overwrite"])
    assert done.exit_code == 2 and "lies in what the run writes" in " ".join(done.output.split()), done.output
    assert (run_dir / "base" / "scene.json").read_bytes() == before
    inner = runner.invoke(app, ["generate", str(run_dir / "base"), "--out", str(run_dir / "base" / "again")])
    assert inner.exit_code == 2 and "inside the input folder" in " ".join(inner.output.split()), inner.output
    assert not (run_dir / "base" / "again").exists()


def test_a_second_run_on_a_folder_being_written_is_refused(tmp_path: Path) -> None:
    """A run holds ``OUT/.lock``; another run on the same folder is refused at once and removes
    nothing of the first's."""
    import fcntl

    from scenemosaic.scene import RunFolder

    out = RunFolder(tmp_path / "out")
    out.root.mkdir()
    (out.root / "base").mkdir()
    (out.root / "base" / "keep.txt").write_text("the first run's", encoding="utf-8")
    with out.lock.open("a", encoding="utf-8") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as the first run holds it
        done = runner.invoke(app, ["generate", str(ROOM), "--out", str(out.root), "--overwrite"])
        assert done.exit_code == 2 and "another run is writing into" in " ".join(done.output.split()), done.output
        assert (out.root / "base" / "keep.txt").is_file()
    released = runner.invoke(app, ["generate", str(ROOM), "--out", str(out.root), "--overwrite", "--no-evolve"])
    assert released.exit_code == 0, released.output
    assert (out.root / "base" / "scene.json").is_file()

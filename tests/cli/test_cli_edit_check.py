"""Issue 26, item 4: ``edit`` checks what it wrote — the edited scene's collisions and objects out
of bounds are reported, an edit that adds one is refused (exit 2, nothing written) unless
``--allow-invalid``, and ``--settle`` settles the edited scene first."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from scenemosaic import GenerateConfig, demo_scene, generate
from scenemosaic.cli import app
from scenemosaic.exchange import read_scene, save_scene
from scenemosaic.physics import check_out_of_bounds

runner = CliRunner()
THROUGH_THE_WALL = "chair.center.u = chair.center.u + 3"


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("edit_check")
    save_scene(demo_scene(), folder / "input")
    generate(folder / "input", folder / "run", GenerateConfig(model="rules", seed=0))
    return folder / "run" / "base"


def _said(output: str) -> str:
    return " ".join(output.split())


def test_an_edit_through_the_wall_is_refused_and_nothing_written(base: Path, tmp_path: Path) -> None:
    done = runner.invoke(app, ["edit", str(base), THROUGH_THE_WALL, "--out", str(tmp_path / "e")])
    assert done.exit_code == 2, done.output
    assert "out of bounds 1 (chair" in _said(done.stdout)
    assert "the edit leaves out of bounds chair" in _said(done.stderr) and "--allow-invalid" in done.stderr
    assert not (tmp_path / "e").exists()


def test_allow_invalid_writes_it_with_the_report(base: Path, tmp_path: Path) -> None:
    done = runner.invoke(app, ["edit", str(base), THROUGH_THE_WALL, "--out", str(tmp_path / "e"), "--allow-invalid"])
    assert done.exit_code == 0, done.output
    assert "out of bounds 1 (chair" in _said(done.stdout)
    assert [o.object_id for o in check_out_of_bounds(read_scene(tmp_path / "e")).objects] == ["chair"]


def test_settle_brings_the_edit_back_into_the_room(base: Path, tmp_path: Path) -> None:
    done = runner.invoke(app, ["edit", str(base), THROUGH_THE_WALL, "--out", str(tmp_path / "e"), "--settle"])
    assert done.exit_code == 0, done.output
    assert "check: collision pairs 0, out of bounds 0" in done.stdout
    edited, before = read_scene(tmp_path / "e"), read_scene(base)
    assert not check_out_of_bounds(edited).objects
    assert edited.get("chair").pose.position[0] > before.get("chair").pose.position[0] + 0.5  # the edit stays


def test_a_valid_edit_reports_a_clean_check(base: Path, tmp_path: Path) -> None:
    done = runner.invoke(app, ["edit", str(base), "chair.center.u = chair.center.u + 0.1", "--out", str(tmp_path / "e")])
    assert done.exit_code == 0, done.output
    assert "check: collision pairs 0, out of bounds 0" in done.stdout
    moved = np.subtract(read_scene(tmp_path / "e").get("chair").pose.position, read_scene(base).get("chair").pose.position)
    assert np.allclose(moved, [0.1, 0.0, 0.0], atol=1e-6)

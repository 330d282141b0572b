"""An ``--out`` that cannot be written — under a file, read-only, a folder where a file goes — is
one line and exit 2 for every command that writes, never a traceback (issue 41, low items)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "tests" / "fixtures" / "bedroom_22.json"
runner = CliRunner()


def _refused(args: list[str], *needles: str) -> None:
    done = runner.invoke(app, args)
    assert done.exit_code == 2, (args, done.output, done.exception)
    flat = " ".join(done.output.split())
    assert "Traceback" not in done.output and not isinstance(done.exception, OSError), flat
    for needle in needles:
        assert needle in flat, (needle, flat)


def test_an_out_under_a_file(tmp_path: Path) -> None:
    a_file = tmp_path / "a_file"
    a_file.write_text("kept", encoding="utf-8")
    manifest = tmp_path / "jobs.jsonl"
    manifest.write_text(json.dumps({"input": str(SCENE), "id": "b"}) + "\n", encoding="utf-8")
    unwritable = "cannot write the output folder"
    _refused(["export", str(SCENE), "--format", "glb", "--out", str(a_file / "x")], unwritable, "Not a directory")
    _refused(["export", str(SCENE), "--format", "glb", "--out", str(a_file)], unwritable, "not a folder")
    _refused(["render", str(SCENE), "--out", str(a_file / "plan.png")], unwritable)
    _refused(["render", str(SCENE), "--out", str(tmp_path)], "is a folder; give the PNG file")
    _refused(["batch", str(manifest), "--out", str(a_file / "x")], unwritable)
    _refused(["demo", "--out", str(a_file / "x")], unwritable)
    _refused(["schema", "--out", str(a_file / "scene.schema.json")], "cannot write")
    assert a_file.read_text(encoding="utf-8") == "kept"


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_out(tmp_path: Path) -> None:
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        _refused(["export", str(SCENE), "--format", "glb", "--out", str(locked)], "cannot write the output folder")
        _refused(["render", str(SCENE), "--out", str(locked / "plan.png")], "cannot write the output folder")
    finally:
        locked.chmod(0o755)


def test_a_planted_base_link_is_replaced_not_followed(tmp_path: Path) -> None:
    """A re-run removes the previous base/; a symlink planted there goes, what it points at stays."""
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("kept", encoding="utf-8")
    args = ["generate", str(SCENE), "--out", str(out), "--no-evolve"]
    assert runner.invoke(app, args).exit_code == 0
    shutil.rmtree(out / "base")
    (out / "base").symlink_to(elsewhere, target_is_directory=True)
    done = runner.invoke(app, args)
    assert done.exit_code == 0, done.output
    assert not (out / "base").is_symlink() and (out / "base" / "scene.json").is_file()
    assert [p.name for p in elsewhere.iterdir()] == ["keep.txt"]

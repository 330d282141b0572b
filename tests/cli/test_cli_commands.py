"""The command line: help on every command, the schema command, clear errors on bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.scene import Scene

runner = CliRunner()


@pytest.mark.parametrize("command", [[], ["generate"], ["demo"], ["inspect"], ["schema"]])
def test_every_command_has_help(command: list[str]) -> None:
    result = runner.invoke(app, [*command, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output


def test_schema_command_writes_the_scene_schema(tmp_path: Path) -> None:
    out = tmp_path / "schema.json"
    result = runner.invoke(app, ["schema", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert json.loads(out.read_text()) == Scene.model_json_schema()


def test_generate_missing_input_is_a_clear_error(tmp_path: Path) -> None:
    result = runner.invoke(app, ["generate", str(tmp_path / "nope.json"), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "input not found" in result.output


def test_unknown_log_level_rejected(tmp_path: Path) -> None:
    result = runner.invoke(app, ["schema", "--help"])
    assert result.exit_code == 0
    bad = runner.invoke(app, ["inspect", str(tmp_path), "--log-level", "loud"])
    assert bad.exit_code == 2
    assert "unknown log level" in bad.output


def test_inspect_reads_any_input_format(repo_data: Path) -> None:
    raw = repo_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
    result = runner.invoke(app, ["inspect", str(raw)])
    assert result.exit_code == 0, result.output
    # an unstructured input: the room is recovered, nothing is parented yet
    assert "unparented:" in result.output and "dining_table_0" in result.output


def test_inspect_bad_file_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "scene.json"
    bad.write_text('{"objects": [')
    result = runner.invoke(app, ["inspect", str(bad)])
    assert result.exit_code == 2
    assert "scene.json" in result.output

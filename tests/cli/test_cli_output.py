"""Issue 26, item 3: a run's output reads like prose on a terminal and on a pipe — no JSON object
unless asked, each warning kind on one line, nothing printed twice, Ctrl-C one calm line."""

from __future__ import annotations

import io
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import structlog
from typer.testing import CliRunner

from scenemosaic._logging import configure_logging, flush_logs
from scenemosaic.cli import REPORTED_EVENTS, app
from scenemosaic.exchange import save_scene
from scenemosaic.scene import AssetRef, Pose, Room, Scene, SceneObject

ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _gizmos(folder: Path, names: list[str]) -> Path:
    """A room of procedural objects whose categories the asset library does not know (each asked
    once per process, so every test names its own)."""
    objects = [
        SceneObject(
            id=f"thing_{i}",
            category=name,
            asset=AssetRef(kind="procedural", category=name, extents=(0.4, 0.4, 0.4)),
            pose=Pose.from_yaw((0.6 + 0.8 * i, 1.0, 0.0), 0.0),
        )
        for i, name in enumerate(names)
    ]
    save_scene(Scene(id="gizmos", room=Room.rectangle(0, 0, 4, 3), objects=objects), folder)
    return folder


def _check_prose(stderr: str, names: list[str]) -> None:
    lines = [ANSI.sub("", line).strip() for line in stderr.replace("\r", "\n").splitlines()]
    lines = [line for line in lines if line]
    assert not [line for line in lines if line.startswith("{")], stderr  # no JSON object
    text = ANSI.sub("", stderr)
    # one line for the kind, with its count and the list (a terminal may wrap it at its width)
    assert text.count("unknown_procedural_category") == 1, stderr
    assert f"unknown_procedural_category ×{len(names)}" in text, stderr
    assert all(text.count(name) == 1 for name in names), stderr
    said = [line for line in lines if line.startswith(("warning", "error"))]
    assert len(said) == len(set(said)), stderr


def test_a_run_on_a_pipe_prints_readable_lines_with_warnings_folded(tmp_path: Path) -> None:
    names = ["zqgizmo", "zqwidget", "zqsprocket"]
    source = _gizmos(tmp_path / "input", names)
    done = CliRunner().invoke(app, ["generate", str(source), "--out", str(tmp_path / "out")])
    assert done.exit_code == 0, done.stderr
    _check_prose(done.stderr, names)


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_run_on_a_terminal_prints_readable_lines_with_warnings_folded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    names = ["zqdoohickey", "zqwhatsit", "zqgubbins", "zqthingummy"]
    source = _gizmos(tmp_path / "input", names)
    terminal, stdout = _Terminal(), _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    monkeypatch.setattr(sys, "stdout", stdout)
    app(["generate", str(source), "--out", str(tmp_path / "out")], standalone_mode=False)
    monkeypatch.undo()
    _check_prose(terminal.getvalue(), names)


def test_json_only_when_asked_and_reported_events_left_out(capsys: pytest.CaptureFixture[str]) -> None:
    log = structlog.get_logger("test")
    configure_logging("warning", log_format="json")
    log.warning("something_odd", value=1)
    assert json.loads(capsys.readouterr().err.strip())["event"] == "something_odd"

    configure_logging("info", suppress=REPORTED_EVENTS)
    log.warning("run_degraded", warnings=["w"])  # the CLI's summary lists these
    log.error("stage_failed", error="boom")  # the CLI's error line says it
    log.info("stage_finished", seconds=1.0)
    log.warning("odd", n=1)
    log.warning("odd", n=2)
    log.info("later")
    flush_logs()
    err = capsys.readouterr().err
    assert err.splitlines() == ["info: stage_finished seconds=1.0", "warning: odd ×2 n=[1, 2]", "info: later"]
    configure_logging("warning")


def test_ctrl_c_prints_one_calm_line(tmp_path: Path) -> None:
    driver = Path(__file__).resolve().parents[1] / "reliability" / "cli_driver.py"
    source = _gizmos(tmp_path / "input", ["zqcalm"])
    cmd = [sys.executable, str(driver), "stabilize", "sleep", "--", "generate", str(source), "--out", str(tmp_path / "out")]
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "SCENEMOSAIC_CACHE": str(tmp_path / "c"), "COLUMNS": "250"}
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stderr is not None
    deadline = time.monotonic() + 120
    for line in proc.stderr:
        if "STAGE-STARTED stabilize" in line:
            break
        assert time.monotonic() < deadline
    os.kill(proc.pid, signal.SIGINT)
    _, rest = proc.communicate(timeout=30)
    assert proc.returncode == 130
    said = [line for line in rest.splitlines() if line.strip() and "━" not in line]
    assert len(said) == 1 and said[0].startswith("interrupted: report and partial result in"), rest
    assert "{" not in rest and "CancelledError" not in rest


def test_resume_of_a_finished_run_lists_each_stage_once(tmp_path: Path) -> None:
    source = _gizmos(tmp_path / "input", ["zqresumed"])
    out = tmp_path / "out"
    assert CliRunner().invoke(app, ["generate", str(source), "--out", str(out)]).exit_code == 0
    done = CliRunner().invoke(app, ["generate", "--resume", str(out)])
    assert done.exit_code == 0, done.output
    table = [line.split()[0] for line in done.stdout.splitlines() if line.startswith("  ") and " s" in line]
    assert table.count("export") == 1 and len(table) == len(set(table)), done.stdout
    stages = [s["name"] for s in json.loads((out / "report.json").read_text(encoding="utf-8"))["stages"]]
    assert len(stages) == len(set(stages)), stages


def test_help_shows_no_type_beside_flags_and_no_braces_in_usage() -> None:
    for command in ("generate", "demo", "edit", "batch", "export", "render", "inspect", "evaluate"):
        done = CliRunner().invoke(app, [command, "--help"], env={"COLUMNS": "200"})
        assert done.exit_code == 0, done.output
        assert "<bool>" not in done.output, command
        usage = next(line for line in done.output.splitlines() if "Usage:" in line)
        assert "{" not in usage and "[[" not in usage, usage


def test_a_refused_overwrite_does_not_call_the_old_results_partial(tmp_path: Path) -> None:
    source = _gizmos(tmp_path / "input", ["zqolder"])
    out = tmp_path / "out"
    assert CliRunner().invoke(app, ["generate", str(source), "--out", str(out)]).exit_code == 0
    other = _gizmos(tmp_path / "other", ["zqnewer", "zqnewest"])
    done = CliRunner().invoke(app, ["generate", str(other), "--out", str(out)])
    assert done.exit_code == 2, done.output
    assert "partial results" not in done.stderr, done.stderr

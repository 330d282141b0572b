"""The example notebook ships executed, and runs again from top to bottom in a fresh kernel: a
scene shown as its plan, a result with variants and metrics, an edit and an export, with
progress lines and no widget warning; a house shown as its plan, a house run's result and one
of its rooms."""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "notebook_tour.ipynb"


def _outputs(nb: nbformat.NotebookNode) -> list[list[nbformat.NotebookNode]]:
    return [cell.outputs for cell in nb.cells if cell.cell_type == "code"]


def _check(nb: nbformat.NotebookNode) -> None:
    plan, run, metrics, edit, export, house, house_run, room = _outputs(nb)
    assert "image/png" in plan[-1]["data"]  # a Scene shows as its plan
    streams = "".join(o.get("text", "") for o in run if o["output_type"] == "stream")
    assert streams.count("generate: ") == 10 and "(10/10, " in streams, streams
    assert "ipywidgets" not in streams and "\x1b[" not in streams
    result = run[-1]["data"]
    assert "image/png" in result and "Div-IoU" in result["text/html"]  # variants and metrics
    assert "variant_2" in metrics[-1]["data"]["text/plain"]
    assert "image/png" in edit[-1]["data"]
    assert "scene.sdf" in export[-1]["data"]["text/plain"]
    shown = house[-1]["data"]  # a House shows as its plan, with a one-line text repr
    assert "image/png" in shown and shown["text/plain"].startswith("House(id='procthor_4room'")
    assert len(shown["text/plain"]) < 200 and "objects=74" in shown["text/plain"]
    summary = house_run[-1]["data"]
    assert "image/png" in summary and "house NAV" in summary["text/html"] and "COL / OOB" in summary["text/html"]
    assert len(summary["text/plain"]) < 400  # not the whole report
    assert "['room_2', 'room_3']" in room[0]["text"] and "image/png" in room[-1]["data"]


def test_the_shipped_notebook_is_executed() -> None:
    _check(nbformat.read(NOTEBOOK, as_version=4))


def test_the_notebook_runs_in_a_fresh_kernel(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    monkeypatch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL", "egl"))
    NotebookClient(nb, timeout=240, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    _check(nb)
    assert (tmp_path / "out" / "notebook" / "edited" / "scene.urdf").is_file()
    assert (tmp_path / "out" / "notebook" / "house" / "base" / "rooms" / "room_3" / "scene.json").is_file()

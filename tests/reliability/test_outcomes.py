"""Honest outcomes through the CLI: unexpected errors, output folders, degraded results, --strict."""

from __future__ import annotations

import json
from pathlib import Path

from cli_helpers import DATA, report, run_cli


def test_an_unexpected_error_is_one_line_with_the_traceback_in_the_report(tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    done = run_cli(["generate", str(dining), "--out", str(out)], tmp_path, stage="stabilize", action="raise")
    assert done.code == 1
    assert "Traceback" not in done.stderr
    assert "unexpected RuntimeError in stage 'stabilize'" in done.stderr and str(dining) in done.stderr.replace("\n", "")
    rep = report(out)
    assert rep["status"] == "failed" and rep["failed_stage"] == "stabilize"
    assert "RuntimeError: injected failure" in rep["traceback"]
    assert (out / "base" / "scene.json").is_file()  # the structured scene is kept


def test_an_output_folder_of_another_input_is_refused_unless_overwrite(tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    assert run_cli(["generate", str(dining), "--out", str(out)], tmp_path).code == 0
    other = DATA / "layouts" / "physcene" / "Bedroom-33922_bedroom.json"
    refused = run_cli(["generate", str(other), "--out", str(out)], tmp_path)
    assert refused.code == 2 and "--overwrite" in refused.stderr
    assert report(out)["input"] == str(dining)  # untouched
    forced = run_cli(["generate", str(other), "--out", str(out), "--overwrite"], tmp_path)
    assert forced.code == 0 and report(out)["input"] == str(other)


def test_a_failing_rerun_does_not_leave_the_old_base_beside_its_report(tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    assert run_cli(["generate", str(dining), "--out", str(out)], tmp_path).code == 0
    failed = run_cli(["generate", str(dining), "--out", str(out)], tmp_path, stage="import", action="raise")
    assert failed.code == 1
    assert report(out)["status"] == "failed"
    assert not (out / "base").exists()  # nothing from the old run pretends to belong to this one


def test_degraded_is_visible_and_strict_exits_one(tmp_path: Path) -> None:
    """Five chairs at one point in a room too small for them (1 m x 1 m: even evolution cannot
    part them): the result is still written, marked degraded, and --strict fails."""
    scene = {
        "id": "crowded",
        "objects": [
            {
                "id": f"chair_{i}",
                "category": "dining_chair",
                "asset": {"kind": "procedural", "category": "dining_chair", "extents": [0.45, 0.5, 0.9]},
                "pose": {"position": [0.5, 0.5, 0.0], "quaternion": [1, 0, 0, 0], "scale": [1, 1, 1]},
            }
            for i in range(5)
        ],
        "room": {
            "id": "room",
            "floor": [[0, 0], [1, 0], [1, 1], [0, 1]],
            "ceiling_height": 2.6,
        },
    }
    source = tmp_path / "crowded.json"
    source.write_text(json.dumps(scene), encoding="utf-8")
    out = tmp_path / "out"
    done = run_cli(["generate", str(source), "--out", str(out)], tmp_path)
    rep = report(out)
    assert rep["status"] == "degraded" and rep["warnings"]
    assert done.code == 0 and "degraded" in done.stderr
    strict = run_cli(["generate", str(source), "--out", str(out), "--strict"], tmp_path)
    assert strict.code == 1

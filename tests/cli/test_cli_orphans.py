"""A house with a room's record removed, as a user runs it (issue 37, item 5): ``generate`` and
``inspect`` exit 2 naming the objects left outside every room; ``generate --allow-orphans`` runs
on, warns on the console, and ends ``degraded`` with that reason first in ``report.json``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app

FOUR_ROOMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"
ORPHANS = ("'5|0' (Toilet_2", "'5|1|0' (Sink_15", "'5|2' (bin_22", "'5|4' (Wall_Decor_Photo_10")
runner = CliRunner()


@pytest.fixture
def no_bathroom(tmp_path: Path) -> Path:
    """The shipped four-room house less its bathroom's record (its toilet, sink and door stay)."""
    raw = json.loads(FOUR_ROOMS.read_text(encoding="utf-8"))
    raw["rooms"] = [r for r in raw["rooms"] if r["roomType"] != "Bathroom"]
    path = tmp_path / "no_bathroom.json"
    path.write_text(json.dumps(raw), encoding="utf-8")
    return path


@pytest.mark.parametrize("command", ["generate", "inspect"])
def test_a_house_missing_a_room_is_refused_naming_its_orphans(no_bathroom: Path, tmp_path: Path, command: str) -> None:
    args = [command, str(no_bathroom)] + (["--model", "rules", "--out", str(tmp_path / "out")] if command == "generate" else [])
    done = runner.invoke(app, args)
    text = " ".join(done.output.split())
    assert done.exit_code == 2, done.output
    assert "Traceback" not in done.output
    assert "4 object(s) lie outside every room" in text and "nearest room 'room|6' (Kitchen)" in text
    assert all(o in text for o in ORPHANS)
    assert "--allow-orphans" in text


@pytest.mark.slow
@pytest.mark.house  # a whole house run: make test-houses
def test_allow_orphans_runs_on_degraded_with_that_reason_first(no_bathroom: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    done = runner.invoke(app, ["generate", str(no_bathroom), "--model", "rules", "--no-evolve", "--allow-orphans", "--out", str(out)])
    assert done.exit_code == 0, done.output
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert report["status"] == "degraded"
    assert report["config"]["allow_orphans"] is True
    first, second = report["warnings"][:2]
    assert first.startswith("input: 4 object(s) lie outside every room") and all(o in first for o in ORPHANS)
    assert second.startswith("input: 1 door(s) or window(s) open onto a room the house does not hold")
    assert report["house"]["rooms"] == ["room_4", "room_6", "room_7"]
    text = " ".join(done.output.split())
    assert "procthor_orphans_allowed" in text  # said when the house is read
    assert "the result is degraded" in text and "input: 4 object(s) lie outside every room" in text


@pytest.mark.slow
def test_one_room_of_such_a_house_is_degraded_too(no_bathroom: Path, tmp_path: Path) -> None:
    """``--room`` reads the whole house first: its orphans degrade a run of any of its rooms."""
    out = tmp_path / "out"
    args = ["generate", str(no_bathroom), "--room", "room|4", "--model", "rules", "--no-evolve", "--allow-orphans", "--out", str(out)]
    done = runner.invoke(app, args)
    assert done.exit_code == 0, done.output
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert report["status"] == "degraded" and "house" not in report
    assert report["warnings"][0].startswith("input: 4 object(s) lie outside every room")

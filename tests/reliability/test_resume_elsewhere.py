"""``--resume OUT`` from any working directory, and checkpoints damaged on disk (issue 41, low items)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import DINING, cli_env


def _cli(args: list[str], cwd: Path, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "scenemosaic.cli", *args], cwd=cwd, capture_output=True, text=True, timeout=300,
        env=cli_env(tmp_path), check=False,
    )  # fmt: skip


@pytest.mark.house  # a run stopped and resumed twice (~30 s): make test-houses
def test_resume_from_another_directory_and_damaged_checkpoints(tmp_path: Path) -> None:
    here, elsewhere = tmp_path / "here", tmp_path / "elsewhere"
    here.mkdir()
    elsewhere.mkdir()
    shutil.copy(DINING, here / "room.json")
    out = tmp_path / "out"
    first = _cli(["generate", "room.json", "--out", str(out), "--no-evolve"], here, tmp_path)  # a relative input
    assert first.returncode == 0, first.stderr[-2000:]
    record = out / ".checkpoint" / "run.json"
    assert json.loads(record.read_text(encoding="utf-8"))["input"] == str(here / "room.json")
    again = _cli(["generate", "--resume", str(out)], elsewhere, tmp_path)
    assert again.returncode == 0, again.stderr[-2000:]
    stages = json.loads((out / "report.json").read_text(encoding="utf-8"))["stages"]
    assert {s["status"] for s in stages if s["name"] == "structure"} == {"reused"}

    # a truncated stage record counts as missing: the stages run again
    [state] = (out / ".checkpoint" / "nodes" / "pipeline").glob("*.json")
    state.write_text(state.read_text(encoding="utf-8")[:500], encoding="utf-8")
    rerun = _cli(["generate", "--resume", str(out)], elsewhere, tmp_path)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert "run_store_record_damaged" in rerun.stderr and "Traceback" not in rerun.stderr
    stages = json.loads((out / "report.json").read_text(encoding="utf-8"))["stages"]
    assert {s["status"] for s in stages if s["name"] == "structure"} == {"done"}

    # a run record that is not one: one line, exit 2
    for damaged in ("[]", '{"input": 5}', json.dumps({"input": "room.json", "config": {"priors_dir": 7}})):
        record.write_text(damaged, encoding="utf-8")
        refused = _cli(["generate", "--resume", str(out)], elsewhere, tmp_path)
        assert refused.returncode == 2, (damaged, refused.stderr[-2000:])
        assert "holds no run to resume" in refused.stderr and "Traceback" not in refused.stderr

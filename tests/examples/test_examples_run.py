"""Every script in examples/ runs to completion; those that take an input path take a whole house too."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))
TWO_ROOMS = ROOT / "data/houses/procthor/procthor10k_house3703_2room.json"


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=240, check=False)


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script: Path, tmp_path: Path) -> None:
    args = [str(script)]
    if script.name == "generate_room.py":
        args += [str(ROOT / "data/layouts/physcene/DiningRoom-19325_diningroom.json"), str(tmp_path / "out")]
    done = _run(args, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip(), "an example should show its result"


@pytest.mark.house  # a whole-house run
def test_the_plugin_agent_runs_in_every_room_of_a_house(tmp_path: Path) -> None:
    done = _run([str(ROOT / "examples/custom_agent.py"), str(TWO_ROOMS), str(tmp_path / "out")], tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    for room in ("room_2", "room_3"):
        scene = json.loads((tmp_path / "out/base/rooms" / room / "scene.json").read_text(encoding="utf-8"))
        crowding = scene["metadata"]["crowding"]
        assert crowding["covered_fraction"] > 0 and crowding["largest"]
        assert f"crowding of {room}: {crowding}" in done.stdout, done.stdout


@pytest.mark.house  # a whole-house run
def test_generate_room_takes_a_house(tmp_path: Path) -> None:
    done = _run([str(ROOT / "examples/generate_room.py"), str(TWO_ROOMS), str(tmp_path / "out")], tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "39 objects in 2 room(s)" in done.stdout, done.stdout
    assert "room_2  (" in done.stdout and "room_3  (" in done.stdout  # each room's tree


@pytest.mark.house  # two whole-house runs (about 25 s on 2 cores)
def test_custom_critic_takes_a_house(tmp_path: Path) -> None:
    done = _run([str(ROOT / "examples/custom_critic.py"), str(TWO_ROOMS), str(tmp_path / "out")], tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "evolved layouts of room_2: " in done.stdout and "evolved layouts of room_3: " in done.stdout, done.stdout

"""The stage plan is one thing (``pipeline.plan``): the driver runs it, announces it before the first
stage, and the progress displays count it instead of guessing from stage names."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from scenemosaic.pipeline import HOUSE_STAGE_NAMES, STAGE_NAMES, GenerateConfig, generate, plan

DATA = Path(__file__).resolve().parents[2] / "data"
ROOM = DATA / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
HOUSE = DATA / "houses" / "procthor" / "procthor_4room.json"


def test_the_plan_of_a_room_a_cluttered_room_and_a_house() -> None:
    assert plan(ROOM, GenerateConfig()).names == STAGE_NAMES
    cluttered = plan(ROOM, GenerateConfig(clutter="fill")).names
    assert len(cluttered) == len(STAGE_NAMES) + 1 and cluttered[cluttered.index("compose") + 1] == "clutter"
    house = plan(HOUSE, GenerateConfig(clutter="vary", variants=2))
    assert house.house and house.names == HOUSE_STAGE_NAMES
    assert [s.name for s in house.room_stages] == [*STAGE_NAMES[: STAGE_NAMES.index("compose") + 1], "clutter"]
    one_room = plan(HOUSE, GenerateConfig(room="room|5"))
    assert not one_room.house and one_room.names == STAGE_NAMES


def test_a_run_announces_its_plan_before_its_first_stage_and_runs_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    events: list[tuple[str, str]] = []
    config = GenerateConfig(clutter="fill", variants=1)
    result = generate(ROOM, tmp_path / "run", config, on_stage=lambda name, status: events.append((name, status)), progress=True)
    planned = [name for name, status in events if status == "planned"]
    first_start = next(i for i, (_, status) in enumerate(events) if status == "started")
    assert all(status == "planned" for _, status in events[:first_start])
    assert tuple(planned) == plan(ROOM, config).names
    assert [s["name"] for s in result.report["stages"]] == planned
    # the line-per-stage progress (no terminal here) counts the plan: 11 stages, not a guess
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("generate: ")]
    assert lines and all(re.search(rf"\(\d+/{len(planned)}, ", line) for line in lines)
    assert f"({len(planned)}/{len(planned)}, " in lines[-1]

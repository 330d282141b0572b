"""A house too large to work on as one is refused at import, in one line and at once: too many
rooms, or rooms spread kilometres apart (the house-wide raster would need gigabytes)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import load_scene
from scenemosaic.scene import MAX_HOUSE_ROOMS, MAX_HOUSE_SPAN_M


def _room(i: int, x0: float, z0: float) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    corners = [(x0, z0), (x0, z0 + 3), (x0 + 3, z0 + 3), (x0 + 3, z0)]
    room = {"id": f"room|{i}", "roomType": "Bedroom", "floorPolygon": [{"x": x, "y": 0, "z": z} for x, z in corners], "children": []}
    walls = []
    for k, ((ax, az), (bx, bz)) in enumerate(zip(corners, corners[1:] + corners[:1], strict=True)):
        walls.append({
            "id": f"wall|{i}|{k}", "roomId": f"room|{i}",
            "polygon": [{"x": ax, "y": 0, "z": az}, {"x": bx, "y": 0, "z": bz}, {"x": ax, "y": 2.7, "z": az}, {"x": bx, "y": 2.7, "z": bz}],
        })  # fmt: skip
    return room, walls


def _house(path: Path, origins: list[tuple[float, float]]) -> Path:
    rooms, walls = [], []
    for i, (x0, z0) in enumerate(origins, start=2):
        room, room_walls = _room(i, x0, z0)
        rooms.append(room)
        walls += room_walls
    path.write_text(json.dumps({"rooms": rooms, "walls": walls, "doors": [], "windows": [], "objects": []}))
    return path


def test_rooms_kilometres_apart_are_refused_at_once(tmp_path: Path) -> None:
    house = _house(tmp_path / "far.json", [(-990.0, 0.0), (990.0, 0.0)])
    started = time.monotonic()
    with pytest.raises(ImportFormatError, match="spread over 1,983 m"):
        load_scene(house)
    assert time.monotonic() - started < 5
    done = CliRunner().invoke(app, ["generate", str(house), "--out", str(tmp_path / "o")], env={"COLUMNS": "400"})
    assert done.exit_code == 2 and f"at most {MAX_HOUSE_SPAN_M:g} m" in done.output and "Traceback" not in done.output


def test_a_house_of_too_many_rooms_is_refused_before_any_room_is_built(tmp_path: Path) -> None:
    count = 1000
    house = _house(tmp_path / "grid.json", [(3.0 * (i % 40), 3.0 * (i // 40)) for i in range(count)])
    started = time.monotonic()
    with pytest.raises(ImportFormatError, match=f"{count} rooms; a house holds at most {MAX_HOUSE_ROOMS}"):
        load_scene(house)
    assert time.monotonic() - started < 5


def test_a_house_within_the_limits_is_read(tmp_path: Path) -> None:
    house = _house(tmp_path / "two.json", [(0.0, 0.0), (3.0, 0.0)])
    loaded = load_scene(house)
    assert [r.id for r in loaded.rooms] == ["room_2", "room_3"]  # type: ignore[union-attr]

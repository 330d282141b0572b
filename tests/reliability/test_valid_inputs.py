"""Valid inputs that once failed inside the library (issue 41, item 10): ids that sanitize alike,
and scenes larger than an agent's own output bounds. Each is run as a user would: the CLI on a
house file, ``structure_scene`` on a scene file."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.exchange import load_scene
from scenemosaic.models import RulesModel
from scenemosaic.scene import MAX_FLOOR_POINTS, Scene
from scenemosaic.structure import structure_scene
from scenemosaic.structure._constraints import MAX_CONSTRAINTS
from scenemosaic.structure._verify import MAX_PROBLEMS

ROOT = Path(__file__).resolve().parents[2]
TWO_ROOMS = ROOT / "data" / "houses" / "procthor" / "procthor10k_house3703_2room.json"


def _object(oid: str, category: str, extents: tuple[float, float, float], at: tuple[float, float, float], yaw: float = 0.0) -> dict[str, Any]:
    half = math.radians(yaw) / 2
    return {
        "id": oid,
        "category": category,
        "asset": {"kind": "procedural", "category": category, "extents": list(extents)},
        "pose": {"position": list(at), "quaternion": [math.cos(half), 0.0, 0.0, math.sin(half)]},
    }


def _scene(path: Path, objects: list[dict[str, Any]], floor: list[tuple[float, float]] | None = None, size: tuple[float, float] = (6.0, 5.0)) -> Path:
    w, d = size
    corners = floor or [(0.0, 0.0), (w, 0.0), (w, d), (0.0, d)]
    room: dict[str, Any] = {"id": "room", "floor": [list(p) for p in corners], "ceiling_height": 2.7}
    path.write_text(json.dumps({"id": path.stem, "room": room, "objects": objects}), encoding="utf-8")
    return path


def _structured(path: Path) -> Scene:
    scene = load_scene(path)
    assert isinstance(scene, Scene)
    return asyncio.run(structure_scene(scene, RulesModel()))


def test_room_ids_that_sanitize_alike_in_one_house(tmp_path: Path) -> None:
    """``room|2`` and ``room_2`` in one house: both rooms are generated, and ``--room`` names one."""
    text = TWO_ROOMS.read_text(encoding="utf-8")
    house = tmp_path / "house.json"
    house.write_text(text.replace("room|3", "room_2").replace('"wall|3|', '"wall|9|'), encoding="utf-8")
    assert "room|2" in house.read_text() and '"room_2"' in house.read_text()
    out = tmp_path / "out"
    runner = CliRunner()
    done = runner.invoke(app, ["generate", str(house), "--out", str(out), "--no-evolve"])
    assert done.exit_code == 0, done.output
    assert sorted(p.name for p in (out / "base" / "rooms").iterdir()) == ["room_2", "room_2_2"]
    for name, expected in (("room_2", "room_2"), ("room|2", "room_2"), ("room_2_2", "room_2_2")):
        shown = runner.invoke(app, ["inspect", str(house), "--room", name])
        assert shown.exit_code == 0, shown.output
        assert shown.output.split()[0] == expected, (name, shown.output)


def test_four_hundred_items_on_one_counter(tmp_path: Path) -> None:
    """Verification reports what it cannot fix within its own bound (the rest summed up in one line)."""
    mugs = [
        _object(f"mug_{k}", "mug", (0.09, 0.09, 0.1), (1.3 + (k % 20) * 0.095, 0.15 + (k // 20) % 5 * 0.1, 0.9 + (k // 100) * 0.1))
        for k in range(400)
    ]
    path = _scene(tmp_path / "counter.json", [_object("counter", "kitchen_counter", (2.0, 0.6, 0.9), (2.25, 0.4, 0.0)), *mugs])
    scene = _structured(path)
    notes = [n for n in scene.provenance.notes if n.startswith("verify: ") and "->" not in n and "laid down" not in n]
    problems = [n for n in notes if "no plausible receptacle or floor spot has room" in n]
    assert 64 < len(problems) < MAX_PROBLEMS, len(problems)
    assert scene.support_of("mug_0") is not None


def test_more_desk_groups_than_constraints(tmp_path: Path) -> None:
    """70 desks, each with a monitor and a chair: the constraints agent keeps its bound."""
    objects = []
    for k in range(70):
        x, y = 1.5 + (k % 10) * 2.5, 1.5 + (k // 10) * 2.5
        objects += [
            _object(f"desk_{k}", "desk", (1.2, 0.6, 0.75), (x, y, 0.0)),
            _object(f"monitor_{k}", "computer_monitor", (0.5, 0.15, 0.4), (x, y, 0.75)),
            _object(f"chair_{k}", "office_chair", (0.55, 0.55, 1.0), (x, y - 0.65, 0.0), 180.0),
        ]
    scene = _structured(_scene(tmp_path / "desks.json", objects, size=(26.0, 19.0)))
    assert len(scene.constraints) == MAX_CONSTRAINTS


def test_a_pile_of_furniture(tmp_path: Path) -> None:
    """40 wardrobes on one spot: 780 nested pairs, more than verification's evidence lists."""
    objects = [_object(f"wardrobe_{k}", "wardrobe", (1.0, 0.6, 2.0), (2.25 + 0.001 * k, 2.5, 0.0)) for k in range(40)]
    scene = _structured(_scene(tmp_path / "pile.json", objects))
    assert any("stand inside each other" in n for n in scene.provenance.notes)


def test_a_floor_drawn_in_many_short_pieces(tmp_path: Path) -> None:
    """A room whose floor has 200 points, 10 cm apart: its walls are kept, short as they are; past
    MAX_FLOOR_POINTS a floor is refused at import, naming the field."""
    def floor(per_side: int) -> list[tuple[float, float]]:
        corners = [(0.0, 0.0), (4.5, 0.0), (4.5, 5.0), (0.0, 5.0)]
        points = []
        for i, (ax, ay) in enumerate(corners):
            bx, by = corners[(i + 1) % 4]
            points += [(round(ax + (bx - ax) * k / per_side, 4), round(ay + (by - ay) * k / per_side, 4)) for k in range(per_side)]
        return points

    bed = [_object("bed", "double_bed", (1.6, 2.1, 1.0), (2.25, 3.9, 0.0))]
    scene = _structured(_scene(tmp_path / "fine.json", bed, floor=floor(50)))
    assert scene.room is not None and len(scene.room.walls) == 200
    with pytest.raises(SceneMosaicError, match=f"room.floor.*at most {MAX_FLOOR_POINTS}"):
        load_scene(_scene(tmp_path / "too_fine.json", bed, floor=floor(75)))

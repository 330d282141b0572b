"""Every published form of the AI2-THOR / ProcTHOR house schema, read from real files (issue 37).

``data/houses/schema_forms`` ships a house in schema 0.0.1 (doors and windows with a
``boundingBox`` and an ``assetOffset``, exterior walls carrying the room's id) and the same house
as ProcTHOR's upgrade wrote it in 1.0.0 (``holePolygon``), and two of AI2-THOR's own 0.0.1 houses
(``rooms/746.json``, ``rooms/143.json``). The expected openings are worked out here from the raw JSON, independently of
the importer: each hole's centre on its ``wall0`` in the world, its width, sill and height.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import load_scenes
from scenemosaic.exchange._procthor import SHARED_WALL_THICKNESS_M
from scenemosaic.scene import Scene

FORMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "schema_forms"
PAIR_0_0_1 = FORMS / "cc_kitchen_living_schema_0_0_1.json"
PAIR_1_0_0 = FORMS / "cc_kitchen_living_schema_1_0_0.json"
AI2THOR_0_0_1 = FORMS / "ai2thor_746_schema_0_0_1.json"
AI2THOR_OPEN_PLAN = FORMS / "ai2thor_143_schema_0_0_1.json"
"""Another 0.0.1 house of AI2-THOR's, whose kitchen and living room share an ``empty`` wall."""
REACH = SHARED_WALL_THICKNESS_M / 2 + 1e-3
"""How far a room's wall may stand from the line the house draws (a shared wall is cut back by half)."""


def _expected(raw: dict[str, Any]) -> list[tuple[str, str, np.ndarray, float, float, float]]:
    """``(room id, kind, world centre (x, z), width, sill, height)`` for every door and window,
    once per room of the house it opens onto."""
    rooms = {r["id"] for r in raw["rooms"]}
    walls = {w["id"]: w for w in raw["walls"]}
    out = []
    for key, kind in (("doors", "door"), ("windows", "window")):
        for item in raw.get(key, []):
            corners = item["holePolygon"] if "holePolygon" in item else [item["boundingBox"]["min"], item["boundingBox"]["max"]]
            xs, ys = [p["x"] for p in corners], [p["y"] for p in corners]
            poly = walls[item["wall0"]]["polygon"]
            low = min(p["y"] for p in poly)
            base: list[tuple[float, float]] = []
            for p in poly:
                if p["y"] == low and (p["x"], p["z"]) not in base:
                    base.append((p["x"], p["z"]))
            a, b = np.array(base[0]), np.array(base[1])
            centre = a + (b - a) / np.linalg.norm(b - a) * (min(xs) + max(xs)) / 2
            for room in dict.fromkeys((item["room0"], item["room1"])):
                if room in rooms:
                    out.append((room, kind, centre, max(xs) - min(xs), min(ys), max(ys) - min(ys)))
    return out


def _openings(scenes: list[Scene]) -> list[tuple[str, str, np.ndarray, float, float, float, str]]:
    """Every door and window the import cut: ``(source room id, kind, world centre, width, sill,
    height, wall id)``."""
    out = []
    for scene in scenes:
        assert scene.room is not None
        for wall in scene.room.walls:
            for o in wall.openings:
                if o.kind != "opening":
                    centre = np.asarray(wall.start) + wall.direction * o.center
                    out.append((scene.provenance.source_room_id, o.kind, centre, o.width, o.bottom, o.height, wall.id))
    return out


@pytest.mark.parametrize("path", [PAIR_0_0_1, PAIR_1_0_0, AI2THOR_0_0_1, AI2THOR_OPEN_PLAN], ids=lambda p: p.stem)
def test_every_door_and_window_lands_on_its_wall_at_its_place_and_size(path: Path) -> None:
    raw = json.loads(path.read_text(encoding="utf-8"))
    scenes = load_scenes(path)
    assert [s.provenance.source_room_id for s in scenes] == [r["id"] for r in raw["rooms"]]
    got = _openings(scenes)
    expected = _expected(raw)
    assert len(got) == len(expected) and expected
    for room, kind, centre, width, sill, height in expected:
        # a hole beside a corner a shared wall's cut-back took is cut only as far as the wall goes:
        # its centre moves along the wall by at most half of that
        match = [g for g in got if g[0] == room and g[1] == kind and np.linalg.norm(g[2] - centre) <= 2 * REACH]
        assert len(match) == 1, (path.name, room, kind, centre)
        _, _, at, w, s, h, wall_id = match[0]
        assert (s, h) == pytest.approx((sill, height), abs=1e-9)
        # on the room's wall along the source wall, not merely near it: the centre lies on that wall's line
        scene = next(sc for sc in scenes if sc.provenance.source_room_id == room)
        assert scene.room is not None
        wall = next(wl for wl in scene.room.walls if wl.id == wall_id)
        assert abs(float(np.dot(centre - np.asarray(wall.start), wall.outward_normal))) <= REACH
        # the source's span along the wall, clipped to the wall: no more than the cut-back taken off
        source = float(np.dot(centre - np.asarray(wall.start), wall.direction))
        lo, hi = max(source - width / 2, 0.0), min(source + width / 2, wall.length)
        along = float(np.dot(at - np.asarray(wall.start), wall.direction))
        assert (along - w / 2, along + w / 2) == pytest.approx((lo, hi), abs=1e-6)
        assert width - w <= 2 * REACH


def test_the_two_forms_of_one_house_import_the_same() -> None:
    """ProcTHOR's own upgrade wrote the 1.0.0 file from the 0.0.1 one: the same rooms, walls,
    openings and objects come out of both."""
    old, new = load_scenes(PAIR_0_0_1), load_scenes(PAIR_1_0_0)
    assert json.loads(PAIR_0_0_1.read_text())["metadata"]["schema"] == "0.0.1"
    assert json.loads(PAIR_1_0_0.read_text())["metadata"]["schema"] == "1.0.0"
    assert len(old) == len(new) == 2
    for a, b in zip(old, new, strict=True):
        assert a.room == b.room  # floor, walls, every opening's place and size
        assert a.objects == b.objects and a.relations == b.relations
    doors = sum(o.kind == "door" for s in old for w in s.room.walls for o in w.openings)  # type: ignore[union-attr]
    windows = sum(o.kind == "window" for s in old for w in s.room.walls for o in w.openings)  # type: ignore[union-attr]
    assert (doors, windows) == (3, 2)  # a door between the rooms (cut in both), one to the outside; two windows


def test_a_house_without_a_schema_version_reads_as_the_first_form(tmp_path: Path) -> None:
    raw = json.loads(PAIR_0_0_1.read_text())
    del raw["metadata"]["schema"]
    path = tmp_path / "house.json"
    path.write_text(json.dumps(raw))
    assert [s.room for s in load_scenes(path)] == [s.room for s in load_scenes(PAIR_0_0_1)]


def test_exterior_walls_of_the_first_form_are_the_outside(tmp_path: Path) -> None:
    """Schema 0.0.1 gives an exterior wall the id of the room it closes: it is still no wall of
    that room (a taller exterior wall does not raise the room's ceiling)."""
    raw = json.loads(PAIR_0_0_1.read_text())
    for wall in raw["walls"]:
        if wall["id"].startswith("wall|exterior|"):
            for p in wall["polygon"]:
                p["y"] = 9.0 if p["y"] > 0 else p["y"]
    path = tmp_path / "house.json"
    path.write_text(json.dumps(raw))
    heights = {s.room.ceiling_height for s in load_scenes(path)}  # type: ignore[union-attr]
    assert heights == {s.room.ceiling_height for s in load_scenes(PAIR_0_0_1)}  # type: ignore[union-attr]
    assert max(heights) < 9.0


def test_a_door_with_no_hole_names_both_forms(tmp_path: Path) -> None:
    raw = json.loads(PAIR_1_0_0.read_text())
    del raw["doors"][0]["holePolygon"]
    path = tmp_path / "house.json"
    path.write_text(json.dumps(raw))
    with pytest.raises(ImportFormatError, match=r"doors\[0\].*holePolygon \(house schema 1\.0\.0\).*boundingBox \(house schema 0\.0\.1\)"):
        load_scenes(path)


def test_a_schema_this_reader_does_not_know_is_refused(tmp_path: Path) -> None:
    """The multi-floor schema 2.0.0 of a ProcTHOR fork stacks storeys this reader would lay on one floor."""
    raw = json.loads(PAIR_1_0_0.read_text())
    raw["metadata"]["schema"] = "2.0.0"
    path = tmp_path / "house.json"
    path.write_text(json.dumps(raw))
    with pytest.raises(ImportFormatError, match=r"metadata\.schema.*'2\.0\.0' is not read.*0\.0\.1 and 1\.0\.0"):
        load_scenes(path)
    raw["metadata"]["schema"] = "1.1.0"  # a later minor version of 1 reads as 1.0.0
    path.write_text(json.dumps(raw))
    assert [s.room for s in load_scenes(path)] == [s.room for s in load_scenes(PAIR_1_0_0)]


def test_the_published_ai2thor_house_of_the_first_form_keeps_its_rooms_and_objects() -> None:
    raw = json.loads(AI2THOR_0_0_1.read_text())

    def count(items: list[dict[str, Any]]) -> int:
        return sum(1 + count(i.get("children") or []) for i in items)

    scenes = load_scenes(AI2THOR_0_0_1)
    assert [s.provenance.room_type for s in scenes] == ["Bedroom", "Bathroom", "Kitchen", "LivingRoom"]
    assert sum(len(s.objects) for s in scenes) == count(raw["objects"]) == 64
    assert all(math.isclose(s.room.ceiling_height, 2.9859275340171396) for s in scenes)  # type: ignore[union-attr]


def test_an_empty_wall_of_the_first_form_opens_the_rooms_onto_each_other() -> None:
    kitchen, living = (s for s in load_scenes(AI2THOR_OPEN_PLAN) if s.provenance.room_type in ("Kitchen", "LivingRoom"))
    for scene in (kitchen, living):
        assert scene.room is not None
        (opening,) = [o for w in scene.room.walls for o in w.openings if o.kind == "opening"]
        assert opening.height == pytest.approx(2.5878443992843385) and opening.width > 6.0

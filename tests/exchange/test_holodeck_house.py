"""Holodeck's multi-room output (issue 54): a whole house, read as a ProcTHOR house is (its rooms,
shared walls, doors between rooms), each object in the room its id names; a single-room output is
read as before. The house is joined from two real single-room outputs (``tests/holodeck_helpers.py``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from holodeck_helpers import BEDROOM, DINING, holodeck_house

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import is_house_source, load_house, load_scene, load_scenes
from scenemosaic.pipeline import GenerateConfig, generate
from scenemosaic.scene import House, Scene


def test_a_two_room_holodeck_house_is_a_house_of_its_rooms(tmp_path: Path) -> None:
    path = holodeck_house(tmp_path / "house.json")
    assert is_house_source(path)
    house = load_scene(path)
    assert isinstance(house, House)
    assert house.room_ids == ["bedroom", "depressed_dining_room"]
    alone = [load_scene(BEDROOM), load_scene(DINING)]
    for room, single in zip(house.rooms, alone, strict=True):
        assert isinstance(single, Scene)
        assert room.provenance.source_format == "holodeck"
        assert sorted(room.provenance.source_ids.values()) == sorted(single.provenance.source_ids.values())
        assert all(raw.endswith(f"({room.provenance.source_room_id})") for raw in room.provenance.source_ids.values())
        assert len(room.provenance.size_estimates) == sum(1 for s in single.metadata["holodeck"]["size_source"].values() if s != "asset_database")
    between = [d for d in house.doorways() if len(d.sides) == 2]
    assert len(between) == 1 and {s.room_id for s in between[0].sides} == set(house.room_ids)
    own = [o for r in house.rooms for w in r.room.walls for o in w.openings]
    assert len(own) == 2 * 1 + 2 + 3 + 2  # the shared door on both sides, each room's own door and windows


def test_a_single_room_output_is_one_scene_named_after_its_file() -> None:
    (scene,) = load_scenes(BEDROOM)
    assert scene.id == "lmg_holodeck_cozy_bedroom" and scene.provenance.source_room_id == "bedroom"


def test_a_door_onto_a_room_the_house_lacks_is_refused_unless_orphans_are_allowed(tmp_path: Path) -> None:
    path = holodeck_house(tmp_path / "house.json")
    data = json.loads(path.read_text(encoding="utf-8"))
    data["doors"][-1]["room1"] = "attic"
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(ImportFormatError, match="opens onto 'attic'"):
        load_house(path)
    house = load_house(path, allow_orphans=True)
    assert all(r.provenance.import_warnings for r in house.rooms)


@pytest.mark.house
def test_a_holodeck_house_runs_whole(tmp_path: Path) -> None:
    result = generate(holodeck_house(tmp_path / "house.json"), tmp_path / "run", GenerateConfig(variants=2, seed=0))
    report = result.report
    assert report["status"] in ("ok", "degraded")  # degraded by the rooms' own sources (docs/importers.md)
    assert report["variants_written"] == 2
    for world in ("base", "variant_1", "variant_2"):
        assert (tmp_path / "run" / world / "scene.xml").is_file()
        assert sorted(p.name for p in (tmp_path / "run" / world / "rooms").iterdir()) == ["bedroom", "depressed_dining_room"]

"""Holodeck's multi-room output (issue 54): a whole house, read as a ProcTHOR house is (its rooms,
shared walls, doors between rooms), each object in the room its id names; a single-room output is
read as before. The house is joined from two real single-room outputs (``tests/holodeck_helpers.py``):
their doors, where Holodeck left each room's floor free, made the one door between them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from holodeck_helpers import BEDROOM, DINING, holodeck_house

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import is_house_source, load_house, load_scene, load_scenes
from scenemosaic.pipeline import GenerateConfig, generate
from scenemosaic.scene import House, Scene, traits


def test_a_two_room_holodeck_house_is_a_house_of_its_rooms(tmp_path: Path) -> None:
    path = holodeck_house(tmp_path / "house.json")
    assert is_house_source(path)
    house = load_scene(path)
    assert isinstance(house, House)
    assert house.room_ids == ["depressed_dining_room", "bedroom"]
    alone = [load_scene(DINING), load_scene(BEDROOM)]
    for room, single in zip(house.rooms, alone, strict=True):
        assert isinstance(single, Scene)
        assert room.provenance.source_format == "holodeck"
        assert sorted(room.provenance.source_ids.values()) == sorted(single.provenance.source_ids.values())
        assert all(raw.endswith(f"({room.provenance.source_room_id})") for raw in room.provenance.source_ids.values())
        assert len(room.provenance.size_estimates) == sum(1 for s in single.metadata["holodeck"]["size_source"].values() if s != "asset_database")
    between = [d for d in house.doorways() if len(d.sides) == 2]
    assert len(between) == 1 and {s.room_id for s in between[0].sides} == set(house.room_ids)
    own = [o for r in house.rooms for w in r.room.walls for o in w.openings]
    assert len(own) == 2 * 1 + 2 + 3  # the shared door on both sides (each room's own door), their windows


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
def test_a_holodeck_house_runs_whole_and_valid(tmp_path: Path) -> None:
    """The house runs ``ok``: its generator's faults (small objects left off the receptacle their
    id names, a wall cabinet drawn 5 cm wide) mended on import and said, every room and variant
    without collision or object out of bounds, no door blocked, no variant cutting off floor."""
    result = generate(holodeck_house(tmp_path / "house.json"), tmp_path / "run", GenerateConfig(variants=2, seed=0))
    report = result.report
    assert report["status"] == "ok", report["warnings"]
    assert report["variants_written"] == 2
    for world in ("base", "variant_1", "variant_2"):
        assert (tmp_path / "run" / world / "scene.xml").is_file()
        assert sorted(p.name for p in (tmp_path / "run" / world / "rooms").iterdir()) == ["bedroom", "depressed_dining_room"]
    for room in report["metrics"]["rooms"].values():
        for row in (room["base"], *room["variants"]):
            assert row["COL"] == 0 and row["OOB"] == 0
    house = report["metrics"]["house"]
    base = house["base"]["house_nav"]
    for row in (house["base"], *house["variants"]):
        assert not row["door_blockers"] and not row["unreachable_rooms"]
        assert row["house_nav"] >= min(0.99, base - 0.005)
    faults = next(s for s in report["stages"] if s["name"] == "import")["detail"]["source_faults"]
    assert any("wall cabinet-0" in f and "sized as planned" in f for f in faults)
    assert any("the receptacle its id names" in f for f in faults)


def test_a_wall_object_drawn_far_smaller_than_planned_takes_the_planned_box() -> None:
    """The dining room's wall cabinets: footprint vertices 5 cm by 3 mm, planned 150 x 35 x 40 cm.
    Sized as planned (width the largest size, height the middle one, depth the least), the back
    where the drawn footprint's was (on the wall), hung on that wall, not standing on the floor."""
    scene = load_scene(DINING)
    assert isinstance(scene, Scene) and scene.room is not None
    for oid in ("wall_cabinet-0", "wall_cabinet-1"):
        cabinet = scene.get(oid)
        assert tuple(round(float(v), 3) for v in cabinet.size) == (1.5, 0.35, 0.4)
        assert min(abs(w.gap(cabinet.corners())) for w in scene.room.walls) < 0.02
        assert scene.metadata["holodeck"]["size_source"][oid] == "plan"
    assert sum("sized as planned" in f for f in scene.provenance.source_faults) == 2
    assert traits(scene.get("wall_cabinet-0").category).placement == "wall"


def test_a_small_object_of_no_known_type_on_its_receptacle_takes_the_files_height() -> None:
    """A small object whose name reads as no database type and that stands on the receptacle its
    id names is as wide as ``receptacle2small_objects`` records and twice its centre's height over
    the receptacle's top tall (the file's own cue), standing on that top; listed as an estimate."""
    path = DINING.parent / "lmg_holodeck_conference_room.json"
    (scene,) = load_scenes(path)
    raw = {o["id"]: o for o in json.loads(path.read_text(encoding="utf-8"))["objects"]}
    sources = scene.metadata["holodeck"]["size_source"]
    found = [oid for oid, how in sources.items() if how == "small_object_receptacle"]
    assert found
    for oid in found:
        obj = scene.get(oid)
        item = raw[scene.provenance.source_ids[oid]]
        holder = scene.get(next(r.parent for r in scene.relations if r.child == oid))
        top = float(holder.aabb()[1][2])
        assert obj.size[2] == pytest.approx(2 * (item["position"]["y"] - top))
        assert float(obj.aabb()[0][2]) == pytest.approx(top)
        assert "twice its centre's height over its receptacle's top" in scene.provenance.size_estimates[oid]

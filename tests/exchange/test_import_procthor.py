"""ProcTHOR house JSON: the two-room fixture against the published asset database."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from shapely.geometry import Polygon

from scenemosaic.exceptions import UsageError
from scenemosaic.exchange import SHARED_WALL_THICKNESS_M, detect_format, load_scene, load_scenes
from scenemosaic.scene import House, Scene, front_vector


def _flatten(
    objects: list[dict[str, Any]], parent: str | None = None
) -> list[tuple[dict[str, Any], str | None]]:
    out: list[tuple[dict[str, Any], str | None]] = []
    for obj in objects:
        out.append((obj, parent))
        out.extend(_flatten(obj.get("children", []), obj["id"]))
    return out


def _sid(raw: str) -> str:
    return raw.replace("|", "_")


@pytest.fixture(scope="module")
def house(procthor_house: Path, procthor_db: Path) -> list[Scene]:
    return load_scenes(procthor_house, asset_database=procthor_db)


def test_one_scene_per_room(procthor_house: Path, house: list[Scene]) -> None:
    raw = json.loads(procthor_house.read_text())
    assert detect_format(procthor_house) == "procthor"
    assert [s.id for s in house] == ["room_2", "room_3"]
    assert [s.provenance.room_type for s in house] == ["Bedroom", "LivingRoom"]
    everything = _flatten(raw["objects"])
    assert sum(len(s.objects) for s in house) == len(everything) == 12
    for scene in house:
        assert scene.provenance.source_format == "procthor"
        assert scene.room is not None and scene.room.ceiling_height == pytest.approx(2.7)


def test_objects_go_to_the_room_that_contains_them(house: list[Scene]) -> None:
    bedroom, living = house
    assert {o.id for o in bedroom.objects} >= {"Bed_2_0", "Pillow_2_0_0", "Dresser_2_1", "FloorLamp_2_3"}
    assert {o.id for o in living.objects} >= {"Sofa_3_4", "TVStand_3_6", "Television_3_6_0"}
    for scene in house:
        assert scene.room is not None
        xs = [p[0] for p in scene.room.floor]
        for obj in scene.objects:
            assert min(xs) <= obj.pose.position[0] <= max(xs), obj.id


def test_sizes_come_from_the_asset_database(
    procthor_house: Path, house: list[Scene], procthor_boxes: dict[str, dict[str, float]]
) -> None:
    raw = json.loads(procthor_house.read_text())
    by_id = {o.id: o for s in house for o in s.objects}
    for obj, _ in _flatten(raw["objects"]):
        box = procthor_boxes[obj["assetId"]]
        scene_obj = by_id[_sid(obj["id"])]
        assert scene_obj.asset.extents == pytest.approx((box["x"], box["z"], box["y"]), abs=1e-12)
        # position is the box centre, Y-up: our origin is the bottom centre
        assert scene_obj.pose.position[2] == pytest.approx(obj["position"]["y"] - box["y"] / 2, abs=1e-9)
        assert scene_obj.pose.position[:2] == pytest.approx((obj["position"]["x"], obj["position"]["z"]))
    assert by_id["Dresser_2_1"].category == "dresser"
    assert by_id["TVStand_3_6"].category == "tv_stand"


def test_children_become_attach_relations(procthor_house: Path, house: list[Scene]) -> None:
    raw = json.loads(procthor_house.read_text())
    expected = {(_sid(o["id"]), _sid(p)) for o, p in _flatten(raw["objects"]) if p is not None}
    got = {(r.child, r.parent) for s in house for r in s.relations}
    assert (
        got
        == expected
        == {
            ("Pillow_2_0_0", "Bed_2_0"),
            ("AlarmClock_2_1_0", "Dresser_2_1"),
            ("Television_3_6_0", "TVStand_3_6"),
        }
    )
    assert all(r.kind == "attach" for s in house for r in s.relations)
    top_level = {_sid(o["id"]) for o in raw["objects"]}
    for scene in house:
        assert not any(scene.support_of(oid) for oid in top_level if any(o.id == oid for o in scene.objects))


def test_wall_side_furniture_faces_into_the_room(house: list[Scene]) -> None:
    bedroom, living = house
    bed = bedroom.get("Bed_2_0")  # against the wall at y = 4
    assert front_vector(bed.pose.quaternion)[:2] == pytest.approx((0.0, -1.0), abs=1e-9)
    sofa = living.get("Sofa_3_4")  # against the wall at y = 0
    assert front_vector(sofa.pose.quaternion)[:2] == pytest.approx((0.0, 1.0), abs=1e-9)
    chair = living.get("ArmChair_3_7")  # east of the coffee table, turned towards it
    table = np.asarray(living.get("CoffeeTable_3_5").pose.position[:2])
    to_table = table - np.asarray(chair.pose.position[:2])
    cos = float(front_vector(chair.pose.quaternion)[:2] @ to_table / np.linalg.norm(to_table))
    assert math.degrees(math.acos(min(1.0, cos))) < 5


def test_door_and_window_become_openings(house: list[Scene]) -> None:
    bedroom, living = house
    assert bedroom.room is not None and living.room is not None
    bed_doors = [(w, o) for w in bedroom.room.walls for o in w.openings]
    liv_openings = [(w, o) for w in living.room.walls for o in w.openings]
    assert [o.kind for _, o in bed_doors] == ["door"]
    assert sorted(o.kind for _, o in liv_openings) == ["door", "window"]
    # the shared wall at x = 4 (2 m along z): each room's floor ends half a wall short of it
    half = SHARED_WALL_THICKNESS_M / 2
    for (wall, door), x in ((bed_doors[0], 4.0 - half), (next((w, o) for w, o in liv_openings if o.kind == "door"), 4.0 + half)):
        centre = np.asarray(wall.start) + wall.direction * door.center
        assert centre == pytest.approx((x, 2.0), abs=1e-9)
        assert (door.width, door.height, door.bottom) == pytest.approx((1.0, 2.1, 0.0))
    (doorway,) = House(rooms=house).doorways()  # the two cuts are one door between the rooms
    assert set(doorway.rooms) == {bedroom.id, living.id} and doorway.width == pytest.approx(1.0)
    wall, window = next((w, o) for w, o in liv_openings if o.kind == "window")
    centre = np.asarray(wall.start) + wall.direction * window.center
    assert centre == pytest.approx((8.0, 4.0 - 1.65), abs=1e-9)
    assert window.bottom == pytest.approx(0.9)


def test_asset_database_ships_with_the_package(
    procthor_house: Path, monkeypatch: pytest.MonkeyPatch, house: list[Scene]
) -> None:
    """No flag and no environment variable: the shipped database gives the same scenes."""
    for name in ("SCENEMOSAIC_PROCTHOR_DB", "SCENEMOSAIC_PRIORS_DIR"):
        monkeypatch.delenv(name, raising=False)
    assert [s.to_json() for s in load_scenes(procthor_house)] == [s.to_json() for s in house]


def test_load_scene_of_a_multi_room_house_is_the_house(procthor_house: Path, procthor_db: Path, house: list[Scene]) -> None:
    whole = load_scene(procthor_house, asset_database=procthor_db)
    assert isinstance(whole, House)
    assert whole.rooms == house and whole.room("room|3") == house[1]


def test_rooms_sharing_a_wall_give_up_half_of_it(house: list[Scene]) -> None:
    """The bedroom (x <= 4) and the living room (x >= 4) meet on x = 4: each floor stops half a
    wall short of it, so their walls there are one slab; exterior walls stay where they were."""
    bedroom, living = house
    assert bedroom.room is not None and living.room is not None
    half = SHARED_WALL_THICKNESS_M / 2
    assert max(x for x, _ in bedroom.room.floor) == pytest.approx(4.0 - half)
    assert min(x for x, _ in living.room.floor) == pytest.approx(4.0 + half)
    assert min(x for x, _ in bedroom.room.floor) == pytest.approx(0.0)  # an exterior wall
    for scene in house:  # furniture that stood on the half given up moved off it
        floor = Polygon(scene.room.floor).buffer(1e-6)
        assert all(floor.covers(Polygon(o.footprint())) for o in scene.objects if scene.support_of(o.id) is None)


def test_a_room_id_picks_one_room(procthor_house: Path, procthor_db: Path, house: list[Scene]) -> None:
    by_new_id = load_scene(procthor_house, room="room_3", asset_database=procthor_db)
    by_source_id = load_scene(procthor_house, room="room|3", asset_database=procthor_db)
    assert by_new_id == by_source_id == house[1]
    with pytest.raises(UsageError, match=r"no room 'kitchen'.*room\|2"):
        load_scene(procthor_house, room="kitchen", asset_database=procthor_db)


def test_each_window_and_door_is_cut_once_per_room_it_opens_onto() -> None:
    """An exterior window lists the same room on both sides: one opening, not a mirrored pair."""
    houses = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"
    for path in sorted(houses.glob("procthor_*.json")):
        raw = json.loads(path.read_text(encoding="utf-8"))
        expected = {"door": 0, "window": 0}
        for key, kind in (("doors", "door"), ("windows", "window")):
            for item in raw.get(key, []):
                expected[kind] += len({item.get("room0"), item.get("room1")} & {r["id"] for r in raw["rooms"]})
        got = {"door": 0, "window": 0}
        for scene in load_scenes(path):
            assert scene.room is not None
            for wall in scene.room.walls:
                for opening in wall.openings:
                    if opening.kind != "opening":  # an `empty` wall: no door, no window
                        got[opening.kind] += 1
        assert got == expected, path.name


def test_the_source_facts_are_typed_and_a_file_from_before_still_reads(house: list[Scene], tmp_path: Path) -> None:
    """Room type, source ids and asset ids are ``Provenance`` fields every reader fills (nothing
    above the readers looks into ``metadata``); a scene file that kept them in
    ``metadata["procthor"]`` (written before) reads back with them typed, and writes back."""
    import json

    from scenemosaic.exchange import read_scene, save_scene

    room = house[0]
    assert room.metadata == {} and room.provenance.room_type == "Bedroom"
    assert room.provenance.source_room_id is not None
    assert set(room.provenance.source_ids) <= {o.id for o in room.objects} and room.provenance.source_ids
    assert room.provenance.asset_ids and room.provenance.asset_database
    folder = save_scene(room, tmp_path / "now").parent
    data = json.loads((folder / "scene.json").read_text())
    old = dict(data["provenance"])
    moved = {k: old.pop(v) for k, v in (("room_id", "source_room_id"), ("room_type", "room_type"), ("source_ids", "source_ids"),
                                       ("asset_ids", "asset_ids"), ("asset_database", "asset_database"))}
    data["provenance"], data["metadata"] = old, {"procthor": moved}
    (folder / "scene.json").write_text(json.dumps(data))
    again = read_scene(folder)
    assert again.provenance == room.provenance and again.metadata == {}

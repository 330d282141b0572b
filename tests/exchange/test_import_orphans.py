"""Objects outside every room, rooms missing, doors onto no room (issue 37, item 5).

A house whose record of a room is missing used to import with that room's objects silently moved
into the nearest room. Now such an *orphan* (a top-level object whose centre lies more than
``OUTSIDE_ROOM_TOLERANCE_M`` outside every floor polygon), and a door or window naming a room the
file does not hold, fail the import naming them, unless ``allow_orphans``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import load_house, load_scenes
from scenemosaic.exchange._procthor import OUTSIDE_ROOM_TOLERANCE_M

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses"
FOUR_ROOMS = HOUSES / "procthor" / "procthor_4room.json"
SHIPPED = sorted(p for p in HOUSES.glob("*/*.json") if p.name != "SOURCES.json")


def _write(tmp_path: Path, raw: dict[str, Any]) -> Path:
    path = tmp_path / "house.json"
    path.write_text(json.dumps(raw), encoding="utf-8")
    return path


def _without_bathroom(tmp_path: Path) -> Path:
    raw = json.loads(FOUR_ROOMS.read_text(encoding="utf-8"))
    raw["rooms"] = [r for r in raw["rooms"] if r["roomType"] != "Bathroom"]
    return _write(tmp_path, raw)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_no_shipped_house_has_an_orphan(path: Path) -> None:
    """Every shipped house imports without ``allow_orphans``, and none needed the tolerance's
    nearest-room rule either: no top-level object's centre lies outside every floor."""
    scenes = load_scenes(path)
    assert not any(s.provenance.import_warnings for s in scenes)
    assert not any("outside every floor polygon" in n for s in scenes for n in s.provenance.notes)


def test_a_missing_room_fails_the_import_naming_its_objects_and_doors(tmp_path: Path) -> None:
    path = _without_bathroom(tmp_path)
    with pytest.raises(ImportFormatError) as caught:
        load_scenes(path)
    text = str(caught.value)
    assert caught.value.field == "objects"
    assert "4 object(s) lie outside every room" in text
    for oid, asset in (("5|0", "Toilet_2"), ("5|1|0", "Sink_15"), ("5|2", "bin_22"), ("5|4", "Wall_Decor_Photo_10")):
        assert f"'{oid}' ({asset}, " in text
    assert "nearest room 'room|6' (Kitchen)" in text
    assert "doors[0] ('door|4|5') opens onto 'room|5'" in text
    assert "--allow-orphans" in text


def test_allowed_orphans_go_to_the_nearest_room_and_every_room_says_so(tmp_path: Path) -> None:
    path = _without_bathroom(tmp_path)
    house = load_house(path, allow_orphans=True)
    kitchen = house.room("room|6")
    ids = {kitchen.provenance.source_ids.get(o.id) for o in kitchen.objects}
    assert {"5|0", "5|1|0", "5|2", "5|4"} <= ids
    for room in house.rooms:
        warnings = room.provenance.import_warnings
        assert warnings[0].startswith("4 object(s) lie outside every room") and "each put in the nearest room" in warnings[0]
        assert "'room|5'" in warnings[1]
    notes = [n for n in kitchen.provenance.notes if "outside every floor polygon" in n and "(allow_orphans)" in n]
    assert len(notes) == 4  # and one bathroom piece within the tolerance of the kitchen's floor, as for any house
    # the bedroom keeps its side of the door to the missing bathroom
    bedroom = house.room("room|4")
    assert sum(o.kind == "door" for w in bedroom.room.walls for o in w.openings) == 2  # type: ignore[union-attr]


def test_a_door_onto_a_room_the_house_does_not_hold_fails_alone(tmp_path: Path) -> None:
    raw = json.loads(FOUR_ROOMS.read_text(encoding="utf-8"))
    raw["doors"][1]["room1"] = "room|99"
    path = _write(tmp_path, raw)
    with pytest.raises(ImportFormatError, match=r"doors\[1\] \('door\|4\|7'\) opens onto 'room\|99'") as caught:
        load_scenes(path)
    assert caught.value.field == "doors" and "object(s)" not in str(caught.value)
    assert load_scenes(path, allow_orphans=True)


def test_the_outside_is_no_missing_room(tmp_path: Path) -> None:
    """An exterior door names its room twice (ProcTHOR) or the outside as ``exterior`` (Holodeck)."""
    raw = json.loads(FOUR_ROOMS.read_text(encoding="utf-8"))
    exterior = next(d for d in raw["doors"] if d["room0"] == d["room1"])
    exterior["room0"] = "exterior"
    scenes = load_scenes(_write(tmp_path, raw))
    assert not any(s.provenance.import_warnings for s in scenes)


def test_an_object_a_few_centimetres_out_goes_to_its_room(tmp_path: Path) -> None:
    """Within the tolerance an object is its nearest room's, with a provenance note (real files
    push pieces against, and a little into, their walls)."""
    raw = json.loads(FOUR_ROOMS.read_text(encoding="utf-8"))
    floors = {r["id"]: [(p["x"], p["z"]) for p in r["floorPolygon"]] for r in raw["rooms"]}
    low_x = min(x for pts in floors.values() for x, _ in pts)
    item = next(o for o in raw["objects"] if abs(o["position"]["x"] - low_x) < 1.0)
    source_id = item["id"]
    for near, far in ((0.05, False), (OUTSIDE_ROOM_TOLERANCE_M + 0.05, True)):
        item["position"]["x"] = low_x - near
        path = _write(tmp_path, raw)
        if far:
            with pytest.raises(ImportFormatError, match=r"1 object\(s\) lie outside every room.*" + re.escape(f"'{source_id}'")):
                load_scenes(path)
            continue
        scenes = load_scenes(path)
        owner = next(s for s in scenes if source_id in s.provenance.source_ids.values())
        assert any("lies outside every floor polygon; assigned to the nearest room" in n for n in owner.provenance.notes)

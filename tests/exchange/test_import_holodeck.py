"""Holodeck single-room output: the real living room in data/, checked against its raw JSON, and bad input
(a whole house: ``test_holodeck_house.py``)."""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import load_asset_database
from scenemosaic.exchange._holodeck import (
    RECEPTACLE_REACH_M,
    _type_name,
    import_holodeck,
    looks_like_holodeck,
)
from scenemosaic.exchange._procthor import _nearest_type, looks_like_procthor
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, Scene, front_vector


@pytest.fixture(scope="module")
def holodeck_path(repo_data: Path) -> Path:
    path = repo_data / "layouts" / "holodeck" / "holodeck_living_room.json"
    assert path.is_file(), path
    return path


@pytest.fixture(scope="module")
def raw(holodeck_path: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(holodeck_path.read_text())
    return data


@pytest.fixture(scope="module")
def scene(raw: dict[str, Any], holodeck_path: Path) -> Scene:
    (scene,) = import_holodeck(copy.deepcopy(raw), holodeck_path)
    return scene


DB = load_asset_database(None)


def _source_ids(scene: Scene) -> dict[str, str]:
    ids: dict[str, str] = scene.provenance.source_ids
    return ids


def _by_source(scene: Scene) -> dict[str, Any]:
    return {raw_id: scene.get(oid) for oid, raw_id in _source_ids(scene).items()}


# -- detection ------------------------------------------------------------------------------------


def test_detection(raw: dict[str, Any], repo_data: Path) -> None:
    assert looks_like_holodeck(raw)
    # the file is also a valid ProcTHOR house: Holodeck detection must be tried first
    assert looks_like_procthor(raw)
    for house in sorted((repo_data / "houses" / "procthor").glob("procthor_*.json")):
        assert not looks_like_holodeck(json.loads(house.read_text())), house.name
    assert not looks_like_holodeck({"ThreedFront": {}})
    assert not looks_like_holodeck({"rooms": [], "objects": []})


# -- the real room --------------------------------------------------------------------------------


def test_every_object_is_imported(raw: dict[str, Any], scene: Scene) -> None:
    assert len(scene.objects) == len(raw["objects"]) == 33
    assert sorted(_source_ids(scene).values()) == sorted(o["id"] for o in raw["objects"])
    assert scene.provenance.source_format == "holodeck"
    source = scene.provenance  # the source's facts, typed
    assert source.room_type == raw["rooms"][0]["roomType"]
    assert set(source.asset_ids.values()) == {o["assetId"] for o in raw["objects"]}
    for obj in scene.objects:
        assert obj.asset.kind == "procedural"
        pose = obj.pose
        assert all(
            math.isfinite(v) for v in (*pose.position, *pose.quaternion, *pose.scale, *obj.asset.extents)
        )


def test_small_objects_attach_to_the_parent_their_id_names(raw: dict[str, Any], scene: Scene) -> None:
    small = [o["id"] for o in raw["objects"] if "|" in o["id"]]
    assert len(small) == len(raw["small_objects"]) == 12
    by_source = _by_source(scene)
    expected = {(by_source[s].id, by_source[s.split("|", 1)[1]].id) for s in small}
    got = {(r.child, r.parent) for r in scene.relations}
    assert got == expected
    assert all(r.kind == "attach" for r in scene.relations)
    # parents are the named floor/wall objects, e.g. the sofa
    assert scene.support_of("throw_pillow-0_sectional_sofa-0") is not None
    assert scene.support_of("throw_pillow-0_sectional_sofa-0").parent == "sectional_sofa-0"  # type: ignore[union-attr]


def test_room_from_the_floor_polygon_walls_doors_and_windows(raw: dict[str, Any], scene: Scene) -> None:
    room = scene.room
    assert room is not None
    floor = {(p["x"], p["z"]) for p in raw["rooms"][0]["floorPolygon"]}
    assert set(room.floor) == floor
    assert len(room.walls) == len(floor)
    assert room.ceiling_height == pytest.approx(raw["wall_height"])
    assert all(w.height == pytest.approx(raw["wall_height"]) for w in room.walls)

    def placed(segment: list[list[float]], kind: str) -> None:
        mid = np.mean(np.asarray(segment, dtype=float), axis=0)
        width = math.dist(segment[0], segment[1])
        hits = []
        for wall in room.walls:
            for op in wall.openings:
                centre = np.asarray(wall.start) + wall.direction * op.center
                if op.kind == kind and np.allclose(centre, mid, atol=1e-6):
                    hits.append(op)
        assert len(hits) == 1, (kind, segment)
        assert hits[0].width == pytest.approx(width)

    for door in raw["doors"]:
        placed(door["doorSegment"], "door")
    for window in raw["windows"]:
        placed(window["windowSegment"], "window")
    assert sum(len(w.openings) for w in room.walls) == len(raw["doors"]) + len(raw["windows"])


def test_objects_are_inside_or_near_the_floor(raw: dict[str, Any], scene: Scene) -> None:
    polygon = Polygon([(p["x"], p["z"]) for p in raw["rooms"][0]["floorPolygon"]]).buffer(0.05)
    for obj in scene.objects:
        x, y, z = obj.pose.position
        assert polygon.covers(Point(x, y)), obj.id
        assert -1e-9 <= z < raw["wall_height"], obj.id


def test_floor_objects_match_their_footprints(raw: dict[str, Any], scene: Scene) -> None:
    """World footprint of each floor object = Holodeck's vertices (cm); it stands on the floor, 2 y tall."""
    by_source = _by_source(scene)
    for entry in raw["floor_objects"]:
        obj = by_source[entry["id"]]
        verts = np.asarray(entry["vertices"], dtype=float) / 100.0
        foot = obj.footprint()
        np.testing.assert_allclose(foot.min(axis=0), verts.min(axis=0), atol=1e-6, err_msg=obj.id)
        np.testing.assert_allclose(foot.max(axis=0), verts.max(axis=0), atol=1e-6, err_msg=obj.id)
        assert obj.pose.position[2] == pytest.approx(0.0, abs=1e-9)
        assert obj.size[2] == pytest.approx(2 * entry["position"]["y"])


def test_objects_face_into_the_room(scene: Scene) -> None:
    """Unity rotation.y: 90 faces +x, 270 faces -x, 180 faces -z (our -y), 0 faces +z (our +y)."""
    expected = {
        "tv_stand-0": (1.0, 0.0),
        "sectional_sofa-0": (-1.0, 0.0),
        "bookshelf-1": (0.0, -1.0),
        "wall_shelf-2": (0.0, 1.0),
        "painting-2": (-1.0, 0.0),
    }
    for oid, direction in expected.items():
        np.testing.assert_allclose(
            front_vector(scene.get(oid).pose.quaternion)[:2], direction, atol=1e-9, err_msg=oid
        )


def test_sizes_of_wall_small_and_database_objects(raw: dict[str, Any], scene: Scene) -> None:
    by_source = _by_source(scene)
    sources = scene.metadata["holodeck"]["size_source"]
    plan = raw["object_selection_plan"][raw["rooms"][0]["roomType"]]
    db = json.loads((PROCTHOR_PRIORS_DIR / "asset-database.json").read_text())
    db_boxes = {e["assetId"]: e["boundingBox"] for entries in db.values() for e in entries}
    for entry in raw["wall_objects"]:
        obj = by_source[entry["id"]]
        if entry["assetId"] in db_boxes:  # an AI2-THOR asset: its exact box
            box = db_boxes[entry["assetId"]]
            np.testing.assert_allclose(obj.asset.extents, (box["x"], box["z"], box["y"]), atol=1e-9)
            assert sources[obj.id] == "asset_database"
        else:  # the plan's middle dimension, cm
            planned = sorted(plan[entry["object_name"].rsplit("-", 1)[0]]["size"])
            assert obj.asset.extents[2] == pytest.approx(planned[1] / 100.0)
            assert obj.pose.position[2] + obj.asset.extents[2] / 2 == pytest.approx(entry["position"]["y"])
    kinds = DB.type_boxes
    for entry in raw["small_objects"]:
        obj = by_source[entry["id"]]
        name, parent = entry["id"].split("|", 1)
        side = next(row[2] for row in raw["receptacle2small_objects"][parent] if row[0] == name)
        ex = np.asarray(obj.asset.extents)
        if sources[obj.id] == "small_object_type":  # its type's proportions, as wide as recorded
            match = _nearest_type(_type_name(name), kinds)
            assert match is not None
            tx, ty, tz = kinds[match]
            np.testing.assert_allclose(ex, np.array([tx, tz, ty]) * side / max(tx, tz), atol=1e-9)
        elif sources[obj.id] == "small_object_receptacle":  # on its receptacle: twice its centre's height over the top
            holder = by_source[parent]
            assert ex[0] == ex[1] == pytest.approx(side)
            assert ex[2] == pytest.approx(2 * (entry["position"]["y"] - float(holder.aabb()[1][2])))
        else:
            assert sources[obj.id] == "small_object_extent" and _nearest_type(_type_name(name), kinds) is None
            np.testing.assert_allclose(ex, (side, side, side))
    assert sum(1 for s in sources.values() if s == "asset_database") == sum(
        1 for o in raw["objects"] if o["assetId"] in db_boxes
    )


def test_the_stacked_small_objects_are_noted(raw: dict[str, Any], scene: Scene) -> None:
    small = [o for o in raw["objects"] if "|" in o["id"]]
    distinct = {tuple(o["position"][k] for k in "xyz") for o in small}
    assert (len(small), len(distinct)) == (12, 4)
    assert any(
        f"{len(small)} small objects sit at only {len(distinct)} distinct positions" in n
        for n in scene.provenance.notes
    )
    # one standing on the receptacle its id names is kept at its stated centre; one standing off
    # it (the generator left it at another one's place) is put on that receptacle, named
    by_source = _by_source(scene)
    moved = 0
    for o in small:
        obj = by_source[o["id"]]
        holder = by_source[o["id"].split("|", 1)[1]]
        stated = Point(o["position"]["x"], o["position"]["z"])
        if Polygon(holder.footprint()).buffer(RECEPTACLE_REACH_M).contains(stated):
            np.testing.assert_allclose(obj.pose.position[:2], (stated.x, stated.y), atol=1e-9)
            continue
        moved += 1
        np.testing.assert_allclose(obj.pose.position[:2], Polygon(holder.footprint()).centroid.coords[0], atol=1e-9)
        assert float(obj.aabb()[0][2]) == pytest.approx(float(holder.aabb()[1][2]))
        assert any(f"{obj.id}: stood" in f and holder.id in f for f in scene.provenance.source_faults)
    assert moved == len(scene.provenance.source_faults) > 0


def test_hand_added_assets_are_noted(raw: dict[str, Any], scene: Scene) -> None:
    listed = {o["id"] for key in ("floor_objects", "wall_objects", "small_objects") for o in raw[key]}
    custom = [i for i, o in enumerate(raw["objects"]) if o["id"] not in listed]
    assert len(custom) == 3
    for i in custom:
        assert any(n.startswith(f"objects[{i}] ") and "centred" in n for n in scene.provenance.notes)


def test_an_asset_database_gives_exact_sizes(raw: dict[str, Any], holodeck_path: Path) -> None:
    sofa = next(o for o in raw["objects"] if o["id"].startswith("sectional_sofa-0"))
    db = {sofa["assetId"]: {"boundingBox": {"x": 2.0, "y": 0.8, "z": 0.9}, "objectType": "Sofa"}}
    (scene,) = import_holodeck(copy.deepcopy(raw), holodeck_path, asset_database=db)
    obj = scene.get("sectional_sofa-0")
    assert obj.asset.extents == (2.0, 0.9, 0.8)
    assert obj.pose.position[2] == pytest.approx(sofa["position"]["y"] - 0.4)


# -- bad input ------------------------------------------------------------------------------------


def _index(raw: dict[str, Any], pred: Callable[[dict[str, Any]], bool]) -> int:
    return next(i for i, o in enumerate(raw["objects"]) if pred(o))


def _floor(raw: dict[str, Any]) -> int:
    return _index(raw, lambda o: o["id"].startswith("coffee_table-0"))


def _wall(raw: dict[str, Any]) -> int:
    return _index(raw, lambda o: o["id"].startswith("wall_shelf-0 "))


def _small(raw: dict[str, Any]) -> int:
    return _index(raw, lambda o: o["id"].startswith("50 inch tv-0|"))


def _drop_rooms(d: dict[str, Any]) -> str:
    del d["rooms"]
    return "rooms"


def _no_position(d: dict[str, Any]) -> str:
    del d["objects"][_floor(d)]["position"]
    return f"objects[{_floor(d)}].position"


def _nan_rotation(d: dict[str, Any]) -> str:
    d["objects"][_floor(d)]["rotation"]["y"] = float("nan")
    return f"objects[{_floor(d)}].rotation.y"


def _no_asset(d: dict[str, Any]) -> str:
    del d["objects"][_floor(d)]["assetId"]
    return f"objects[{_floor(d)}].assetId"


def _no_vertices(d: dict[str, Any]) -> str:
    del d["objects"][_floor(d)]["vertices"]
    return f"objects[{_floor(d)}].vertices"


def _flat_vertices(d: dict[str, Any]) -> str:
    d["objects"][_floor(d)]["vertices"] = [[100, 100], [200, 100], [300, 100]]
    return f"objects[{_floor(d)}].vertices"


def _sunk(d: dict[str, Any]) -> str:
    d["objects"][_floor(d)]["position"]["y"] = 0.0
    return f"objects[{_floor(d)}].position.y"


def _wall_without_plan(d: dict[str, Any]) -> str:
    del d["object_selection_plan"]["living room"]["wall_shelf"]
    return f"objects[{_wall(d)}].vertices"


def _small_unlisted(d: dict[str, Any]) -> str:
    d["receptacle2small_objects"]["tv_stand-0 (living room)"] = []
    return f"objects[{_small(d)}].id"


def _duplicate_id(d: dict[str, Any]) -> str:
    d["objects"][4]["id"] = d["objects"][3]["id"]
    return "objects[4].id"


def _bad_door_wall(d: dict[str, Any]) -> str:
    d["doors"][0]["wall0"] = "wall|nowhere"
    return "doors[0].wall0"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (_drop_rooms, "missing required field"),
        (_no_position, "missing required field"),
        (_nan_rotation, "finite"),
        (_no_asset, "missing required field"),
        (_no_vertices, "has no size"),
        (_flat_vertices, "zero width or depth"),
        (_sunk, "above the floor"),
        (_wall_without_plan, "has no height"),
        (_small_unlisted, "has no size"),
        (_duplicate_id, "duplicate id"),
        (_bad_door_wall, "no wall with id"),
    ],
)
def test_bad_input_names_the_field(
    raw: dict[str, Any], holodeck_path: Path, edit: Callable[[dict[str, Any]], str], message: str
) -> None:
    data = copy.deepcopy(raw)
    field = edit(data)
    with pytest.raises(ImportFormatError, match=message) as info:
        import_holodeck(data, holodeck_path)
    assert info.value.field == field
    assert info.value.path == str(holodeck_path)


def test_a_missing_parent_is_noted_not_fatal(raw: dict[str, Any], holodeck_path: Path) -> None:
    data = copy.deepcopy(raw)
    tv = _small(data)
    data["objects"][tv]["id"] = "50 inch tv-0|gone-0 (living room)"
    data["receptacle2small_objects"]["gone-0 (living room)"] = [["50 inch tv-0", "x", 0.8]]
    (scene,) = import_holodeck(data, holodeck_path)
    assert len(scene.objects) == 33 and len(scene.relations) == 11
    assert any(f"objects[{tv}]: parent 'gone-0 (living room)'" in n for n in scene.provenance.notes)

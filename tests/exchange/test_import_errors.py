"""Bad input: every importer names the file and the field."""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.exchange import detect_format, load_scene, load_scenes
from scenemosaic.scene import Room


def _write(tmp_path: Path, name: str, data: Any) -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))  # json writes NaN as the bare NaN token, as Python's own tools do
    return path


# -- 3D-FRONT ------------------------------------------------------------------------------------


@pytest.fixture
def front3d(physcene_files: list[Path]) -> dict[str, Any]:
    path = next(p for p in physcene_files if p.name.startswith("DiningRoom-19325"))
    data: dict[str, Any] = json.loads(path.read_text())
    return data


def _first(data: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    model = next(iter(data["ThreedFront"]))
    return model, data["ThreedFront"][model][0]


def _del_size(o: dict[str, Any]) -> None:
    del o["size"]


def _str_theta(o: dict[str, Any]) -> None:
    o["theta"] = "north"


def _nan_position(o: dict[str, Any]) -> None:
    o["position"][1] = math.nan


def _bad_label(o: dict[str, Any]) -> None:
    o["label"] = "chair/stool (1)"


def _short_size(o: dict[str, Any]) -> None:
    o["size"] = [0.3, 0.4]


def _negative_size(o: dict[str, Any]) -> None:
    o["size"] = [0.3, -0.4, 0.2]


@pytest.mark.parametrize(
    ("mutate", "field", "words"),
    [
        (_del_size, "size", "missing required field"),
        (_str_theta, "theta", "expected a number"),
        (_nan_position, "position[1]", "must be finite"),
        (_bad_label, "label", "not a category name"),
        (_short_size, "size", "expected 3 numbers"),
        (_negative_size, "size", "positive"),
    ],
)
def test_front3d_bad_object(
    front3d: dict[str, Any],
    tmp_path: Path,
    mutate: Callable[[dict[str, Any]], None],
    field: str,
    words: str,
) -> None:
    data = copy.deepcopy(front3d)
    model, obj = _first(data)
    mutate(obj)
    path = _write(tmp_path, "layout.json", data)
    with pytest.raises(ImportFormatError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}: ThreedFront.{model}[0].{field}: ")
    assert words in str(info.value)
    assert info.value.path == str(path) and info.value.field == f"ThreedFront.{model}[0].{field}"


def test_front3d_wrong_container_types(tmp_path: Path) -> None:
    path = _write(tmp_path, "a.json", {"ThreedFront": [1, 2]})
    with pytest.raises(ImportFormatError, match="ThreedFront: expected a JSON object"):
        load_scene(path)
    path = _write(tmp_path, "b.json", {"ThreedFront": {"m": {"label": "bed"}}})
    with pytest.raises(ImportFormatError, match=r"ThreedFront\.m: expected a JSON array"):
        load_scene(path)
    path = _write(tmp_path, "c.json", {"ThreedFront": {}})
    with pytest.raises(ImportFormatError, match="no objects"):
        load_scene(path)


def test_labels_are_normalized(front3d: dict[str, Any], tmp_path: Path) -> None:
    data = copy.deepcopy(front3d)
    _, obj = _first(data)
    obj["label"] = "Dining Chair"
    scene = load_scene(_write(tmp_path, "layout.json", data))
    assert scene.objects[0].category == "dining_chair"


def test_room_only_for_single_room_formats(procthor_house: Path, procthor_db: Path) -> None:
    with pytest.raises(UsageError, match="room="):
        load_scenes(procthor_house, room=Room.rectangle(0, 0, 1, 1), asset_database=procthor_db)


# -- ProcTHOR ------------------------------------------------------------------------------------


@pytest.fixture
def house(procthor_house: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(procthor_house.read_text())
    return data


@pytest.mark.parametrize(
    ("edit", "field", "words"),
    [
        (lambda h: h["objects"][2].pop("assetId"), "objects[2].assetId", "missing required field"),
        (lambda h: h["objects"][1]["rotation"].update(y="90"), "objects[1].rotation.y", "expected a number"),
        (lambda h: h["objects"][3]["position"].update(x=math.nan), "objects[3].position.x", "finite"),
        (
            lambda h: h["objects"][0]["children"][0].pop("position"),
            "objects[0].children[0].position",
            "missing required field",
        ),
        (
            lambda h: h["rooms"][1].update(floorPolygon=[{"x": 0, "y": 0, "z": 0}]),
            "rooms[1].floorPolygon",
            "3 points",
        ),
        (lambda h: h["walls"][0].update(polygon="flat"), "walls[0].polygon", "expected a JSON array"),
        (lambda h: h["doors"][0].update(holePolygon=[{"x": 1}]), "doors[0].holePolygon", "two corners"),
    ],
)
def test_procthor_bad_input(
    house: dict[str, Any],
    procthor_db: Path,
    tmp_path: Path,
    edit: Callable[[dict[str, Any]], Any],
    field: str,
    words: str,
) -> None:
    data = copy.deepcopy(house)
    edit(data)
    path = _write(tmp_path, "house.json", data)
    with pytest.raises(ImportFormatError) as info:
        load_scenes(path, asset_database=procthor_db)
    assert str(info.value).startswith(f"{path}: {field}: "), str(info.value)
    assert words in str(info.value)


def test_procthor_bad_database(house: dict[str, Any], tmp_path: Path) -> None:
    path = _write(tmp_path, "house.json", house)
    with pytest.raises(ImportFormatError, match="asset database not found"):
        load_scenes(path, asset_database=tmp_path / "nope.json")
    db = _write(
        tmp_path, "db.json", {"Bed": [{"assetId": "Bed_1", "boundingBox": {"x": 1, "y": "tall", "z": 2}}]}
    )
    with pytest.raises(ImportFormatError, match=r"db\.json: Bed\[0\]\.boundingBox\.y: expected a number"):
        load_scenes(path, asset_database=db)


# -- SAM3D -----------------------------------------------------------------------------------------


@pytest.fixture
def poses(link_sam3d_example: Callable[[Path], dict[str, Any]], tmp_path: Path) -> dict[str, Any]:
    """The example's poses, with its meshes linked into ``tmp_path`` (where the edited file goes)."""
    return link_sam3d_example(tmp_path)


@pytest.mark.parametrize(
    ("edit", "field", "words"),
    [
        (lambda d: d["objects"][1].pop("mesh"), "objects[1].mesh", "missing required field"),
        (lambda d: d["objects"][1].update(mesh="missing/chair.glb"), "objects[1].mesh", "not found"),
        (lambda d: d["objects"][2]["position"].__setitem__(0, math.nan), "objects[2].position[0]", "finite"),
        (
            lambda d: d["objects"][2].update(quaternion=[1, 0, 0]),
            "objects[2].quaternion",
            "expected 4 numbers",
        ),
        (lambda d: d["objects"][2].update(quaternion=[0, 0, 0, 0]), "objects[2].quaternion", "zero norm"),
        (lambda d: d["objects"][0].update(scale=[1, 0, 1]), "objects[0].scale", "positive"),
        (lambda d: d["objects"][0].update(label=7), "objects[0].label", "expected a string"),
        (lambda d: d["objects"][0].update(frame="x_up"), "objects[0].frame", "unknown frame"),
        (lambda d: d.update(units="furlong"), "units", "unknown units"),
        (lambda d: d["objects"][4].update(front="up"), "objects[4].front", "unknown front axis"),
        (lambda d: d["objects"][4].update(up_axis="x"), "objects[4].up_axis", "unknown up axis"),
        (lambda d: d["objects"][3].update(sim={"mass_kg": -1}), "objects[3].sim.mass_kg", "greater than 0"),
        (lambda d: d["room"].update(floor=[[0, 0], [1, 1], [2, 2]]), "room.floor", "zero area"),
    ],
)
def test_sam3d_bad_input(
    poses: dict[str, Any],
    sam3d_example: Path,
    tmp_path: Path,
    edit: Callable[[dict[str, Any]], Any],
    field: str,
    words: str,
) -> None:
    data = copy.deepcopy(poses)
    edit(data)
    path = _write(tmp_path, "poses.json", data)
    with pytest.raises(ImportFormatError) as info:
        load_scene(tmp_path)
    assert str(info.value).startswith(f"{path}: {field}: "), str(info.value)
    assert words in str(info.value)


# -- detection and truncated files ----------------------------------------------------------------


def test_truncated_json_names_the_file(
    physcene_files: list[Path], procthor_house: Path, tmp_path: Path
) -> None:
    for i, source in enumerate([physcene_files[0], procthor_house]):
        text = source.read_text()
        path = tmp_path / f"cut_{i}.json"
        path.write_text(text[: len(text) // 2])
        with pytest.raises(ImportFormatError, match=rf"cut_{i}\.json: invalid JSON at line \d+"):
            load_scenes(path)


def test_unknown_format(tmp_path: Path) -> None:
    path = _write(tmp_path, "thing.json", {"vertices": [1, 2, 3]})
    with pytest.raises(ImportFormatError, match=r"thing\.json: unknown format"):
        load_scene(path)
    with pytest.raises(ImportFormatError, match=r"thing\.json: unknown format"):
        detect_format(path)
    with pytest.raises(ImportFormatError, match="format: unknown format 'obj'"):
        load_scene(path, format="obj")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ImportFormatError, match="no scene file"):
        load_scenes(tmp_path / "empty")
    with pytest.raises(ImportFormatError, match=r"neither poses\.json nor scene\.json"):
        detect_format(tmp_path / "empty")
    with pytest.raises(ImportFormatError, match="file not found"):
        load_scene(tmp_path / "absent.json")


def test_detection_rules(physcene_files: list[Path], procthor_house: Path, tmp_path: Path) -> None:
    assert detect_format(physcene_files[0]) == "front3d"
    assert detect_format(procthor_house) == "procthor"
    sam = _write(
        tmp_path, "objs.json", {"objects": [{"label": "bed", "mesh": "bed.glb", "position": [0, 0, 0]}]}
    )
    assert detect_format(sam) == "sam3d"
    native = _write(tmp_path, "scene_copy.json", {"id": "s", "objects": []})
    assert detect_format(native) == "native"
    assert load_scene(native).id == "s"

"""Degenerate numbers and awkward ids through ``load_scene``: errors that name file, object and field."""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from scenemosaic.exceptions import ImportFormatError, SceneMosaicError, SceneValidationError
from scenemosaic.exchange import load_scene, load_scenes, save_scene
from scenemosaic.scene import MAX_OBJECTS, AssetRef, Pose, Scene, SceneObject, sanitize_id


def _front3d(tmp_path: Path, **item: Any) -> Path:
    entry = {"label": "chair", "size": [0.25, 0.45, 0.2], "position": [1.0, 0.0, 1.0], "theta": 0.0, **item}
    path = tmp_path / "layout.json"
    path.write_text(json.dumps({"ThreedFront": {"model_a": [entry]}}))
    return path


# -- numbers -----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("item", "field", "words"),
    [
        ({"size": [1e-9, 0.45, 0.2]}, "ThreedFront.model_a[0].size", "size along x is 2e-09 m, below the 0.001 m"),
        ({"size": [0.25, 80.0, 0.2]}, "ThreedFront.model_a[0].size", "above the 100 m maximum"),
        ({"position": [1.0, 0.0, 5000.0]}, "ThreedFront.model_a[0].position", "coordinate 2 is 5000 m"),
        ({"position": [1.0, math.nan, 1.0]}, "ThreedFront.model_a[0].position[1]", "finite"),
        ({"size": [0.25, math.inf, 0.2]}, "ThreedFront.model_a[0].size[1]", "finite"),
        ({"theta": -math.inf}, "ThreedFront.model_a[0].theta", "finite"),
    ],
)
def test_front3d_degenerate_numbers(tmp_path: Path, item: dict[str, Any], field: str, words: str) -> None:
    path = _front3d(tmp_path, **item)
    with pytest.raises(ImportFormatError) as info:
        load_scene(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {field}: "), message
    assert words in message, message
    if "finite" not in words:
        assert "object 'chair_0'" in message  # the object is named, not only its place in the file


def test_front3d_object_count_is_checked_before_reading_objects(tmp_path: Path) -> None:
    entry = {"label": "chair", "size": [0.25, 0.45, 0.2], "position": [1.0, 0.0, 1.0], "theta": 0.0}
    path = tmp_path / "crowd.json"
    path.write_text(json.dumps({"ThreedFront": {"a": [entry] * 300, "b": [{}] * (MAX_OBJECTS - 299)}}))
    with pytest.raises(ImportFormatError, match=r"crowd\.json: ThreedFront: 513 objects; a scene holds at most 512"):
        load_scene(path)


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda o: o["asset"].update(extents=[1e-9, 0.5, 0.9]), "object 'chair_1' (objects[1]): Value error, asset.extents * pose.scale: size along x is 1e-09 m"),
        (lambda o: o["pose"].update(position=[0.0, 2e4, 0.0]), "pose.position: coordinate 1 is 20000 m"),
        (lambda o: o["pose"].update(scale=[1.0, 1.0, 1e-6]), "pose.scale: scale along z is 1e-06"),
        (lambda o: o["pose"].update(position=[0.0, math.inf, 0.0]), "field pose.position"),
        (lambda o: o["asset"].update(extents=[0.5, math.nan, 0.9]), "field asset.extents"),
    ],
)
def test_native_degenerate_numbers(tmp_path: Path, edit: Callable[[dict[str, Any]], Any], words: str) -> None:
    objects = [
        SceneObject(id=f"chair_{i}", category="chair", asset=AssetRef(kind="box", extents=(0.5, 0.5, 0.9)),
                    pose=Pose(position=(float(i), 0.0, 0.0)))
        for i in range(2)
    ]  # fmt: skip
    path = save_scene(Scene(objects=objects), tmp_path / "native")
    data = json.loads(path.read_text())
    edit(data["objects"][1])
    path.write_text(json.dumps(data))
    with pytest.raises(SceneValidationError) as info:
        load_scene(path.parent)
    message = str(info.value)
    assert str(path) in message and "chair_1" in message and words in message, message
    assert info.value.object_id == "chair_1"


def test_sam3d_limits_name_the_field_and_the_original_id(
    link_sam3d_example: Callable[[Path], dict[str, Any]], tmp_path: Path
) -> None:
    base = link_sam3d_example(tmp_path)
    cases = [
        (lambda d: d["objects"][1].update(position=[0.0, -3000.0, 0.0]), "objects[1].position",
         "object 'work_desk': coordinate 1 is -3000 m"),
        (lambda d: d["objects"][2].update(scale=[1.0, 1e-5, 1.0]), "objects[2].scale",
         "object 'office_chair': scale along y is 1e-05"),
        (lambda d: d["objects"][3].update(scale=[0.001, 0.001, 0.001]), "objects[3]",
         "object 'printer': asset.extents * pose.scale: size along"),
        # the limit is in metres: 2e5 cm is 2 km
        (lambda d: d.update(units="cm") or d["objects"][4].update(position=[0.0, 0.0, 2e5]),
         "objects[4].position", "object 'coffee_mug': coordinate 2 is 2000 m"),
        (lambda d: d["room"].update(ceiling_height=1e4), "room.ceiling_height", "at most 100 m"),
        (lambda d: d["objects"].extend([d["objects"][0]] * MAX_OBJECTS), "objects", "at most 512"),
    ]  # fmt: skip
    for edit, field, words in cases:
        data = copy.deepcopy(base)
        edit(data)
        path = tmp_path / "poses.json"
        path.write_text(json.dumps(data))
        with pytest.raises(ImportFormatError) as info:
            load_scene(tmp_path)
        message = str(info.value)
        assert message.startswith(f"{path}: {field}: "), message
        assert words in message, message


def test_every_degenerate_input_is_a_scenemosaic_error(tmp_path: Path) -> None:
    """No traceback from pydantic, numpy or the OS: each bad input is one of our errors."""
    bad_inputs = {
        "tiny.json": {"ThreedFront": {"m": [{"label": "cup", "size": [1e-9, 1e-9, 1e-9], "position": [0, 0, 0], "theta": 0}]}},
        "far.json": {"ThreedFront": {"m": [{"label": "cup", "size": [0.1, 0.1, 0.1], "position": [1e9, 0, 0], "theta": 0}]}},
        "nan.json": {"ThreedFront": {"m": [{"label": "cup", "size": [0.1, 0.1, 0.1], "position": [0, 0, 0], "theta": math.nan}]}},
    }  # fmt: skip
    for name, data in bad_inputs.items():
        (tmp_path / name).write_text(json.dumps(data))
        with pytest.raises(SceneMosaicError):
            load_scene(tmp_path / name)


# -- ids ---------------------------------------------------------------------------------------------


def _sam3d_with_ids(link: Callable[[Path], dict[str, Any]], folder: Path, ids: list[Any]) -> Path:
    data = link(folder)
    for obj, oid in zip(data["objects"], ids, strict=False):
        obj["id"] = oid
    (folder / "poses.json").write_text(json.dumps(data))
    return folder


def test_sam3d_ids_that_sanitize_alike_stay_distinct(
    link_sam3d_example: Callable[[Path], dict[str, Any]], tmp_path: Path
) -> None:
    folder = _sam3d_with_ids(link_sam3d_example, tmp_path, ["椅子", "桌子", "mug!", "mug?", "椅子🙂"])
    ids = [o.id for o in load_scene(folder).objects]
    assert len(set(ids)) == 5
    assert ids == [sanitize_id(x) for x in ["椅子", "桌子", "mug!", "mug?", "椅子🙂"]]
    assert all(i.startswith("object_") for i in ids[:2]) and ids[4].startswith("object_")
    assert ids[2].startswith("mug_") and ids[3].startswith("mug_")
    assert "object" not in ids


def test_sam3d_duplicate_error_names_the_original_ids(
    link_sam3d_example: Callable[[Path], dict[str, Any]], tmp_path: Path
) -> None:
    folder = _sam3d_with_ids(link_sam3d_example, tmp_path, ["椅子", "桌子", "mug!", "椅子"])
    with pytest.raises(ImportFormatError) as info:
        load_scene(folder)
    assert str(info.value).endswith("objects[3].id: duplicate id '椅子' (objects[0] has it too)")


def test_sam3d_ids_kept_verbatim_win_over_sanitized_lookalikes(
    link_sam3d_example: Callable[[Path], dict[str, Any]], tmp_path: Path
) -> None:
    """``a b`` sanitizes to ``a_b`` (a separator, no hash); the verbatim ``a_b`` keeps its id."""
    folder = _sam3d_with_ids(link_sam3d_example, tmp_path, ["a b", "a_b"])
    ids = [o.id for o in load_scene(folder).objects]
    assert ids[:2] == ["a_b_2", "a_b"]


def test_procthor_ids_keep_their_readable_form(procthor_house: Path, procthor_db: Path) -> None:
    scenes = load_scenes(procthor_house, asset_database=procthor_db)
    ids = [o.id for s in scenes for o in s.objects]
    sources = [raw for s in scenes for raw in s.provenance.source_ids.values()]
    assert ids and all("|" not in i for i in ids)
    assert all(sanitize_id(raw) == raw.replace("|", "_") for raw in sources)
    assert [s.room.id for s in scenes if s.room is not None] == [s.id for s in scenes]


def test_a_room_recovered_beyond_the_limits_is_a_clean_error(tmp_path: Path) -> None:
    """An object just inside the coordinate limit gives a recovered room (footprint + margin) beyond it."""
    path = _front3d(tmp_path, position=[999.9, 0.0, 0.0], size=[0.5, 0.45, 0.5])
    with pytest.raises(ImportFormatError, match=r"layout\.json: the room recovered from the objects is unusable"):
        load_scene(path)

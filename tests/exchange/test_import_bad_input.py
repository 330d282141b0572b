"""More bad input: truncated pose files, repeated ids, degenerate meshes, wrong types in scene.json.

Each case must raise an error that names the file and the field (or object), and leave the
inputs on disk untouched.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from structlog.testing import capture_logs

from scenemosaic.exceptions import AssetError, ImportFormatError, SceneValidationError
from scenemosaic.exchange import load_scene, read_scene, save_scene
from scenemosaic.scene import AssetRef, Pose, Relation, Scene, SceneObject


@pytest.fixture
def poses_text(link_sam3d_example: Callable[[Path], dict[str, Any]], tmp_path: Path) -> str:
    """The example's poses.json, for a folder ``tmp_path / "set"`` that holds links to its meshes."""
    return json.dumps(link_sam3d_example(tmp_path / "set"), indent=1)


def _poses_dir(tmp_path: Path, text: str) -> Path:
    folder = tmp_path / "set"
    folder.mkdir(exist_ok=True)
    (folder / "poses.json").write_text(text)
    return folder


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.97])
def test_sam3d_truncated_poses_file(poses_text: str, tmp_path: Path, fraction: float) -> None:
    cut = poses_text[: int(len(poses_text) * fraction)]
    folder = _poses_dir(tmp_path, cut)
    with pytest.raises(ImportFormatError, match=r"poses\.json: invalid JSON at line \d+ column \d+") as info:
        load_scene(folder)
    assert info.value.path == str(folder / "poses.json")
    assert (folder / "poses.json").read_text() == cut  # the input is left as it was


def test_sam3d_valid_file_still_loads(poses_text: str, tmp_path: Path) -> None:
    """The control for the cases below: the unmodified text imports."""
    scene = load_scene(_poses_dir(tmp_path, poses_text))
    assert [o.id for o in scene.objects] == ["bed", "work_desk", "office_chair", "printer", "coffee_mug"]


@pytest.mark.parametrize(
    ("edit", "field", "words"),
    [
        (lambda d: d["objects"][3].update(id="bed"), "objects[3].id", "duplicate id 'bed' (objects[0]"),
        (lambda d: d["objects"][1].update(id="floor"), "objects[1].id", "reserved for a room anchor"),
        (lambda d: d["objects"][1].update(id="wall_2"), "objects[1].id", "reserved for a room anchor"),
        (lambda d: d["objects"][1].update(id=12), "objects[1].id", "expected a string"),
        (lambda d: d.update(objects="bed"), "objects", "expected a JSON array"),
        (lambda d: d.update(objects=[]), "objects", "empty"),
        (lambda d: d["objects"][0].update(position="0 0 0"), "objects[0].position", "expected a JSON array"),
        (lambda d: d["objects"][0].update(position=[0, 0, "1"]), "objects[0].position[2]", "expected a number"),
        (lambda d: d["objects"][0].update(quaternion=[1, 0, 0, math.inf]), "objects[0].quaternion[3]", "finite"),
        (lambda d: d["objects"][0].update(scale=[1, math.nan, 1]), "objects[0].scale[1]", "finite"),
        (lambda d: d.update(units=None), "units", "unknown units"),
        (lambda d: d.update(units=0.01), "units", "unknown units"),
    ],
)
def test_sam3d_bad_fields(
    poses_text: str, tmp_path: Path, edit: Callable[[dict[str, Any]], Any], field: str, words: str
) -> None:
    data = json.loads(poses_text)
    edit(data)
    folder = _poses_dir(tmp_path, json.dumps(data))
    with pytest.raises(ImportFormatError) as info:
        load_scene(folder)
    assert str(info.value).startswith(f"{folder / 'poses.json'}: {field}: "), str(info.value)
    assert words in str(info.value)


def test_sam3d_generated_ids_steer_around_explicit_ones(poses_text: str, tmp_path: Path) -> None:
    data = json.loads(poses_text)
    del data["objects"][0]["id"]  # the bed (label "bed") now gets a generated id ...
    data["objects"][3]["id"] = "bed_0"  # ... which the printer claims explicitly
    scene = load_scene(_poses_dir(tmp_path, json.dumps(data)))
    ids = [o.id for o in scene.objects]
    assert ids[3] == "bed_0" and ids[0] != "bed_0" and ids[0].startswith("bed_")
    assert scene.get("bed_0").category == "printer"


@pytest.mark.parametrize(
    ("name", "content", "words"),
    [
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "flat"),
        ("sheet.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n", "flat"),
        ("nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 1\n", ""),
        ("junk.glb", "this is not a glb file", "cannot read mesh"),
    ],
)
def test_sam3d_degenerate_mesh_names_pose_file_field_and_mesh(
    poses_text: str, tmp_path: Path, name: str, content: str, words: str
) -> None:
    bad = tmp_path / "set" / name
    bad.write_text(content)
    data = json.loads(poses_text)
    data["objects"][2]["mesh"] = str(bad)
    folder = _poses_dir(tmp_path, json.dumps(data))
    with pytest.raises(AssetError) as info:
        load_scene(folder)
    message = str(info.value)
    assert message.startswith(f"{folder / 'poses.json'}: objects[2].mesh: {bad}"), message
    assert words in message
    assert bad.read_text() == content


# -- native scene.json ---------------------------------------------------------------------------


def _native(tmp_path: Path) -> tuple[Path, dict[str, Any]]:
    objs = [
        SceneObject(id=f"chair_{i}", category="chair", asset=AssetRef(kind="box", extents=(0.5, 0.5, 0.9)),
                    pose=Pose.from_yaw((i, 0.0, 0.0), 0.0))
        for i in range(3)
    ]
    scene = Scene(objects=objs, relations=[Relation(kind="attach", child="chair_1", parent="floor")])
    path = save_scene(scene, tmp_path / "native")
    return path, json.loads(path.read_text())


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda d: d["objects"][1]["pose"].update(position="1 0 0"), "object 'chair_1' (objects[1]) field pose.position"),
        (lambda d: d["objects"][2].pop("asset"), "object 'chair_2' (objects[2]) field asset"),
        (lambda d: d["objects"][0].pop("id"), "objects[0] field id"),
        (lambda d: d["objects"][2]["pose"].update(quaternion=[1, 0, 0, math.nan]),
         "object 'chair_2' (objects[2]) field pose.quaternion"),
        (lambda d: d["objects"][1]["asset"].update(kind="hologram"), "object 'chair_1' (objects[1]) field asset.kind"),
        (lambda d: d.update(objects={"chair_0": {}}), "field objects"),
        (lambda d: d["objects"].append(dict(d["objects"][0])), "duplicate object id 'chair_0'"),
        (lambda d: d["relations"][0].update(parent="chair_9"), "chair_9"),
    ],
)
def test_native_bad_fields_name_file_and_object(
    tmp_path: Path, edit: Callable[[dict[str, Any]], Any], words: str
) -> None:
    path, data = _native(tmp_path)
    assert read_scene(path).objects[0].id == "chair_0"  # control: the saved file is valid
    edit(data)
    path.write_text(json.dumps(data))
    with pytest.raises(SceneValidationError) as info:
        load_scene(path.parent)
    assert str(path) in str(info.value)
    assert words in str(info.value), str(info.value)


def test_native_non_unit_quaternion_is_normalized_with_a_warning(tmp_path: Path) -> None:
    """The documented choice (docs/conventions.md): normalize and log, do not reject."""
    path, data = _native(tmp_path)
    data["objects"][1]["pose"]["quaternion"] = [0.0, 0.0, 0.0, 2.0]
    path.write_text(json.dumps(data))
    with capture_logs() as logs:
        scene = read_scene(path)
    assert scene.get("chair_1").pose.quaternion == pytest.approx((0.0, 0.0, 0.0, 1.0))
    warned = [e for e in logs if e["event"] == "quaternion_normalized"]
    assert len(warned) == 1 and warned[0]["log_level"] == "warning" and warned[0]["norm"] == pytest.approx(2.0)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[" * 5000 + "]" * 5000, "nested too deeply"),
        ('{"objects": [{"id": "a", "size": ' + "9" * 5000 + "}]}", "number too long"),
    ],
    ids=["deep", "huge-integer"],
)
def test_json_beyond_what_python_parses_is_a_format_error(tmp_path: Path, text: str, message: str) -> None:
    """Nesting past the recursion limit and integers past the digit limit name the file: a bad
    input (exit 2 from the CLI), not a crash."""
    for path in (tmp_path / "room.json", tmp_path / "native" / "scene.json"):
        path.parent.mkdir(exist_ok=True)
        path.write_text(text, encoding="utf-8")
        with pytest.raises(ImportFormatError, match=message) as info:
            load_scene(path.parent if path.name == "scene.json" else path)
        assert str(path.name) in str(info.value)

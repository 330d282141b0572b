"""Native scene folders: save_scene / read_scene round trips and validation messages."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenemosaic.exceptions import AssetError, ImportFormatError, SceneValidationError
from scenemosaic.exchange import detect_format, load_scene, read_scene, save_scene
from scenemosaic.scene import AssetRef, Pose, Relation, Scene, SceneObject


def _physcene(physcene_files: list[Path]) -> Scene:
    return load_scene(next(p for p in physcene_files if p.name.startswith("LivingDiningRoom-124277")))


def test_round_trip_is_equal_and_byte_identical(physcene_files: list[Path], tmp_path: Path) -> None:
    scene = _physcene(physcene_files)
    scene.relations.append(Relation(kind="attach", child="dining_chair_0", parent="floor", source="test"))
    first = save_scene(scene, tmp_path / "a")
    assert first == tmp_path / "a" / "scene.json"
    back = read_scene(tmp_path / "a")
    assert back == scene
    second = save_scene(back, tmp_path / "b")
    assert first.read_bytes() == second.read_bytes()
    assert read_scene(second) == back
    assert detect_format(tmp_path / "a") == "native"
    assert load_scene(tmp_path / "a") == scene  # imported provenance is kept
    assert load_scene(first, format="native") == scene


def test_mesh_files_are_copied_with_their_side_files(sam3d_dir: Path, tmp_path: Path) -> None:
    gltf = next(sam3d_dir.glob("generated_assets/sdf/printer_*/printer.gltf"))
    asset = AssetRef(
        kind="mesh",
        uri=str(gltf),
        extents=(0.7, 0.9, 0.8),
        source_transform=[1.0, *[0.0] * 4, 1.0, *[0.0] * 4, 1.0, *[0.0] * 4, 1.0],
    )
    objs = [
        SceneObject(id=f"printer_{i}", category="printer", asset=asset, pose=Pose.from_yaw((i, 0, 0), 0.0))
        for i in range(2)
    ]
    scene = Scene(objects=objs)
    path = save_scene(scene, tmp_path / "s")
    saved = read_scene(path)
    uris = {o.asset.uri for o in saved.objects}
    assert len(uris) == 1  # one shared copy
    uri = uris.pop()
    assert uri is not None and uri.startswith("assets/printer-") and uri.endswith("/printer.gltf")
    copied = tmp_path / "s" / uri
    assert copied.read_bytes() == gltf.read_bytes()
    for name in ("gltf_buffer_0.bin", "gltf_buffer_3.bin"):
        assert (copied.parent / name).read_bytes() == (gltf.parent / name).read_bytes()
    assert saved.objects[0].asset.source_transform == asset.source_transform
    # saving the read scene elsewhere (relative uris resolved against its folder) changes nothing
    again = save_scene(saved, tmp_path / "t", base_dir=tmp_path / "s")
    assert again.read_bytes() == path.read_bytes()
    assert (tmp_path / "t" / uri).is_file()
    # and saving it in place copies nothing over itself
    assert save_scene(saved, tmp_path / "s", base_dir=tmp_path / "s").read_bytes() == path.read_bytes()


def test_missing_mesh_file_is_an_asset_error(tmp_path: Path) -> None:
    asset = AssetRef(kind="mesh", uri="nowhere/chair.glb", extents=(1, 1, 1))
    scene = Scene(
        objects=[SceneObject(id="chair_0", category="chair", asset=asset, pose=Pose(position=(0, 0, 0)))]
    )
    with pytest.raises(AssetError, match=r"chair_0.*not found"):
        save_scene(scene, tmp_path / "out", base_dir=tmp_path)


def test_validation_error_names_the_object_and_field(physcene_files: list[Path], tmp_path: Path) -> None:
    path = save_scene(_physcene(physcene_files), tmp_path / "bad")
    data = json.loads(path.read_text())
    data["objects"][3]["pose"]["position"][1] = float("nan")
    data["objects"][5]["asset"]["extents"] = [1.0, -2.0, 1.0]
    path.write_text(json.dumps(data))
    with pytest.raises(SceneValidationError) as info:
        read_scene(path)
    message = str(info.value)
    oid3, oid5 = data["objects"][3]["id"], data["objects"][5]["id"]
    assert str(path) in message
    assert f"object {oid3!r} (objects[3]) field pose.position" in message and "finite" in message
    assert f"object {oid5!r} (objects[5]) field asset.extents" in message
    assert info.value.object_id == oid3


def test_reference_errors_name_the_file(tmp_path: Path) -> None:
    obj = SceneObject(
        id="lamp_0", category="lamp", asset=AssetRef(extents=(1, 1, 1)), pose=Pose(position=(0, 0, 0))
    )
    data = json.loads(Scene(objects=[obj]).to_json())
    data["relations"] = [{"kind": "attach", "child": "lamp_0", "parent": "table_9"}]
    (tmp_path / "scene.json").write_text(json.dumps(data))
    with pytest.raises(SceneValidationError, match=r"scene\.json.*table_9") as info:
        read_scene(tmp_path)
    assert info.value.object_id == "lamp_0"


def test_bad_json_and_missing_files(tmp_path: Path) -> None:
    (tmp_path / "scene.json").write_text('{"objects": [')
    with pytest.raises(ImportFormatError, match=r"scene\.json: invalid JSON"):
        read_scene(tmp_path)
    with pytest.raises(ImportFormatError, match=r"scene\.json: invalid JSON"):
        load_scene(tmp_path)
    with pytest.raises(ImportFormatError, match=r"missing\.json: file not found"):
        read_scene(tmp_path / "missing.json")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ImportFormatError, match=r"no scene\.json in folder"):
        read_scene(tmp_path / "empty")
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(ImportFormatError, match="top level"):
        read_scene(tmp_path / "list.json")


def test_hand_written_scene_gets_native_provenance(tmp_path: Path) -> None:
    obj = SceneObject(
        id="box_0",
        category="box",
        asset=AssetRef(kind="box", extents=(1, 1, 1)),
        pose=Pose(position=(0, 0, 0)),
    )
    file = tmp_path / "scene.json"
    file.write_text(Scene(objects=[obj]).to_json())
    assert read_scene(file).provenance.source_format is None
    loaded = load_scene(file)
    assert loaded.provenance.source_format == "native"
    assert loaded.provenance.source_path == file.as_posix()

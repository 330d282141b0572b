"""Hostile file references: every file a scene names must lie in the scene's folder (or an allowed
root), checked when the scene is read and again where files are read or copied."""

from __future__ import annotations

import json
import os
import shutil
import stat
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import trimesh

from scenemosaic.assets import load_mesh, referenced_files
from scenemosaic.exceptions import AssetError, ImportFormatError, UnsafePathError
from scenemosaic.exchange import export_sceneeval, load_scene, read_scene, save_scene
from scenemosaic.scene import AssetRef, Pose, Scene, SceneObject


@pytest.fixture(autouse=True)
def _umask_022() -> Iterator[None]:
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


def _box_obj(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(trimesh.creation.box(extents=(0.5, 0.4, 0.9)).export(file_type="obj").encode())
    return path


def _box_gltf(folder: Path, *, images: list[str] | None = None, buffer_uri: str | None = None) -> Path:
    """A glTF box with an external buffer; ``images`` adds image entries, ``buffer_uri`` renames the buffer."""
    folder.mkdir(parents=True, exist_ok=True)
    files = trimesh.Scene(trimesh.creation.box(extents=(0.5, 0.4, 0.9))).export(file_type="gltf")
    doc = json.loads(files.pop("model.gltf"))
    for name, data in files.items():
        (folder / name).write_bytes(data)
    if buffer_uri is not None:
        doc["buffers"][0]["uri"] = buffer_uri
    if images is not None:
        doc["images"] = [{"uri": uri} for uri in images]
    path = folder / "box.gltf"
    path.write_text(json.dumps(doc))
    return path


def _native(folder: Path, uri: str, *, oid: str = "chair_0") -> Path:
    """A scene.json in ``folder`` whose one object is a mesh with ``uri`` (written as is)."""
    scene = Scene(
        objects=[
            SceneObject(
                id=oid,
                category="chair",
                asset=AssetRef(kind="mesh", uri=uri, extents=(0.5, 0.4, 0.9)),
                pose=Pose(position=(0.0, 0.0, 0.0)),
            )
        ]
    )
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "scene.json").write_text(scene.to_json())
    return folder / "scene.json"


# -- native scene.json -------------------------------------------------------------------------------


@pytest.mark.parametrize("uri", ["../../../etc/passwd", "/etc/passwd", "assets/../../outside.obj"])
def test_native_uri_outside_the_folder_is_refused_at_import(tmp_path: Path, uri: str) -> None:
    _box_obj(tmp_path / "outside.obj")
    path = _native(tmp_path / "scene", uri)
    with pytest.raises(ImportFormatError) as info:
        load_scene(path.parent)
    message = str(info.value)
    assert message.startswith(f"{path}: objects[0].asset.uri: object 'chair_0': "), message
    assert "outside" in message and uri in message
    assert info.value.field == "objects[0].asset.uri"
    with pytest.raises(ImportFormatError):
        read_scene(path)


def test_nothing_outside_is_ever_copied_into_the_output(tmp_path: Path) -> None:
    """The reported attack: read a scene.json naming /etc/passwd, then save it."""
    path = _native(tmp_path / "scene", "../../../../../../../../etc/passwd")
    with pytest.raises(ImportFormatError):
        save_scene(read_scene(path), tmp_path / "out")
    assert not (tmp_path / "out").exists()
    # a scene built in code with an escaping relative uri is refused by save_scene itself
    scene = Scene.model_validate_json(path.read_text())
    with pytest.raises(UnsafePathError, match=r"object 'chair_0'.*outside"):
        save_scene(scene, tmp_path / "out", base_dir=tmp_path / "scene")
    assert not list((tmp_path / "out").rglob("passwd"))


def test_native_symlink_to_a_file_outside_is_refused(tmp_path: Path) -> None:
    outside = _box_obj(tmp_path / "elsewhere" / "box.obj")
    folder = tmp_path / "scene"
    (folder / "assets").mkdir(parents=True)
    (folder / "assets" / "box.obj").symlink_to(outside)
    _native(folder, "assets/box.obj")
    with pytest.raises(ImportFormatError, match=r"objects\[0\]\.asset\.uri.*resolves to .*elsewhere"):
        load_scene(folder)


def test_native_files_inside_load_and_an_asset_dir_root_is_allowed(tmp_path: Path) -> None:
    inside = _box_obj(tmp_path / "scene" / "assets" / "box.obj")
    assert load_scene(_native(tmp_path / "scene", "assets/box.obj").parent).objects[0].asset.uri == "assets/box.obj"
    assert load_scene(_native(tmp_path / "scene", str(inside)).parent).objects[0].asset.uri == str(inside)
    library = _box_obj(tmp_path / "library" / "box.obj")
    path = _native(tmp_path / "scene", str(library))
    with pytest.raises(ImportFormatError, match="outside"):
        load_scene(path)
    assert load_scene(path, asset_dir=tmp_path / "library").objects[0].asset.uri == str(library)


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda folder: (folder / "assets" / "box.obj").mkdir(parents=True), "is a directory, not a mesh file"),
        (lambda folder: (folder / "assets").mkdir() or (folder / "assets" / "box.obj").touch(), "is empty (0 bytes)"),
        (lambda folder: None, "mesh file not found"),
        (
            lambda folder: (folder / "assets").mkdir()
            or (folder / "assets" / "box.obj").symlink_to(folder / "assets" / "loop.obj")
            or (folder / "assets" / "loop.obj").symlink_to(folder / "assets" / "box.obj"),
            "symlink loop",
        ),
    ],
)
def test_native_degenerate_mesh_files_are_named(tmp_path: Path, make: Callable[[Path], Any], words: str) -> None:
    folder = tmp_path / "scene"
    folder.mkdir()
    make(folder)
    path = _native(folder, "assets/box.obj", oid="stool_3")
    with pytest.raises(ImportFormatError) as info:
        load_scene(folder)
    message = str(info.value)
    assert message.startswith(f"{path}: objects[0].asset.uri: object 'stool_3'"), message
    assert words in message, message


# -- files a mesh references -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("images", "buffer_uri", "words"),
    [
        (["../../x.png"], None, "outside"),
        (["%2e%2e/%2e%2e/x.png"], None, "outside"),  # what a glTF reader following the spec opens
        (["/etc/passwd"], None, "absolute path"),
        (["https://example.com/x.png"], None, "URL"),
        ([], "../gltf_buffer_0.bin", "outside"),
    ],
)
def test_gltf_side_files_outside_the_mesh_folder_are_refused_at_load(
    tmp_path: Path, images: list[str], buffer_uri: str | None, words: str
) -> None:
    (tmp_path / "x.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    gltf = _box_gltf(tmp_path / "a" / "b" / "mesh", images=images, buffer_uri=buffer_uri)
    with pytest.raises(UnsafePathError, match=words) as info:
        load_mesh(gltf)
    assert str(gltf) in str(info.value)


def test_embedded_and_inside_side_files_are_listed(tmp_path: Path) -> None:
    gltf = _box_gltf(tmp_path / "mesh", images=["textures/wood.png", "data:image/png;base64,AAAA"])
    listed = [ref for ref, _ in referenced_files(gltf)]
    assert listed[-1] == "textures/wood.png" and not any(ref.startswith("data:") for ref in listed)
    assert load_mesh(gltf).extents == pytest.approx((0.5, 0.9, 0.4))  # a missing texture is not fatal


def test_obj_material_and_texture_outside_are_refused(tmp_path: Path) -> None:
    folder = tmp_path / "mesh"
    obj = _box_obj(folder / "box.obj")
    text = obj.read_text()
    (tmp_path / "evil.mtl").write_text("newmtl m\n")
    obj.write_text("mtllib ../evil.mtl\n" + text)
    with pytest.raises(UnsafePathError, match=r"'\.\./evil\.mtl'.*outside"):
        load_mesh(obj)
    (folder / "box.mtl").write_text("newmtl m\nmap_Kd ../../secret.png\n")
    obj.write_text("mtllib box.mtl\n" + text)
    with pytest.raises(UnsafePathError, match=r"secret\.png"):
        load_mesh(obj)


def test_save_scene_refuses_a_mesh_whose_side_file_escapes(tmp_path: Path) -> None:
    gltf = _box_gltf(tmp_path / "mesh", images=["../secret.png"])
    (tmp_path / "secret.png").write_bytes(b"secret")
    scene = Scene.model_validate_json(_native(tmp_path / "scene", str(gltf)).read_text())
    with pytest.raises(UnsafePathError, match=r"object 'chair_0'.*secret\.png"):
        save_scene(scene, tmp_path / "out")
    assert not list((tmp_path / "out").rglob("secret.png"))


# -- SAM3D pose files --------------------------------------------------------------------------------


def _poses(folder: Path, mesh: str, **extra: Any) -> Path:
    entry = {"id": "椅子", "label": "chair", "mesh": mesh, "position": [0.0, 0.0, 0.0], **extra}
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "poses.json").write_text(json.dumps({"format": "sam3d", "objects": [entry]}))
    return folder / "poses.json"


def test_sam3d_meshes_in_sub_folders_load(tmp_path: Path) -> None:
    _box_obj(tmp_path / "set" / "meshes" / "deep" / "box.obj")
    scene = load_scene(_poses(tmp_path / "set", "meshes/deep/box.obj"))
    assert scene.objects[0].asset.uri == (tmp_path / "set" / "meshes" / "deep" / "box.obj").resolve().as_posix()


@pytest.mark.parametrize("where", ["../outside/box.obj", "ABSOLUTE"])
def test_sam3d_meshes_outside_the_pose_folder_are_refused(tmp_path: Path, where: str) -> None:
    outside = _box_obj(tmp_path / "outside" / "box.obj")
    path = _poses(tmp_path / "set", str(outside) if where == "ABSOLUTE" else where)
    with pytest.raises(ImportFormatError) as info:
        load_scene(path)
    message = str(info.value)
    assert message.startswith(f"{path}: objects[0].mesh: object '椅子': "), message
    assert "outside" in message


def test_sam3d_asset_dir_is_no_root_for_pose_files(tmp_path: Path) -> None:
    outside = _box_obj(tmp_path / "outside" / "box.obj")
    with pytest.raises(ImportFormatError, match="outside"):
        load_scene(_poses(tmp_path / "set", str(outside)), asset_dir=tmp_path / "outside")


@pytest.mark.parametrize(
    ("make", "error", "words"),
    [
        (lambda f: (f / "m.obj").mkdir(), ImportFormatError, "is a directory, not a mesh file"),
        (lambda f: (f / "m.obj").touch(), AssetError, "empty mesh file (0 bytes)"),
        (lambda f: (f / "m.obj").symlink_to(f / "n.obj") or (f / "n.obj").symlink_to(f / "m.obj"),
         ImportFormatError, "symlink loop"),
    ],
)
def test_sam3d_degenerate_mesh_files_are_named(
    tmp_path: Path, make: Callable[[Path], Any], error: type[Exception], words: str
) -> None:
    folder = tmp_path / "set"
    folder.mkdir()
    make(folder)
    path = _poses(folder, "m.obj")
    with pytest.raises(error) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}: objects[0].mesh: "), str(info.value)
    assert words in str(info.value)


def test_sam3d_gltf_with_an_escaping_image_is_refused_when_imported(tmp_path: Path) -> None:
    (tmp_path / "x.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    _box_gltf(tmp_path / "set" / "meshes", images=["../../x.png"])
    path = _poses(tmp_path / "set", "meshes/box.gltf")
    with pytest.raises(AssetError, match=r"objects\[0\]\.mesh: .*'\.\./\.\./x\.png'.*outside"):
        load_scene(path)


# -- SceneEval ---------------------------------------------------------------------------------------


def test_sceneeval_asset_symlinked_outside_is_refused_unless_asset_dir_allows_it(
    small_scene: Scene, tmp_path: Path
) -> None:
    exported = export_sceneeval(small_scene, tmp_path / "export")
    folder = tmp_path / "edited"
    (folder / "assets").mkdir(parents=True)
    for glb in (exported.parent / "assets").glob("*.glb"):
        (folder / "assets" / glb.name).symlink_to(glb)
    shutil.copy(exported, folder / "state.json")
    with pytest.raises(ImportFormatError, match=r"scene\.object\[0\]\.modelId: asset '.*resolves to .*outside"):
        load_scene(folder / "state.json")
    scene = load_scene(folder / "state.json", asset_dir=exported.parent / "assets")
    assert len(scene.objects) == len(small_scene.objects)


# -- written files -----------------------------------------------------------------------------------


def test_saved_scene_files_get_the_ordinary_mode(sam3d_example: Path, tmp_path: Path) -> None:
    target = save_scene(load_scene(sam3d_example), tmp_path / "out")
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    for copied in (tmp_path / "out" / "assets").rglob("*"):
        if copied.is_file():
            assert stat.S_IMODE(copied.stat().st_mode) == 0o644, copied

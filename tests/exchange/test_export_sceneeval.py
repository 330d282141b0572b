"""SceneEval sceneState export, read back the way SceneEval reads it and compared with scene.glb."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from scenemosaic.exchange import MODEL_ID_PREFIX, Y_UP_TO_Z_UP, export_glb, export_sceneeval, sceneeval_state
from scenemosaic.scene import MAX_OBJECTS, AssetRef, Pose, Room, Scene, SceneObject, front_vector

TOL_M = 1e-3


def _load_state(out_dir: Path) -> dict[str, Any]:
    return json.loads((out_dir / "scene_base.json").read_text())


def _sceneeval_world_mesh(out_dir: Path, obj: dict[str, Any]) -> trimesh.Trimesh:
    """What SceneEval does: load the asset GLB as one mesh (raw glTF coordinates) and apply the transform."""
    asset_id = obj["modelId"][len(MODEL_ID_PREFIX) :]
    mesh = trimesh.load(out_dir / "assets" / f"{asset_id}.glb", force="mesh")
    mesh.apply_transform(np.asarray(obj["transform"]["data"]).reshape(4, 4).T)
    return mesh


def _glb_world_vertices(glb: trimesh.Scene, node: str) -> np.ndarray:
    matrix, geom = glb.graph[node]
    return trimesh.transform_points(glb.geometry[geom].vertices, Y_UP_TO_Z_UP @ matrix)


@pytest.mark.parametrize("which", ["small_scene", "dining_scene"])
def test_world_geometry_matches_scene_glb(which: str, request: pytest.FixtureRequest, tmp_path: Path) -> None:
    scene: Scene = request.getfixturevalue(which)
    out = tmp_path / "sceneeval"
    export_sceneeval(scene, out)
    glb = trimesh.load(export_glb(scene, tmp_path / "scene.glb"))
    state = _load_state(out)
    assert [o["id"] for o in state["scene"]["object"]] == [o.id for o in scene.objects]
    for obj in state["scene"]["object"]:
        ours = _sceneeval_world_mesh(out, obj).vertices
        ref = _glb_world_vertices(glb, obj["id"])
        np.testing.assert_allclose(ours.min(axis=0), ref.min(axis=0), atol=TOL_M, err_msg=obj["id"])
        np.testing.assert_allclose(ours.max(axis=0), ref.max(axis=0), atol=TOL_M, err_msg=obj["id"])
        # every vertex has a counterpart within 1 mm, both ways
        assert cKDTree(ref).query(ours)[0].max() < TOL_M, obj["id"]
        assert cKDTree(ours).query(ref)[0].max() < TOL_M, obj["id"]


def test_document_shape_and_arch(small_scene: Scene, tmp_path: Path) -> None:
    export_sceneeval(small_scene, tmp_path)
    state = _load_state(tmp_path)
    assert state["format"] == "sceneState"
    body = state["scene"]
    assert body["version"] == "scene@1.0.2"
    assert body["up"] == [0, 0, 1] and body["front"] == [0, 1, 0] and body["unit"] == 1.0
    arch = body["arch"]
    assert arch["scaleToMeters"] == 1
    types = [e["type"] for e in arch["elements"]]
    assert (
        set(types) == {"Floor", "Wall", "Ceiling"} and types.count("Floor") == 1 and types.count("Wall") == 4
    )
    floor = next(e for e in arch["elements"] if e["type"] == "Floor")
    assert floor["roomId"] == small_scene.room.id and len(floor["points"]) >= 3
    assert all(len(p) == 3 and p[2] == 0.0 for p in floor["points"])
    walls = [e for e in arch["elements"] if e["type"] == "Wall"]
    for wall, ours in zip(walls, small_scene.room.walls, strict=True):
        assert wall["points"] == [[*ours.start, 0.0], [*ours.end, 0.0]]
        assert wall["height"] == ours.height and wall["roomId"] == small_scene.room.id
    door = walls[0]["holes"]
    assert len(door) == 1 and door[0]["type"] == "Door"
    np.testing.assert_allclose(door[0]["box"]["min"], [0.55, 0.0])
    np.testing.assert_allclose(door[0]["box"]["max"], [1.45, 2.1])
    window = walls[1]["holes"][0]
    assert window["type"] == "Window"
    np.testing.assert_allclose(window["box"]["min"], [0.9, 0.9])
    np.testing.assert_allclose(window["box"]["max"], [2.1, 2.0])
    assert walls[2]["holes"] == []


def test_objects_ids_indices_model_ids_and_rigid_transforms(small_scene: Scene, tmp_path: Path) -> None:
    export_sceneeval(small_scene, tmp_path)
    objects = _load_state(tmp_path)["scene"]["object"]
    assert len({o["id"] for o in objects}) == len(objects)
    assert sorted(o["index"] for o in objects) == list(range(len(objects)))
    for o in objects:
        assert isinstance(o["index"], int)
        assert o["modelId"].startswith(MODEL_ID_PREFIX)
        asset_id = o["modelId"][len(MODEL_ID_PREFIX) :]
        assert re.fullmatch(r"[A-Za-z0-9_.\-]+", asset_id)
        assert len(f"idx{o['index']}_{o['modelId']}".encode()) <= 63
        assert (tmp_path / "assets" / f"{asset_id}.glb").is_file()
        assert o["category"] == small_scene.get(o["id"]).category
        t = o["transform"]
        assert t["rows"] == 4 and t["cols"] == 4 and len(t["data"]) == 16
        m = np.asarray(t["data"]).reshape(4, 4).T
        np.testing.assert_allclose(m[3], [0, 0, 0, 1], atol=1e-12)
        np.testing.assert_allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-9)
        assert abs(np.linalg.det(m[:3, :3]) - 1.0) < 1e-9
        np.testing.assert_allclose(m[:3, 3], small_scene.get(o["id"]).pose.position, atol=1e-12)


def test_gltf_asset_frame_and_front(small_scene: Scene, tmp_path: Path) -> None:
    export_sceneeval(small_scene, tmp_path)
    objects = {o["id"]: o for o in _load_state(tmp_path)["scene"]["object"]}
    table = objects["table"]
    asset = trimesh.load(
        tmp_path / "assets" / f"{table['modelId'][len(MODEL_ID_PREFIX) :]}.glb", force="mesh"
    )
    # glTF: x width, +Y up (height 0.75 from the bottom at y = 0), z depth, centred in x and z
    np.testing.assert_allclose(asset.bounds, [[-0.7, 0.0, -0.4], [0.7, 0.75, 0.4]], atol=1e-6)
    for oid, o in objects.items():
        m = np.asarray(o["transform"]["data"]).reshape(4, 4).T
        # glTF +Z (the asset's front) lands on the object's front, glTF +Y on its up axis
        quat = small_scene.get(oid).pose.quaternion
        np.testing.assert_allclose(m[:3, :3] @ [0, 0, 1], front_vector(quat), atol=1e-9, err_msg=oid)
    lamp = np.asarray(objects["lamp"]["transform"]["data"]).reshape(4, 4).T  # yaw 0 faces world -Y
    np.testing.assert_allclose(lamp[:3, :3] @ [0, 0, 1], [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(lamp[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-12)


def test_support_types(small_scene: Scene, tmp_path: Path) -> None:
    export_sceneeval(small_scene, tmp_path)
    got = {o["id"]: o["sceneeval"]["supportType"] for o in _load_state(tmp_path)["scene"]["object"]}
    assert got == {
        "table": "ground", "chair": "ground", "lamp": "ceiling", "tv": "wall", "mug": "object", "book": "object",
    }  # fmt: skip


def test_support_type_defaults_to_ground_without_relations(dining_scene: Scene) -> None:
    state, _ = sceneeval_state(dining_scene)
    assert {o["sceneeval"]["supportType"] for o in state["scene"]["object"]} == {"ground"}


def test_identical_assets_are_shared(dining_scene: Scene, tmp_path: Path) -> None:
    export_sceneeval(dining_scene, tmp_path)
    objects = _load_state(tmp_path)["scene"]["object"]
    by_model: dict[str, set[tuple[str, tuple[float, ...]]]] = {}
    for o in objects:
        obj = dining_scene.get(o["id"])
        by_model.setdefault(o["modelId"], set()).add((obj.category, tuple(np.round(obj.size, 6))))
    assert all(len(v) == 1 for v in by_model.values())  # a shared asset means equal category and size
    sizes = {(o.category, tuple(np.round(o.size, 6))) for o in dining_scene.objects}
    assert len(by_model) == len(sizes) < len(objects)
    assert len(list((tmp_path / "assets").glob("*.glb"))) == len(by_model)
    meta = json.loads((tmp_path / "assets" / "metadata.json").read_text())
    for model_id, ((category, size),) in by_model.items():
        entry = meta[model_id[len(MODEL_ID_PREFIX) :]]
        assert entry["category"] == category
        np.testing.assert_allclose(entry["extents_m"], size, atol=1e-6)


def test_object_name_length_rule_with_many_objects() -> None:
    """The largest scene the model allows (MAX_OBJECTS objects, all different) keeps names short."""
    category = "an_unusually_long_category_name_for_a_piece_of_furniture_x"
    objects = [
        SceneObject(id=f"o{i}", category=category, asset=AssetRef(kind="box", extents=(0.1, 0.1, 0.1 + i * 1e-3)),
                    pose=Pose.from_yaw((0.01 * i, 0.0, 0.0), 0.0))
        for i in range(MAX_OBJECTS)
    ]  # fmt: skip
    scene = Scene(room=Room.rectangle(-1, -1, 2, 1), objects=objects)
    state, assets = sceneeval_state(scene)
    assert len(assets) == MAX_OBJECTS
    names = [f"idx{o['index']}_{o['modelId']}" for o in state["scene"]["object"]]
    assert len(set(names)) == MAX_OBJECTS
    assert max(len(n.encode()) for n in names) <= 63


def test_export_is_deterministic(small_scene: Scene, tmp_path: Path) -> None:
    export_sceneeval(small_scene, tmp_path / "a")
    export_sceneeval(small_scene, tmp_path / "b")
    files_a = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    files_b = sorted(p.relative_to(tmp_path / "b") for p in (tmp_path / "b").rglob("*") if p.is_file())
    assert files_a == files_b
    for rel in files_a:
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel

"""SceneEval sceneState import: our own export read back, SceneEval's example scenes, bad input."""

from __future__ import annotations

import copy
import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import MODEL_ID_PREFIX, export_sceneeval, load_scene
from scenemosaic.exchange._sceneeval_read import import_sceneeval, looks_like_sceneeval
from scenemosaic.scene import Scene

REAL_FILES = ["layoutvlm_scene_0.json", "layoutvlm_scene_1.json", "atiss_scene_0.json"]


def _read(path: Path) -> Any:
    return json.loads(path.read_text())


def _import(path: Path, **kwargs: Any) -> Scene:
    return import_sceneeval(_read(path), path, **kwargs)


def _asset_id(model_id: str) -> str:
    return model_id.split(".", 1)[1]


def _quat_close(a: tuple[float, ...], b: tuple[float, ...], tol: float) -> bool:
    return bool(min(np.abs(np.subtract(a, b)).max(), np.abs(np.add(a, b)).max()) <= tol)


@pytest.fixture(scope="module")
def dining(repo_data: Path) -> Scene:
    return load_scene(repo_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json")


@pytest.fixture()
def small_export(small_scene: Scene, tmp_path: Path) -> Path:
    return export_sceneeval(small_scene, tmp_path / "sceneeval")


# -- our own export --------------------------------------------------------------------------------


@pytest.mark.parametrize("which", ["dining", "small_scene"])
def test_own_export_round_trips(which: str, request: pytest.FixtureRequest, tmp_path: Path) -> None:
    scene: Scene = request.getfixturevalue(which)
    path = export_sceneeval(scene, tmp_path / "sceneeval")
    assert path.name == "scene_base.json"
    assert looks_like_sceneeval(_read(path))
    back = _import(path)

    assert [o.id for o in back.objects] == [o.id for o in scene.objects]
    assert [o.category for o in back.objects] == [o.category for o in scene.objects]
    for ours, theirs in zip(scene.objects, back.objects, strict=True):
        np.testing.assert_allclose(theirs.pose.position, ours.pose.position, atol=1e-6, err_msg=ours.id)
        assert _quat_close(theirs.pose.quaternion, ours.pose.quaternion, 1e-6), ours.id
        np.testing.assert_allclose(theirs.size, ours.size, atol=1e-3, err_msg=ours.id)
        assert theirs.asset.kind == "mesh" and theirs.asset.uri is not None
        assert theirs.asset.uri.startswith("assets/") and (path.parent / theirs.asset.uri).is_file()
        assert theirs.asset.sha256 is not None and theirs.asset.source_transform is not None

    assert scene.room is not None and back.room is not None
    assert back.room.floor == scene.room.floor
    assert back.room.id == scene.room.id
    assert back.room.ceiling_height == pytest.approx(scene.room.ceiling_height)
    assert [w.id for w in back.room.walls] == [w.id for w in scene.room.walls]
    for ours_w, theirs_w in zip(scene.room.walls, back.room.walls, strict=True):
        assert theirs_w.start == ours_w.start and theirs_w.end == ours_w.end
        assert theirs_w.height == pytest.approx(ours_w.height)
        assert theirs_w.thickness == pytest.approx(ours_w.thickness)
        assert [o.kind for o in theirs_w.openings] == [o.kind for o in ours_w.openings]
        for a, b in zip(ours_w.openings, theirs_w.openings, strict=True):
            assert (b.center, b.width, b.bottom, b.height) == pytest.approx(
                (a.center, a.width, a.bottom, a.height)
            )
    # no parentId is written, so no relation comes back: support is inferred later
    assert back.relations == []
    assert back.provenance.source_format == "sceneeval"
    assert back.metadata["sceneeval"]["model_ids"] == {
        o["id"]: o["modelId"] for o in _read(path)["scene"]["object"]
    }


def test_round_trip_meshes_are_the_exported_ones(small_scene: Scene, small_export: Path) -> None:
    """The imported pose and extents put each canonical mesh where SceneEval puts the GLB."""
    from scenemosaic.render import object_world_mesh

    back = _import(small_export)
    state = _read(small_export)["scene"]["object"]
    for obj, entry in zip(back.objects, state, strict=True):
        raw = trimesh.load(
            small_export.parent / "assets" / f"{_asset_id(entry['modelId'])}.glb", force="mesh"
        )
        raw.apply_transform(np.asarray(entry["transform"]["data"]).reshape(4, 4).T)
        ours = object_world_mesh(obj, small_export.parent)
        np.testing.assert_allclose(ours.bounds, raw.bounds, atol=1e-5, err_msg=obj.id)


# -- SceneEval's example scenes (no meshes shipped) ------------------------------------------------


@pytest.mark.parametrize("name", REAL_FILES)
def test_real_file_without_meshes_names_the_missing_assets(repo_data: Path, name: str) -> None:
    path = repo_data / "sceneeval_scenestate" / name
    data = _read(path)
    assert looks_like_sceneeval(data)
    with pytest.raises(ImportFormatError) as info:
        import_sceneeval(data, path)
    message = str(info.value)
    wanted = {_asset_id(o["modelId"]) for o in data["scene"]["object"]}
    assert f"{len(wanted)} asset mesh(es) not found" in message
    for asset_id in wanted:  # at most 10 distinct ones in these files: all are listed
        assert asset_id in message
    assert "asset_dir=" in message and "--asset-dir" in message
    assert str(path.parent / "assets") in message
    assert info.value.path == str(path)


def _box_assets(folder: Path, asset_ids: set[str]) -> dict[str, tuple[float, float, float]]:
    """One small box GLB per asset id, each of a different size (glTF frame: x, y up, z)."""
    folder.mkdir(parents=True, exist_ok=True)
    sizes: dict[str, tuple[float, float, float]] = {}
    for k, asset_id in enumerate(sorted(asset_ids)):
        size = (0.3 + 0.05 * k, 0.4 + 0.03 * k, 0.2 + 0.02 * k)
        box = trimesh.creation.box(extents=size)
        (folder / f"{asset_id}.glb").write_bytes(box.export(file_type="glb"))
        sizes[asset_id] = size
    return sizes


@pytest.mark.parametrize("name", REAL_FILES)
def test_real_file_with_an_asset_dir(repo_data: Path, tmp_path: Path, name: str) -> None:
    path = repo_data / "sceneeval_scenestate" / name
    data = _read(path)
    entries = data["scene"]["object"]
    assets = tmp_path / "meshes"
    sizes = _box_assets(assets, {_asset_id(o["modelId"]) for o in entries})
    scene = import_sceneeval(data, path, asset_dir=assets)

    assert len(scene.objects) == len(entries)
    assert [o.id for o in scene.objects] == [str(o["id"]) for o in entries]
    for obj, entry in zip(scene.objects, entries, strict=True):
        assert all(math.isfinite(v) for v in (*obj.pose.position, *obj.pose.quaternion, *obj.pose.scale))
        # uris outside the scene folder stay absolute
        assert obj.asset.uri == (assets / f"{_asset_id(entry['modelId'])}.glb").resolve().as_posix()
        # the glTF box (x, y up, z) is (x, z, y) in our frame
        sx, sy, sz = sizes[_asset_id(entry["modelId"])]
        np.testing.assert_allclose(obj.asset.extents, (sx, sz, sy), atol=1e-6)
        # where SceneEval would put the box: the raw GLB under the column-major transform
        raw = trimesh.creation.box(extents=(sx, sy, sz))
        raw.apply_transform(np.asarray(entry["transform"]["data"], dtype=float).reshape(4, 4).T)
        lo, hi = obj.aabb()
        np.testing.assert_allclose(lo, raw.bounds[0], atol=1e-5, err_msg=obj.id)
        np.testing.assert_allclose(hi, raw.bounds[1], atol=1e-5, err_msg=obj.id)

    arch = data["scene"]["arch"]["elements"]
    floor = next(e for e in arch if e["type"] == "Floor")
    walls = [e for e in arch if e["type"] == "Wall"]
    assert scene.room is not None
    assert {tuple(p) for p in scene.room.floor} == {(float(p[0]), float(p[1])) for p in floor["points"]}
    assert len(scene.room.walls) == len(walls)
    assert scene.room.ceiling_height == pytest.approx(max(w["height"] for w in walls))
    for wall in scene.room.walls:  # every wall keeps the room on its left, whatever the file's winding
        mid = (np.add(wall.start, wall.end) / 2) + 0.01 * wall.inward_normal
        xs, ys = zip(*scene.room.floor, strict=True)
        assert min(xs) < mid[0] < max(xs) and min(ys) < mid[1] < max(ys), wall.id
    assert scene.relations == []  # every parentId is empty


def test_asset_dir_wins_over_the_folder_beside_the_file(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    ids = {_asset_id(o["modelId"]) for o in data["scene"]["object"]}
    other = tmp_path / "elsewhere"
    _box_assets(other, ids)
    scene = import_sceneeval(data, small_export, asset_dir=other)
    assert all(
        o.asset.uri is not None and o.asset.uri.startswith(other.resolve().as_posix()) for o in scene.objects
    )


# -- fields ----------------------------------------------------------------------------------------


def _write(tmp_path: Path, source: Path, data: Any) -> Path:
    """Write ``data`` beside a copy of the exported assets (so only the JSON differs).

    A copy, not a symlink: a link to a folder outside the scene's would be refused."""
    folder = tmp_path / "edited"
    if not folder.exists():
        shutil.copytree(source.parent / "assets", folder / "assets")
    path = folder / "scene_base.json"
    path.write_text(json.dumps(data))
    return path


def test_category_from_the_model_id(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    for entry in data["scene"]["object"]:
        del entry["category"]
    path = _write(tmp_path, small_export, data)
    scene = _import(path)
    # our asset ids are <category>_<10 hex digits>: the hash is dropped, synonyms normalized (tv)
    assert [o.category for o in scene.objects] == [
        "dining_table",
        "dining_chair",
        "pendant_lamp",
        "television",
        "mug",
        "book",
    ]


def test_category_of_a_bare_uid_is_object(repo_data: Path, tmp_path: Path) -> None:
    path = repo_data / "sceneeval_scenestate" / "layoutvlm_scene_0.json"
    data = _read(path)
    assets = tmp_path / "meshes"
    _box_assets(assets, {_asset_id(o["modelId"]) for o in data["scene"]["object"]})
    scene = import_sceneeval(data, path, asset_dir=assets)
    assert {o.category for o in scene.objects} == {"object"}


def test_parent_ids_become_attach_relations(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    by_id = {o["id"]: o for o in data["scene"]["object"]}
    wall_2 = next(e["id"] for e in data["scene"]["arch"]["elements"] if str(e["id"]).endswith("|wall_2"))
    by_id["mug"]["parentId"] = "table"
    by_id["book"]["parentId"] = "table"
    by_id["tv"]["parentId"] = wall_2  # an arch element: becomes our wall
    by_id["lamp"]["parentId"] = "nowhere"
    by_id["chair"]["parentId"] = ""
    scene = _import(_write(tmp_path, small_export, data))
    got = {(r.kind, r.child, r.parent) for r in scene.relations}
    assert got == {("attach", "mug", "table"), ("attach", "book", "table"), ("attach", "tv", "wall_2")}
    assert any("'nowhere'" in n for n in scene.provenance.notes)


def test_clockwise_arch_walls_are_turned(small_scene: Scene, small_export: Path, tmp_path: Path) -> None:
    """A file whose floor and walls wind clockwise gives the same room: walls keep it on their left."""
    data = _read(small_export)
    elements = data["scene"]["arch"]["elements"]
    floor = next(e for e in elements if e["type"] == "Floor")
    floor["points"] = floor["points"][::-1]
    for e in elements:
        if e["type"] == "Wall":
            e["points"] = e["points"][::-1]
            for hole in e["holes"]:  # holes are measured from the wall's (new) start
                length = math.dist(e["points"][0][:2], e["points"][1][:2])
                lo, hi = hole["box"]["min"], hole["box"]["max"]
                hole["box"] = {"min": [length - hi[0], lo[1]], "max": [length - lo[0], hi[1]]}
    scene = _import(_write(tmp_path, small_export, data))
    assert scene.room is not None and small_scene.room is not None
    assert scene.room.floor == small_scene.room.floor
    for ours, theirs in zip(small_scene.room.walls, scene.room.walls, strict=True):
        assert (theirs.start, theirs.end) == (ours.start, ours.end)
        for a, b in zip(ours.openings, theirs.openings, strict=True):
            assert (b.center, b.width, b.bottom, b.height) == pytest.approx(
                (a.center, a.width, a.bottom, a.height)
            )


def test_a_parent_cycle_is_broken(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    by_id = {o["id"]: o for o in data["scene"]["object"]}
    by_id["mug"]["parentId"] = "book"
    by_id["book"]["parentId"] = "mug"
    scene = _import(_write(tmp_path, small_export, data))
    assert [(r.child, r.parent) for r in scene.relations] == [("mug", "book")]
    assert any("cycle" in n for n in scene.provenance.notes)


def test_scaled_transform_gives_pose_scale(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    entry = data["scene"]["object"][0]
    m = np.asarray(entry["transform"]["data"]).reshape(4, 4).T
    m[:3, :3] = m[:3, :3] @ np.diag([2.0, 3.0, 0.5])  # glTF-frame scale: x, y (up), z (front)
    entry["transform"]["data"] = m.T.reshape(-1).tolist()
    before = _import(small_export).objects[0]
    after = _import(_write(tmp_path, small_export, data)).objects[0]
    np.testing.assert_allclose(after.pose.scale, (2.0, 0.5, 3.0), atol=1e-9)  # ours: x, y (depth), z (up)
    np.testing.assert_allclose(after.size, before.size * np.array([2.0, 0.5, 3.0]), atol=1e-6)
    assert _quat_close(after.pose.quaternion, before.pose.quaternion, 1e-9)


def test_many_missing_assets_are_counted(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    template = data["scene"]["object"][0]
    data["scene"]["object"] = []
    for k in range(13):
        entry = copy.deepcopy(template)
        entry["id"] = f"thing_{k}"
        entry["modelId"] = f"{MODEL_ID_PREFIX}missing_{k:02d}"
        data["scene"]["object"].append(entry)
    with pytest.raises(
        ImportFormatError, match=r"13 asset mesh\(es\) not found: missing_00, .*missing_09 and 3 more"
    ):
        _import(_write(tmp_path, small_export, data))


# -- bad input -------------------------------------------------------------------------------------


def _set(data: dict[str, Any], dotted: str, value: Any) -> None:
    node: Any = data
    keys = dotted.split(".")
    for key in keys[:-1]:
        node = node[int(key)] if isinstance(node, list) else node[key]
    last = keys[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


@pytest.mark.parametrize(
    ("edit", "value", "field", "message"),
    [
        ("scene.object.3.transform.data.5", float("nan"), "scene.object[3].transform.data[5]", "finite"),
        ("scene.object.1.transform.data.12", float("inf"), "scene.object[1].transform.data[12]", "finite"),
        ("scene.object.2.transform.data", [1.0] * 15, "scene.object[2].transform.data", "16 numbers"),
        ("scene.object.0.transform.data.3", 0.5, "scene.object[0].transform", "not an affine"),
        ("scene.object.0.modelId", "scenemosaic.../etc", "scene.object[0].modelId", "does not name an asset"),
        ("scene.object.0.modelId", 7, "scene.object[0].modelId", "expected a string"),
        ("scene.up", [0, 1, 0], "scene.up", "Z-up"),
        ("scene.unit", 0.01, "scene.unit", "metric"),
        ("format", "sceneGraph", "format", "sceneState"),
        ("scene.arch.elements.1.points", [[0, 0, 0]], "scene.arch.elements[1].points", "2 points"),
        (
            "scene.arch.elements.0.points",
            [[0, 0, 0], [1, 0, 0]],
            "scene.arch.elements[0].points",
            "at least 3",
        ),
    ],
)
def test_bad_fields_are_named(
    small_export: Path, tmp_path: Path, edit: str, value: Any, field: str, message: str
) -> None:
    data = _read(small_export)
    _set(data, edit, value)
    path = _write(tmp_path, small_export, data)
    with pytest.raises(ImportFormatError, match=message) as info:
        _import(path)
    assert info.value.field == field
    assert info.value.path == str(path)


def test_missing_transform_is_named(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    del data["scene"]["object"][4]["transform"]
    with pytest.raises(ImportFormatError, match="missing required field") as info:
        _import(_write(tmp_path, small_export, data))
    assert info.value.field == "scene.object[4].transform"


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        (np.diag([-1.0, 1.0, 1.0]), "mirrors"),
        (np.diag([1.0, 0.0, 1.0]), "degenerate"),
    ],
)
def test_reflections_and_singular_transforms_are_refused(
    small_export: Path, tmp_path: Path, matrix: np.ndarray, message: str
) -> None:
    data = _read(small_export)
    entry = data["scene"]["object"][3]
    m = np.asarray(entry["transform"]["data"]).reshape(4, 4).T
    m[:3, :3] = m[:3, :3] @ matrix
    entry["transform"]["data"] = m.T.reshape(-1).tolist()
    with pytest.raises(ImportFormatError, match=message) as info:
        _import(_write(tmp_path, small_export, data))
    assert info.value.field == "scene.object[3].transform"


def test_detection() -> None:
    assert looks_like_sceneeval({"format": "sceneState", "scene": {}})
    assert not looks_like_sceneeval({"format": "sceneState"})
    assert not looks_like_sceneeval({"format": "other", "scene": {}})
    assert not looks_like_sceneeval({"ThreedFront": {}})
    assert not looks_like_sceneeval([{"format": "sceneState"}])


def test_no_arch_recovers_the_room(small_export: Path, tmp_path: Path) -> None:
    data = _read(small_export)
    del data["scene"]["arch"]
    scene = _import(_write(tmp_path, small_export, data))
    assert scene.room is not None and len(scene.objects) == 6
    assert any("recovered" in n for n in scene.provenance.notes)

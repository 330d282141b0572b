"""object_mesh / object_hulls: procedural, box and mesh assets land in the object's scaled local frame."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from structlog.testing import capture_logs

from scenemosaic.assets import (
    CoacdParams,
    HullCache,
    load_mesh,
    object_hulls,
    object_mesh,
    procedural_parts,
    shutdown_workers,
)
from scenemosaic.exceptions import AssetError
from scenemosaic.scene import AssetRef, Pose, Scene, SceneObject

SAM3D = Path(__file__).resolve().parents[2] / "data/sam3d_objects/generated_assets"
MUG_URI = "manipulands/sdf/coffee_mug_1762992163/coffee_mug.gltf"


@pytest.fixture(scope="module", autouse=True)
def _stop_workers() -> Iterator[None]:
    yield
    shutdown_workers()


def _box_bounds(size: np.ndarray) -> np.ndarray:
    return np.array([[-size[0] / 2, -size[1] / 2, 0.0], [size[0] / 2, size[1] / 2, size[2]]])


def _union(meshes: list) -> np.ndarray:
    return np.array(
        [np.min([m.bounds[0] for m in meshes], axis=0), np.max([m.bounds[1] for m in meshes], axis=0)]
    )


def _object(
    asset: AssetRef, category: str = "chair", scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
) -> SceneObject:
    return SceneObject(
        id="obj_1",
        category=category,
        asset=asset,
        pose=Pose(position=(1.0, 2.0, 0.0), scale=scale),
    )


def test_procedural_object_uses_its_size() -> None:
    obj = _object(
        AssetRef(kind="procedural", category="dining_chair", extents=(0.5, 0.55, 0.95)), scale=(1.2, 1.0, 0.9)
    )
    np.testing.assert_allclose(obj.size, (0.6, 0.55, 0.855))
    mesh = object_mesh(obj)
    np.testing.assert_allclose(mesh.bounds, _box_bounds(obj.size), atol=1e-6)
    hulls = object_hulls(obj)
    np.testing.assert_allclose(_union(hulls), _box_bounds(obj.size), atol=1e-6)
    assert len(hulls) == len(procedural_parts("chair", tuple(obj.size)))
    assert all(h.is_convex for h in hulls)


def test_procedural_asset_without_category_falls_back_to_the_object_category() -> None:
    obj = _object(AssetRef(kind="procedural", extents=(1.8, 0.4, 2.0)), category="ShelvingUnit")
    hulls = object_hulls(obj)
    assert len(hulls) == len(procedural_parts("bookshelf", (1.8, 0.4, 2.0))) > 1
    np.testing.assert_allclose(object_mesh(obj).bounds, _box_bounds(obj.size), atol=1e-6)


def test_box_asset() -> None:
    obj = _object(AssetRef(kind="box", extents=(0.4, 0.3, 0.2)), scale=(2.0, 1.0, 0.5))
    mesh = object_mesh(obj)
    np.testing.assert_allclose(mesh.bounds, [[-0.4, -0.15, 0.0], [0.4, 0.15, 0.1]], atol=1e-12)
    (hull,) = object_hulls(obj)
    np.testing.assert_allclose(hull.bounds, mesh.bounds, atol=1e-12)
    assert hull.volume == pytest.approx(0.8 * 0.3 * 0.1)


def _mug_object(scale: tuple[float, float, float] = (1.0, 1.0, 1.0), **asset: object) -> SceneObject:
    extents = load_mesh(SAM3D / MUG_URI).extents
    return _object(AssetRef(kind="mesh", uri=MUG_URI, extents=extents, **asset), category="mug", scale=scale)  # type: ignore[arg-type]


def test_mesh_asset_visual_is_scaled_to_its_size() -> None:
    obj = _mug_object(scale=(2.0, 1.0, 3.0))
    mesh = object_mesh(obj, SAM3D)
    np.testing.assert_allclose(mesh.bounds, _box_bounds(obj.size), atol=1e-6)
    assert len(mesh.faces) == 40000
    # an absolute uri needs no base_dir
    absolute = _object(obj.asset.model_copy(update={"uri": str(SAM3D / MUG_URI)}), scale=(2.0, 1.0, 3.0))
    np.testing.assert_allclose(object_mesh(absolute).vertices, mesh.vertices, atol=1e-12)


def test_source_transform_is_applied_instead_of_canonicalizing() -> None:
    canonical = load_mesh(SAM3D / MUG_URI)
    with_transform = _mug_object(source_transform=[float(v) for v in canonical.transform.reshape(-1)])
    without = _mug_object()
    np.testing.assert_allclose(
        object_mesh(with_transform, SAM3D).vertices, object_mesh(without, SAM3D).vertices, atol=1e-9
    )
    # a different source transform (a quarter turn about Z) changes the result, and still fits the box
    turn = np.array([[0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0, 0, 0, 1.0]])
    turned = _mug_object(source_transform=[float(v) for v in (turn @ canonical.transform).reshape(-1)])
    mesh = object_mesh(turned, SAM3D)
    np.testing.assert_allclose(mesh.bounds, _box_bounds(turned.size), atol=1e-6)
    assert not np.allclose(mesh.vertices, object_mesh(without, SAM3D).vertices, atol=1e-3)


def test_mesh_asset_hulls_fit_the_scaled_box(
    sam3d_office: Scene, shared_hull_cache: HullCache, shared_params: CoacdParams
) -> None:
    mug = sam3d_office.get("coffee_mug")
    obj = mug.model_copy(update={"pose": mug.pose.model_copy(update={"scale": (2.0, 2.0, 1.5)})})
    cache = shared_hull_cache
    hulls = object_hulls(obj, cache=cache, params=shared_params)
    assert cache.computations + cache.disk_hits == 1  # one decomposition, computed or read back
    assert 2 <= len(hulls) <= shared_params.max_convex_hull
    assert all(h.is_convex and h.is_watertight for h in hulls)
    box = _box_bounds(obj.size)
    union = _union(hulls)
    assert np.all(union[0] >= box[0] - 1e-9) and np.all(union[1] <= box[1] + 1e-9)
    np.testing.assert_allclose(union, box, atol=0.05 * float(obj.size.max()))
    # the same asset at another scale reuses the decomposition of the unscaled mesh
    computed = cache.computations
    unscaled = object_hulls(mug, cache=cache, params=shared_params)
    assert cache.computations == computed
    assert cache.disk_hits == 2 - computed
    assert len(unscaled) == len(hulls)
    np.testing.assert_allclose(_union(unscaled), _box_bounds(mug.size), atol=0.05 * float(mug.size.max()))


def test_missing_mesh_file_names_the_object(tmp_path: Path) -> None:
    obj = _object(AssetRef(kind="mesh", uri="missing/chair.glb", extents=(0.5, 0.5, 0.9)))
    with pytest.raises(AssetError, match=r"obj_1.*missing/chair\.glb"):
        object_mesh(obj, tmp_path)
    with pytest.raises(AssetError, match="obj_1"):
        object_hulls(obj, tmp_path, cache=HullCache(tmp_path / "hulls"))


def test_hash_mismatch_is_logged() -> None:
    obj = _mug_object(sha256="0" * 64)
    with capture_logs() as logs:
        object_mesh(obj, SAM3D)
    assert any(e["event"] == "asset_hash_mismatch" for e in logs)
    good = _mug_object(sha256=load_mesh(SAM3D / MUG_URI).sha256)
    with capture_logs() as logs:
        object_mesh(good, SAM3D)
    assert not any(e["event"] == "asset_hash_mismatch" for e in logs)

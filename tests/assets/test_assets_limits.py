"""Mesh limits and degenerate mesh files: face caps, the decimation target before CoACD, the vertex
cap of the single-hull fallback, directories, empty files and symlink loops."""

from __future__ import annotations

import stat
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from scenemosaic.assets import CoacdParams, HullCache, _canonical, _hulls, load_mesh, shutdown_workers
from scenemosaic.assets._coacd_worker import RawPiece
from scenemosaic.exceptions import AssetError, UnsafePathError
from scenemosaic.scene import COACD_MAX_FACES, MAX_HULL_VERTICES

PARAMS = CoacdParams(seed=5)


@pytest.fixture(scope="module", autouse=True)
def _stop_workers() -> Iterator[None]:
    yield
    shutdown_workers()


@pytest.fixture
def sphere() -> trimesh.Trimesh:
    """A smooth closed mesh whose every vertex (2562 of them) is on its convex hull."""
    mesh: trimesh.Trimesh = trimesh.creation.icosphere(subdivisions=4, radius=0.3)
    return mesh


def _write_obj(path: Path, mesh: trimesh.Trimesh) -> Path:
    path.write_text(mesh.export(file_type="obj"))
    return path


# -- files ---------------------------------------------------------------------------------------------


def test_a_directory_is_not_a_mesh(tmp_path: Path) -> None:
    (tmp_path / "chair.glb").mkdir()
    with pytest.raises(AssetError, match=r"chair\.glb: is a directory, not a mesh file"):
        load_mesh(tmp_path / "chair.glb")


def test_an_empty_file_is_not_a_mesh(tmp_path: Path) -> None:
    (tmp_path / "chair.obj").touch()
    with pytest.raises(AssetError, match=r"chair\.obj: empty mesh file \(0 bytes\)"):
        load_mesh(tmp_path / "chair.obj")


def test_a_symlink_loop_is_a_clean_asset_error(tmp_path: Path) -> None:
    (tmp_path / "a.obj").symlink_to(tmp_path / "b.obj")
    (tmp_path / "b.obj").symlink_to(tmp_path / "a.obj")
    with pytest.raises(UnsafePathError, match="symlink loop"):
        load_mesh(tmp_path / "a.obj")


def test_mesh_types_that_name_unchecked_files_are_refused(tmp_path: Path) -> None:
    (tmp_path / "robot.urdf").write_text('<robot name="r"><link name="l"/></robot>')
    with pytest.raises(AssetError, match=r"unsupported mesh file type '\.urdf'"):
        load_mesh(tmp_path / "robot.urdf")


def test_meshes_above_the_face_limit_are_refused(
    sphere: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _write_obj(tmp_path / "dense.obj", sphere)
    monkeypatch.setattr(_canonical, "MAX_MESH_FACES", 1000)  # the real limit is millions of faces
    with pytest.raises(AssetError, match=r"dense\.obj: 5120 faces; meshes may have at most 1000"):
        load_mesh(path)
    monkeypatch.setattr(_hulls, "MAX_MESH_FACES", 1000)
    with pytest.raises(AssetError, match="5120 faces"):
        HullCache(tmp_path / "cache").get(sphere, PARAMS)


# -- decimation before CoACD ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("asked", "sent"),
    [(4000, 4000), (COACD_MAX_FACES, COACD_MAX_FACES), (0, COACD_MAX_FACES), (10 * COACD_MAX_FACES, COACD_MAX_FACES)],
)
def test_coacd_input_is_decimated_to_the_documented_target(
    sphere: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, asked: int, sent: int
) -> None:
    calls: list[dict[str, Any]] = []

    def decompose(vertices: Any, faces: Any, options: dict[str, Any]) -> list[RawPiece]:
        calls.append(options)
        hull = trimesh.convex.convex_hull(vertices)
        return [(np.asarray(hull.vertices), np.asarray(hull.faces))]

    with ThreadPoolExecutor(max_workers=1) as executor:
        monkeypatch.setattr(HullCache, "_submit", lambda _c, v, f, o: executor.submit(decompose, v, f, o))
        HullCache(tmp_path).get(sphere, CoacdParams(simplify_faces=asked))
    assert [c["simplify_faces"] for c in calls] == [sent]


def test_the_worker_decimates_a_dense_mesh_before_coacd() -> None:
    from scenemosaic.assets._coacd_worker import _simplify

    dense = trimesh.creation.icosphere(subdivisions=6)  # 81,920 faces
    vertices, faces = _simplify(np.asarray(dense.vertices), np.asarray(dense.faces), COACD_MAX_FACES)
    assert len(dense.faces) > COACD_MAX_FACES >= len(faces) > 0.9 * COACD_MAX_FACES
    assert len(vertices) < len(dense.vertices)


# -- the single-hull fallback -----------------------------------------------------------------------


def test_fallback_hull_is_capped_with_the_same_bounds(sphere: trimesh.Trimesh) -> None:
    assert len(sphere.convex_hull.vertices) > MAX_HULL_VERTICES
    ((vertices, faces),) = _hulls._single_hull(sphere)
    hull = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    assert len(vertices) <= MAX_HULL_VERTICES
    np.testing.assert_allclose(hull.bounds, sphere.bounds, atol=1e-9)  # the extremes are kept
    assert hull.is_convex and hull.is_watertight
    assert 0.9 * sphere.convex_hull.volume < hull.volume <= sphere.convex_hull.volume + 1e-12


def test_small_fallback_hulls_are_left_alone() -> None:
    box = trimesh.creation.box(extents=(1.0, 0.5, 0.3))
    ((vertices, _),) = _hulls._single_hull(box)
    assert len(vertices) == 8


def test_a_failed_decomposition_gives_a_capped_hull(
    sphere: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def fail(vertices: Any, faces: Any, options: Any) -> Any:
        raise RuntimeError("simulated CoACD crash")

    with ThreadPoolExecutor(max_workers=1) as executor:
        monkeypatch.setattr(HullCache, "_submit", lambda _c, v, f, o: executor.submit(fail, v, f, o))
        cache = HullCache(tmp_path)
        (piece,) = cache.get(sphere, PARAMS)
    assert cache.fallbacks == 1 and len(piece.vertices) <= MAX_HULL_VERTICES


def test_cache_files_get_the_ordinary_mode(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    box = trimesh.creation.box(extents=(1.0, 0.5, 0.3))

    def decompose(vertices: Any, faces: Any, options: Any) -> list[RawPiece]:
        return [(np.asarray(box.vertices), np.asarray(box.faces))]

    import os

    old = os.umask(0o022)
    try:
        with ThreadPoolExecutor(max_workers=1) as executor:
            monkeypatch.setattr(HullCache, "_submit", lambda _c, v, f, o: executor.submit(decompose, v, f, o))
            cache = HullCache(tmp_path)
            cache.get(box, PARAMS)
    finally:
        os.umask(old)
    key = cache.key(box, PARAMS)
    assert stat.S_IMODE(cache.path_for(key).stat().st_mode) == 0o644
    assert cache.lock_path(key).exists()  # the lock file stays (removing it would race)

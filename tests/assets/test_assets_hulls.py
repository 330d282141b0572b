"""HullCache: CoACD in a worker process, disk cache, corruption recovery, async without blocking."""

from __future__ import annotations

import asyncio
import shutil
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull
from structlog.testing import capture_logs

from scenemosaic.assets import CoacdParams, HullCache, default_cache_dir, shutdown_workers
from scenemosaic.assets._objects import _canonical
from scenemosaic.exceptions import AssetError
from scenemosaic.scene import Scene

# Coarse, fast settings (seconds, not minutes) for the synthetic ring: the behaviour under test does
# not depend on quality. Real meshes use the suite's shared settings and cache (conftest).
FAST = CoacdParams(
    threshold=0.15,
    max_convex_hull=8,
    preprocess_resolution=20,
    simplify_faces=500,
    resolution=500,
    mcts_nodes=10,
    mcts_iterations=60,
)


@pytest.fixture(scope="module", autouse=True)
def _stop_workers() -> Iterator[None]:
    yield
    shutdown_workers()


@pytest.fixture(scope="module")
def mug(sam3d_office: Scene) -> trimesh.Trimesh:
    """The example's coffee mug in the canonical frame, exactly as ``object_hulls`` decomposes it."""
    return _canonical(sam3d_office.get("coffee_mug"), None)


@pytest.fixture(scope="module")
def mug_pieces(
    mug: trimesh.Trimesh, shared_hull_cache_dir: Path, shared_params: CoacdParams
) -> list[trimesh.Trimesh]:
    cache = HullCache(shared_hull_cache_dir)
    pieces = cache.get(mug, shared_params)
    assert cache.computations + cache.disk_hits == 1  # computed (cold checkout) or read, once
    assert cache.fallbacks == 0
    return pieces


def _inside_any(points: np.ndarray, pieces: list[trimesh.Trimesh], tolerance: float) -> np.ndarray:
    inside = np.zeros(len(points), dtype=bool)
    for piece in pieces:
        eq = ConvexHull(piece.vertices).equations  # rows (n, offset) with n.x + offset <= 0 inside
        inside |= np.all(points @ eq[:, :3].T + eq[:, 3] <= tolerance, axis=1)
    return inside


def test_mug_decomposes_into_convex_pieces_covering_it(
    mug: trimesh.Trimesh, mug_pieces: list[trimesh.Trimesh]
) -> None:
    assert 2 <= len(mug_pieces) <= CoacdParams.fast().max_convex_hull  # a real decomposition
    for piece in mug_pieces:
        assert piece.is_watertight
        assert piece.is_convex
        assert piece.volume > 0
    # nearly all of the mug's surface lies in (or within 2 mm of) some piece
    points, _ = trimesh.sample.sample_surface(mug, 3000, seed=0)
    covered = _inside_any(points, mug_pieces, tolerance=0.002)
    assert covered.mean() >= 0.9
    # and the pieces do not balloon past the mug's box
    lo = np.min([p.bounds[0] for p in mug_pieces], axis=0)
    hi = np.max([p.bounds[1] for p in mug_pieces], axis=0)
    size = mug.extents
    np.testing.assert_allclose(lo, mug.bounds[0], atol=0.1 * size.max())
    np.testing.assert_allclose(hi, mug.bounds[1], atol=0.1 * size.max())
    # the pieces' volume is of the order of the mug's closed volume (a mug's hulls fill the cup)
    closed = trimesh.Trimesh(mug.vertices, mug.faces)
    closed.merge_vertices(merge_tex=True, merge_norm=True)
    ratio = sum(p.volume for p in mug_pieces) / abs(closed.volume)
    assert 0.9 <= ratio <= 3.0


def test_second_get_is_served_from_disk(
    mug: trimesh.Trimesh,
    shared_hull_cache_dir: Path,
    shared_params: CoacdParams,
    mug_pieces: list[trimesh.Trimesh],
) -> None:
    cache = HullCache(shared_hull_cache_dir)
    start = time.perf_counter()
    again = cache.get(mug, shared_params)
    elapsed = time.perf_counter() - start
    assert cache.computations == 0  # no worker job was started
    assert cache.disk_hits == 1
    assert elapsed < 2.0
    assert len(again) == len(mug_pieces)
    for a, b in zip(again, mug_pieces, strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
    # the layout: <root>/<key[:2]>/<key>.npz, and no temporary file of this key left behind
    key = cache.key(mug, shared_params)
    assert cache.path_for(key) == shared_hull_cache_dir / key[:2] / f"{key}.npz"
    assert cache.path_for(key).is_file()
    assert not list(cache.path_for(key).parent.glob(f".{key[:16]}.*.tmp"))


def test_key_depends_on_mesh_and_every_param(mug: trimesh.Trimesh, tmp_path: Path) -> None:
    cache = HullCache(tmp_path)
    key = cache.key(mug, FAST)
    assert key == HullCache(tmp_path / "other").key(mug.copy(), CoacdParams(**FAST.__dict__))
    assert key != cache.key(mug, CoacdParams(**{**FAST.__dict__, "seed": 1}))
    assert key != cache.key(mug, CoacdParams(**{**FAST.__dict__, "simplify_faces": 501}))
    moved = mug.copy()
    moved.apply_translation((0.01, 0.0, 0.0))
    assert key != cache.key(moved, FAST)


@pytest.fixture
def ring() -> trimesh.Trimesh:
    """A small non-convex mesh that CoACD splits in a second or two."""
    mesh: trimesh.Trimesh = trimesh.creation.annulus(r_min=0.2, r_max=0.4, height=0.3, sections=24)
    return mesh


@pytest.fixture(scope="module")
def ring_file(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    """The ring decomposed once, cold, with FAST: its cache file and piece count."""
    ring: trimesh.Trimesh = trimesh.creation.annulus(r_min=0.2, r_max=0.4, height=0.3, sections=24)
    cache = HullCache(tmp_path_factory.mktemp("ring-hulls"))
    pieces = cache.get(ring, FAST)
    assert cache.computations == 1 and cache.disk_hits == 0
    assert len(pieces) >= 2  # a ring is not convex
    return cache.path_for(cache.key(ring, FAST)), len(pieces)


@pytest.mark.parametrize("damage", ["garbage", "truncated", "empty", "npy", "other-key"])
def test_corrupted_file_is_recomputed(
    ring: trimesh.Trimesh, ring_file: tuple[Path, int], tmp_path: Path, damage: str
) -> None:
    stored, count = ring_file
    first = HullCache(tmp_path)
    path = first.path_for(first.key(ring, FAST))
    path.parent.mkdir(parents=True)
    shutil.copyfile(stored, path)
    assert len(first.get(ring, FAST)) == count and first.disk_hits == 1  # the intact file reads back
    data = path.read_bytes()
    if damage == "garbage":
        path.write_bytes(b"not a zip file at all" * 10)
    elif damage == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "npy":
        with open(path, "wb") as fh:
            np.save(fh, np.zeros((3, 3)))
    else:  # a readable file that belongs to another key
        with open(path, "wb") as fh:
            np.savez(
                fh, meta=np.array('{"key": "0000", "pieces": 1}'), vertices_0=np.eye(3), faces_0=np.eye(3)
            )
    second = HullCache(tmp_path)
    with capture_logs() as logs:
        again = second.get(ring, FAST)
    assert second.computations == 1
    assert any(e["event"] == "hull_cache_corrupt" and e["log_level"] == "warning" for e in logs)
    assert len(again) == count
    third = HullCache(tmp_path)  # the file was rewritten and reads back
    third.get(ring, FAST)
    assert third.computations == 0
    assert third.disk_hits == 1


async def test_aget_does_not_block_the_event_loop(ring: trimesh.Trimesh, tmp_path: Path) -> None:
    cache = HullCache(tmp_path)
    params = CoacdParams(**{**FAST.__dict__, "seed": 7})
    ticks: list[float] = []
    done = asyncio.Event()

    async def ticker() -> None:
        while not done.is_set():
            ticks.append(time.perf_counter())
            await asyncio.sleep(0.01)

    tick_task = asyncio.create_task(ticker())
    start = time.perf_counter()
    pieces, twin = await asyncio.gather(cache.aget(ring, params), cache.aget(ring, params))
    elapsed = time.perf_counter() - start
    done.set()
    await tick_task
    assert len(pieces) == len(twin) >= 2
    assert cache.computations == 1  # concurrent requests for one key share one computation
    assert elapsed > 0.2  # it really computed
    gaps = np.diff(ticks)
    assert gaps.max() < 0.5, f"the loop stalled for {gaps.max():.2f} s"
    assert len(ticks) >= 0.3 * elapsed / 0.01
    # and a second aget comes from disk
    again = await HullCache(tmp_path).aget(ring, params)
    assert len(again) == len(pieces)


def test_degenerate_meshes_raise(tmp_path: Path) -> None:
    cache = HullCache(tmp_path)
    flat = trimesh.Trimesh(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]], process=False
    )
    with pytest.raises(AssetError, match="flat"):
        cache.get(flat, FAST)
    nan = trimesh.creation.box()
    nan.vertices[0] = [np.nan, 0.0, 0.0]
    with pytest.raises(AssetError, match="non-finite"):
        cache.get(nan, FAST)
    empty = trimesh.Trimesh()
    with pytest.raises(AssetError, match="without faces"):
        cache.get(empty, FAST)
    assert cache.computations == 0


def _always_fails(vertices: Any, faces: Any, options: Any) -> Any:
    raise RuntimeError("simulated CoACD crash")


def test_coacd_failure_falls_back_to_the_convex_hull(
    ring: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with ThreadPoolExecutor(max_workers=1) as executor:
        monkeypatch.setattr(HullCache, "_submit", lambda _c, v, f, o: executor.submit(_always_fails, v, f, o))
        cache = HullCache(tmp_path)
        with capture_logs() as logs:
            pieces = cache.get(ring, FAST)
    assert len(pieces) == 1
    assert pieces[0].volume == pytest.approx(ring.convex_hull.volume)
    assert cache.fallbacks == 1
    assert any(e["event"] == "coacd_failed_using_convex_hull" for e in logs)
    assert not cache.path_for(cache.key(ring, FAST)).exists()  # a fallback is not cached


def test_default_cache_dir_honours_the_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SCENEMOSAIC_CACHE", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c"
    assert HullCache().root == tmp_path / "c" / "hulls"
    monkeypatch.delenv("SCENEMOSAIC_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "scenemosaic"


def test_warm_cache_is_at_least_50x_faster_than_a_cold_decomposition(ring: trimesh.Trimesh, tmp_path: Path) -> None:
    """The acceptance ratio of issue 2, measured in the suite too (benchmarks/assets.py reports it)."""
    params = CoacdParams(**{**FAST.__dict__, "seed": 23})
    cold_cache = HullCache(tmp_path)
    start = time.perf_counter()
    cold_pieces = cold_cache.get(ring, params)
    cold = time.perf_counter() - start
    assert cold_cache.computations == 1
    warm_times = []
    for _ in range(3):  # best of three: a shared machine may stall one read
        warm_cache = HullCache(tmp_path)  # a new instance: served from disk, not from memory
        start = time.perf_counter()
        warm_pieces = warm_cache.get(ring, params)
        warm_times.append(time.perf_counter() - start)
        assert warm_cache.computations == 0 and warm_cache.disk_hits == 1
        assert [p.vertices.tolist() for p in warm_pieces] == [p.vertices.tolist() for p in cold_pieces]
    assert cold >= 50 * min(warm_times), (cold, warm_times)

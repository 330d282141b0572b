"""HullCache's check after CoACD: pieces that miss part of the mesh, or too many of them, give way
to the mesh's single convex hull (logged, counted, and stored like any result)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from structlog.testing import capture_logs

from scenemosaic.assets import CoacdParams, HullCache, object_hulls, shutdown_workers
from scenemosaic.assets._coacd_worker import RawPiece
from scenemosaic.assets._hulls import MAX_PIECES, MIN_COVERAGE
from scenemosaic.assets._objects import _canonical
from scenemosaic.scene import Scene

PARAMS = CoacdParams(seed=3)  # nothing runs CoACD here except the real printer below
EVENT = "coacd_poor_pieces_using_convex_hull"


@pytest.fixture(scope="module", autouse=True)
def _stop_workers() -> Iterator[None]:
    yield
    shutdown_workers()


@pytest.fixture
def table() -> trimesh.Trimesh:
    """A non-convex mesh (a top on four legs), 1.2 x 0.8 x 0.75 m, whose convex hull is its box."""
    parts = [trimesh.creation.box(bounds=[[-0.6, -0.4, 0.7], [0.6, 0.4, 0.75]])]
    for x in (-0.55, 0.55):
        for y in (-0.35, 0.35):
            parts.append(trimesh.creation.box(bounds=[[x - 0.05, y - 0.05, 0.0], [x + 0.05, y + 0.05, 0.7]]))
    mesh: trimesh.Trimesh = trimesh.util.concatenate(parts)
    return mesh


def _box(lo: list[float], hi: list[float]) -> RawPiece:
    b = trimesh.creation.box(bounds=[lo, hi])
    return np.asarray(b.vertices, dtype=np.float64), np.asarray(b.faces, dtype=np.int64)


def _fake_coacd(
    monkeypatch: pytest.MonkeyPatch, executor: ThreadPoolExecutor, pieces: list[RawPiece]
) -> list[dict[str, Any]]:
    """Run "CoACD" in a thread and have it return ``pieces``; the options it got are recorded."""
    calls: list[dict[str, Any]] = []

    def decompose(vertices: Any, faces: Any, options: dict[str, Any]) -> list[RawPiece]:
        calls.append(options)
        return pieces

    monkeypatch.setattr(HullCache, "_submit", lambda _c, v, f, o: executor.submit(decompose, v, f, o))
    return calls


def _meta(cache: HullCache, key: str) -> dict[str, Any]:
    with np.load(cache.path_for(key)) as data:
        meta: dict[str, Any] = json.loads(str(data["meta"]))
    return meta


def test_slivers_missing_half_the_mesh_fall_back_to_the_convex_hull(
    table: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the table top and the two front legs: full width and height, but only 55 % of the depth
    slivers = [
        _box([-0.6, -0.4, 0.7], [0.6, 0.04, 0.75]),
        _box([-0.6, -0.4, 0.0], [-0.5, -0.3, 0.7]),
        _box([0.5, -0.4, 0.0], [0.6, -0.3, 0.7]),
    ]
    with ThreadPoolExecutor(max_workers=1) as executor:
        calls = _fake_coacd(monkeypatch, executor, slivers)
        cache = HullCache(tmp_path)
        with capture_logs() as logs:
            pieces = cache.get(table, PARAMS)
    assert len(calls) == 1
    assert len(pieces) == 1
    np.testing.assert_allclose(pieces[0].bounds, table.bounds, atol=1e-9)
    assert pieces[0].volume == pytest.approx(table.convex_hull.volume)
    assert pieces[0].is_convex and pieces[0].is_watertight
    assert cache.fallbacks == 1 and cache.computations == 1
    warnings = [e for e in logs if e["event"] == EVENT]
    assert len(warnings) == 1 and warnings[0]["log_level"] == "warning"
    assert "y 55%" in warnings[0]["problem"]
    # deterministic for its key, so stored: a new instance reads the hull back without CoACD
    key = cache.key(table, PARAMS)
    assert "y 55%" in _meta(cache, key)["fallback"]
    again = HullCache(tmp_path)
    (piece,) = again.get(table, PARAMS)
    assert again.computations == 0 and again.disk_hits == 1 and again.fallbacks == 0
    np.testing.assert_array_equal(piece.vertices, pieces[0].vertices)


def test_pieces_covering_the_bounds_are_kept(
    table: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the top and four legs, the back legs 2 cm short of the back edge: 95 % of the depth
    good = [
        _box([-0.6, -0.4, 0.7], [0.6, 0.36, 0.75]),
        *(
            _box([x - 0.05, y - 0.05, 0.0], [x + 0.05, y + 0.05, 0.7])
            for x in (-0.55, 0.55)
            for y in (-0.35, 0.31)
        ),
    ]
    with ThreadPoolExecutor(max_workers=1) as executor:
        _fake_coacd(monkeypatch, executor, good)
        cache = HullCache(tmp_path)
        with capture_logs() as logs:
            pieces = cache.get(table, PARAMS)
    assert MIN_COVERAGE <= 1 - 0.04 / 0.8  # the case is on the accepted side of the threshold
    assert len(pieces) == 5
    assert cache.fallbacks == 0
    assert not [e for e in logs if e["event"] == EVENT]
    assert "fallback" not in _meta(cache, cache.key(table, PARAMS))


def test_too_many_pieces_fall_back_to_the_convex_hull(
    table: trimesh.Trimesh, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a 6 x 6 grid of thin slabs tiling the table top and reaching the floor: full coverage, 36 pieces
    xs, ys = np.linspace(-0.6, 0.6, 7), np.linspace(-0.4, 0.4, 7)
    grid = [
        _box([xs[i], ys[j], 0.0 if (i, j) == (0, 0) else 0.7], [xs[i + 1], ys[j + 1], 0.75])
        for i in range(6)
        for j in range(6)
    ]
    assert len(grid) > max(MAX_PIECES, PARAMS.max_convex_hull)
    with ThreadPoolExecutor(max_workers=1) as executor:
        _fake_coacd(monkeypatch, executor, grid)
        cache = HullCache(tmp_path)
        with capture_logs() as logs:
            pieces = cache.get(table, PARAMS)
    assert len(pieces) == 1 and cache.fallbacks == 1
    (warning,) = [e for e in logs if e["event"] == EVENT]
    assert "36 pieces" in warning["problem"]
    # a larger max_convex_hull raises the cap: the same 36 pieces are then accepted
    roomy = CoacdParams(seed=3, max_convex_hull=40)
    with ThreadPoolExecutor(max_workers=1) as executor:
        _fake_coacd(monkeypatch, executor, grid)
        assert len(HullCache(tmp_path).get(table, roomy)) == 36


def test_real_printer_scan_gets_its_convex_hull(
    sam3d_office: Scene, shared_hull_cache: HullCache, shared_params: CoacdParams
) -> None:
    """The SAM3D printer is an open shell: CoACD's pieces span about 70 % of its depth, so the
    physics tests get its convex hull, which fills the printer's whole box."""
    printer = sam3d_office.get("printer")
    pieces = object_hulls(printer, cache=shared_hull_cache, params=shared_params)
    assert len(pieces) == 1
    size = np.asarray(printer.size)
    box = [[-size[0] / 2, -size[1] / 2, 0.0], [size[0] / 2, size[1] / 2, size[2]]]
    np.testing.assert_allclose(pieces[0].bounds, box, atol=1e-6)
    key = shared_hull_cache.key(_canonical(printer, None), shared_params)
    reason = _meta(shared_hull_cache, key)["fallback"]
    assert "pieces span only" in reason
    # and the mug next to it keeps its real decomposition
    mug = object_hulls(sam3d_office.get("coffee_mug"), cache=shared_hull_cache, params=shared_params)
    assert len(mug) > 1

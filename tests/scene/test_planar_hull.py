"""The 2D convex hull every footprint goes through (``scene.convex_hull_2d``), checked as geometry."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from shapely.geometry import MultiPoint, Point, Polygon

from scenemosaic.scene import convex_hull_2d, edge_axes, outline_polygon

coords = st.floats(min_value=-50, max_value=50, allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=300, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 16), st.just(2)), elements=coords))
def test_the_hull_is_the_smallest_convex_ccw_polygon_of_the_points(points: np.ndarray) -> None:
    hull = convex_hull_2d(points)
    rounded = {tuple(p) for p in np.round(points, 9).tolist()}
    assert hull.shape[1] == 2 and len(hull) <= len(rounded)
    assert {tuple(p) for p in hull.tolist()} <= rounded  # its corners are input points
    assert tuple(hull[0]) == min(rounded)  # starts at the lowest point in (x, y) order
    if len(hull) >= 3:
        ring = Polygon(hull)
        assert ring.exterior.is_ccw and ring.is_valid
        assert abs(ring.area - MultiPoint(list(rounded)).convex_hull.area) < 1e-6 * max(1.0, ring.area)
        grown = ring.buffer(1e-6)
        assert all(grown.covers(Point(p)) for p in rounded)


def test_a_box_seen_from_above_gives_its_four_corners_once() -> None:
    corners = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    hull = convex_hull_2d(np.vstack([corners, corners[::-1], [[1.0, 0.5]]]))  # top and bottom face, and a point inside
    assert hull.tolist() == [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]
    assert convex_hull_2d(np.array([[1.0, 1.0], [1.0, 1.0]])).shape == (1, 2)
    assert convex_hull_2d(np.zeros((0, 2))).shape == (0, 2)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(arrays(np.float64, st.tuples(st.integers(3, 12), st.just(2)), elements=st.floats(-50, 50, allow_nan=False)))
def test_an_outline_polygon_is_the_shapely_polygon_of_its_points(points: np.ndarray) -> None:
    """Issue 38: the planner's fast polygons are shapely's own, point for point."""
    assert outline_polygon(points).wkb == Polygon(points).wkb
    assert outline_polygon(points.astype(np.float32)).wkb == Polygon(points.astype(np.float32)).wkb


def test_an_outline_of_too_few_points_fails_as_shapely_does() -> None:
    with pytest.raises(ValueError):
        Polygon(np.zeros((2, 2)))
    with pytest.raises(ValueError):
        outline_polygon(np.zeros((2, 2)))


@settings(max_examples=300, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 16), st.just(2)), elements=coords))
def test_edge_axes_are_the_unit_outward_normals_of_the_hulls_edges(points: np.ndarray) -> None:
    hull = convex_hull_2d(points)
    axes = edge_axes(hull)
    # the plain formula over arrays, bit for bit: a settle's separating axes may not move
    edges = np.roll(hull, -1, axis=0) - hull
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
    lengths = np.linalg.norm(normals, axis=1)
    expected = normals[lengths > 1e-12] / lengths[lengths > 1e-12, None]
    assert axes.shape == expected.shape and axes.tobytes() == expected.tobytes()
    if len(hull) >= 3:  # unit length, and outward: every corner lies behind each edge's normal
        assert np.allclose(np.linalg.norm(axes, axis=1), 1.0)
        for corner, axis in zip(hull, axes, strict=True):
            assert np.all((hull - corner) @ axis <= 1e-9 * max(1.0, float(np.abs(hull).max())))


_SHARED_REGION_IN_THREADS = """
import threading
import numpy as np
from shapely.geometry import Polygon
from scenemosaic.scene import minimal_containing_shift

angles = np.linspace(0.0, 2.0 * np.pi, 300, endpoint=False)
regions = [
    Polygon(np.c_[np.cos(angles) * (2 + 0.3 * np.sin(5 * angles + k)), np.sin(angles) * (2 + 0.3 * np.cos(3 * angles + k))])
    for k in range(1500)
]
square = np.array([[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]])
start = threading.Barrier(6)
shifts = [[] for _ in range(6)]

def settle(i):
    for k, region in enumerate(regions):
        if k % 20 == 0:
            start.wait()  # every thread asks for the same regions at the same moment
        shifts[i].append(minimal_containing_shift(square * (1 + 4 * (k % 3)), region))

threads = [threading.Thread(target=settle, args=(i,)) for i in range(6)]
for t in threads:
    t.start()
for t in threads:
    t.join()
assert all(len(s) == len(regions) for s in shifts)
for s in shifts[1:]:
    assert all((a is None and b is None) or np.array_equal(a, b) for a, b in zip(s, shifts[0]))
print("same shifts in every thread")
"""


def test_containing_shifts_asked_from_many_threads_at_once_agree_and_do_not_crash() -> None:
    """A unit's variants settle in threads of one process and ask for the same anchor's region:
    the region shrunk once and shared must stay safe to query from all of them at once (a shared
    *prepared* GEOS geometry is not: its lazily built index corrupted the heap, a worker died of
    SIGSEGV). Run in a child process so that a crash fails this test, not the test run."""
    done = subprocess.run([sys.executable, "-c", _SHARED_REGION_IN_THREADS], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    assert "same shifts in every thread" in done.stdout


def test_a_shrunk_region_shared_between_calls_is_not_prepared() -> None:
    from scenemosaic.scene._planar import _inset

    region = Polygon([(0, 0), (4, 0), (4, 3), (0, 3)])
    inner = _inset(region, 0.002)
    assert inner is _inset(Polygon(region.exterior.coords), 0.002)  # made once, shared
    assert not shapely.is_prepared(inner)
    assert inner.bounds == pytest.approx((0.002, 0.002, 3.998, 2.998))

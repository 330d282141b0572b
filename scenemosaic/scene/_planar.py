"""Convex geometry in a plane: hulls, separating axes, and the least move that fits a region.

Shared by the physics units (footprints in a unit's support plane) and by the structuring
agents (furniture boxes seen from above); points are ``(n, 2)`` float arrays.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points

from scenemosaic._memo import Memo
from scenemosaic.scene._geometry import FloatArray

__all__ = ["convex_hull_2d", "edge_axes", "minimal_containing_shift", "outline_polygon", "sat_overlap"]


def _array_constructors() -> bool:
    """Whether shapely's array constructors take a ring's coordinates and NaN rule (shapely >= 2.1)."""
    try:
        ring = shapely.lib.linearrings(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.intc(0))
        return isinstance(shapely.lib.polygons(ring, _NO_HOLES), Polygon)
    except Exception:  # another shapely: the plain constructor serves
        return False


_NO_HOLES = np.empty((0,), dtype=object)
_FAST_POLYGONS = _array_constructors()


def outline_polygon(points: FloatArray) -> Polygon:
    """The polygon of an outline's ``(k, 2)`` points: what ``Polygon(points)`` gives, built
    straight through shapely's array constructors, at about half the cost (a room is planned
    with tens of thousands of trial outlines)."""
    pts = np.asarray(points)
    if _FAST_POLYGONS and pts.dtype == np.float64 and pts.ndim == 2 and pts.shape[1] == 2 and len(pts) >= 3:
        polygon: Polygon = shapely.lib.polygons(shapely.lib.linearrings(pts, np.intc(0)), _NO_HOLES)
        return polygon
    return Polygon(pts)


def convex_hull_2d(points: FloatArray) -> FloatArray:
    """Counter-clockwise convex hull (monotone chain) of 2D points, shape (k, 2), starting at the
    lowest point in (x, y) order; points are compared rounded to 1e-9.

    Plain Python floats on purpose: the hull of a box's few corners is asked for hundreds of
    thousands of times while a room is planned, and numpy's per-call overhead (``unique`` over
    rows) cost more than the hull itself; the arithmetic is the same IEEE doubles either way."""
    pts = sorted(set(map(tuple, np.round(points, 9).tolist())))
    if len(pts) <= 2:
        return np.array(pts, dtype=np.float64).reshape(-1, 2)

    def turn(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and turn(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=np.float64)


def edge_axes(poly: FloatArray) -> FloatArray:
    """Unit outward edge normals of a convex polygon (the candidate separating axes), shape (k, 2).

    Plain Python floats, as :func:`convex_hull_2d`: asked for every piece of every body each time
    a unit settles, on a handful of vertices, where numpy's per-call overhead was four times the
    arithmetic; the same IEEE doubles (``sqrt(x*x + y*y)``, then the quotients) either way."""
    pts = np.asarray(poly, dtype=np.float64).tolist()
    out: list[tuple[float, float]] = []
    for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True):
        nx, ny = y1 - y0, -(x1 - x0)
        length = math.sqrt(nx * nx + ny * ny)
        if length > 1e-12:
            out.append((nx / length, ny / length))
    return np.array(out, dtype=np.float64).reshape(-1, 2)


def sat_overlap(a: FloatArray, b: FloatArray, axes: FloatArray | None = None) -> tuple[float, FloatArray]:
    """Separating-axis test of two convex polygons.

    Returns ``(depth, axis)``: the smallest overlap over all edge normals (negative when the
    polygons are apart: the gap along the best separating axis) and the unit axis along which
    moving ``b`` by ``+depth`` (or ``a`` by ``-depth``) separates them. ``axes`` may carry the
    precomputed edge normals of both polygons (they do not change under translation).
    """
    if axes is None:
        axes = np.concatenate([edge_axes(a), edge_axes(b)]) if len(a) > 2 and len(b) > 2 else np.eye(2)
    pa = a @ axes.T
    pb = b @ axes.T
    amin, amax = pa.min(axis=0), pa.max(axis=0)
    bmin, bmax = pb.min(axis=0), pb.max(axis=0)
    push_pos = amax - bmin  # move b along +axis by this much
    push_neg = bmax - amin  # move b along -axis by this much
    need = np.minimum(push_pos, push_neg)
    k = int(np.argmin(need))
    axis = axes[k] if push_pos[k] <= push_neg[k] else -axes[k]
    return float(need[k]), axis


_INSET_REGIONS: Memo[tuple[bytes, float], Polygon] = Memo(256)
"""Regions shrunk by an inset, by the region's WKB and the inset: a settle asks for the same
anchor's region for every child on every sweep."""


def _inset(region: Polygon, inset: float) -> Polygon:
    """``region`` shrunk by ``inset`` (mitred; shared: never modified); ``region`` itself when
    ``inset`` is not positive.

    The shared region is never *prepared*: GEOS builds a prepared geometry's indexes lazily, on
    its first queries, and shapely runs those queries without the GIL, so two threads asking the
    same prepared region at once (the settles of one unit's variants) corrupt the heap and crash
    the process (GEOS issue 825; ``tests/scene/test_planar_hull.py`` runs it in threads)."""
    if inset <= 0:
        return region
    return _INSET_REGIONS.get((region.wkb, float(inset)), lambda: region.buffer(-inset, join_style="mitre"))


def minimal_containing_shift(
    footprint: FloatArray, region: Polygon, inset: float = 0.002
) -> FloatArray | None:
    """Smallest 2D shift that puts the convex ``footprint`` inside ``region`` (shrunk by ``inset``).

    The feasible shifts are the intersection of the region translated by minus each footprint
    corner; its point nearest the origin is the minimal move. ``None`` when no shift fits (the
    object is larger than its support).
    """
    inner = _inset(region, inset)
    if inner.is_empty:
        return None
    if shapely.contains(inner, Polygon(footprint)):
        return np.zeros(2)
    feasible = None
    for px, py in footprint:
        moved = affinity.translate(inner, -float(px), -float(py))
        feasible = moved if feasible is None else feasible.intersection(moved)
        if feasible.is_empty:
            return None
    assert feasible is not None
    origin = Point(0.0, 0.0)
    if feasible.contains(origin):
        return np.zeros(2)
    nearest = nearest_points(feasible, origin)[0]
    return np.array([nearest.x, nearest.y], dtype=np.float64)

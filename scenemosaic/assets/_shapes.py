"""The procedural furniture library's primitives: convex pieces (boxes, prisms, frustums, low-poly
blobs, rods, vessels) built in a unit frame and mapped onto an axis-aligned target box, and the
helpers every builder shares (legs, drawers, hinge sides, spans). The builders are in
``_furniture.py``, ``_household.py`` and ``_fixtures.py``; ``_procedural.py`` names them."""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
import trimesh

from scenemosaic.assets._articulation import (
    Box6,
    HingeSide,
    PartSpec,
    drawer,
)
from scenemosaic.exceptions import AssetError

__all__ = ["Articulated", "Builder", "FloatArray", "Interval", "Parts"]

FloatArray = npt.NDArray[np.float64]
Parts = list[trimesh.Trimesh]
Builder = Callable[[float, float, float], Parts]

_SECTIONS = 8
"""Sides of prisms and frustums; a multiple of 4 so a round part touches all four sides of its box."""



# --------------------------------------------------------------------------------------------
# primitives: each is built in a unit frame and mapped onto an axis-aligned target box
# --------------------------------------------------------------------------------------------
Interval = tuple[float, float]


def _place(mesh: trimesh.Trimesh, x: Interval, y: Interval, z: Interval) -> trimesh.Trimesh:
    """Map ``mesh``'s bounds exactly onto the box ``x * y * z`` (per-axis scale, then shift)."""
    lo_t = np.array([x[0], y[0], z[0]], dtype=np.float64)
    hi_t = np.array([x[1], y[1], z[1]], dtype=np.float64)
    if np.any(hi_t - lo_t <= 0):
        raise AssetError(f"procedural part with empty box {lo_t.tolist()} .. {hi_t.tolist()}")
    lo, hi = mesh.bounds
    scale = (hi_t - lo_t) / (hi - lo)
    vertices = (np.asarray(mesh.vertices) - lo) * scale + lo_t
    vertices = np.clip(vertices, lo_t, hi_t)  # remove the last ulp of rounding, so parts stay inside
    return trimesh.Trimesh(vertices=vertices, faces=np.asarray(mesh.faces).copy(), process=False)


@functools.cache
def _unit_box() -> trimesh.Trimesh:
    box: trimesh.Trimesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return box


def _ring(radius: float, z: float) -> FloatArray:
    angles = np.arange(_SECTIONS) * (2.0 * np.pi / _SECTIONS)
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles), np.full(_SECTIONS, z)])


@functools.cache
def _unit_profile(radii: tuple[float, ...]) -> trimesh.Trimesh:
    """Convex solid of revolution (few-sided) through rings of the given radii, evenly spaced in z."""
    zs = np.linspace(0.0, 1.0, len(radii))
    points = np.vstack([_ring(r, z) for r, z in zip(radii, zs, strict=True)])
    hull: trimesh.Trimesh = trimesh.convex.convex_hull(points)
    return hull


@functools.cache
def _unit_blob() -> trimesh.Trimesh:
    blob: trimesh.Trimesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    return blob


def _box(x: Interval, y: Interval, z: Interval) -> trimesh.Trimesh:
    return _place(_unit_box(), x, y, z)


def _cyl(x: Interval, y: Interval, z: Interval) -> trimesh.Trimesh:
    return _place(_unit_profile((1.0, 1.0)), x, y, z)


def _frustum(x: Interval, y: Interval, z: Interval, bottom: float, top: float) -> trimesh.Trimesh:
    """A tapered prism; ``bottom``/``top`` are relative radii (the larger one fills the box)."""
    return _place(_unit_profile((bottom, top)), x, y, z)


def _profile(x: Interval, y: Interval, z: Interval, radii: Sequence[float]) -> trimesh.Trimesh:
    return _place(_unit_profile(tuple(radii)), x, y, z)


def _blob(x: Interval, y: Interval, z: Interval) -> trimesh.Trimesh:
    return _place(_unit_blob(), x, y, z)


def _hull(points: Sequence[Sequence[float]]) -> trimesh.Trimesh:
    hull: trimesh.Trimesh = trimesh.convex.convex_hull(np.asarray(points, dtype=np.float64))
    return hull


_FACE = float(np.cos(np.pi / _SECTIONS))
"""Apothem of a unit-circumradius ``_SECTIONS``-gon: ``_rod`` and ``_vessel`` turn a face (not a corner)
to each side of their box, so a lying rod rests on a face and a vessel's wall is flush with the box."""


@functools.cache
def _unit_rod(radii: tuple[float, ...], axis: int, flat: bool) -> trimesh.Trimesh:
    """A solid of revolution along ``axis`` with faces (not corners) at the four sides of its box.

    ``flat`` (for a horizontal axis): every ring is lifted so that its lowest face lies on the same
    plane, which gives a tapered rod lying down a flat, stable underside instead of a rolling edge.
    """
    angles = np.pi / _SECTIONS + np.arange(_SECTIONS) * (2.0 * np.pi / _SECTIONS)
    top = max(radii)
    rings = []
    for r, s in zip(radii, np.linspace(0.0, 1.0, len(radii)), strict=True):
        u, v = r * np.cos(angles), r * np.sin(angles)
        if flat and axis != 2:
            v = v + (top - r) * _FACE
        cols = {
            0: (np.full(_SECTIONS, s), u, v),
            1: (u, np.full(_SECTIONS, s), v),
            2: (u, v, np.full(_SECTIONS, s)),
        }
        rings.append(np.column_stack(cols[axis]))
    hull: trimesh.Trimesh = trimesh.convex.convex_hull(np.vstack(rings))
    return hull


def _rod(
    x: Interval, y: Interval, z: Interval, radii: Sequence[float], *, axis: int = 2, flat: bool = True
) -> trimesh.Trimesh:
    """A few-sided rod/frustum along ``axis`` through rings of relative ``radii`` filling the box."""
    return _place(_unit_rod(tuple(radii), axis, flat), x, y, z)


def _rod_in(spans: Sequence[Interval], radii: Sequence[float], *, axis: int) -> trimesh.Trimesh:
    return _rod(spans[0], spans[1], spans[2], radii, axis=axis)


@functools.cache
def _unit_lump(cut: float) -> trimesh.Trimesh:
    """A low-poly sphere with its bottom cut flat at ``z = -cut``: a rounded lump that rests on a face."""
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    points = np.asarray(sphere.vertices, dtype=np.float64).copy()
    points[:, 2] = np.maximum(points[:, 2], -cut)
    hull: trimesh.Trimesh = trimesh.convex.convex_hull(points)
    return hull


def _lump(x: Interval, y: Interval, z: Interval, *, cut: float = 0.7) -> trimesh.Trimesh:
    return _place(_unit_lump(cut), x, y, z)


def _vessel(x: Interval, y: Interval, z: Interval, *, floor: float, wall: float, bottom: float) -> Parts:
    """An open-top round vessel (bowl, pot): a floor disc and ``_SECTIONS`` convex wall segments.

    The outer wall is flush with the sides of the box at the rim and narrows to ``bottom`` (relative)
    at the foot; ``floor`` and ``wall`` are metres. The inside is hollow.
    """
    cx, cy = 0.5 * (x[0] + x[1]), 0.5 * (y[0] + y[1])
    ax, ay = 0.5 * (x[1] - x[0]), 0.5 * (y[1] - y[0])
    height = z[1] - z[0]
    floor = min(floor, 0.5 * height)
    wall_u = min(wall / min(ax, ay), 0.3 * bottom)
    angles = np.pi / _SECTIONS + np.arange(_SECTIONS + 1) * (2.0 * np.pi / _SECTIONS)
    circ = 1.0 / _FACE  # circumradius of the polygon whose faces touch the box

    def ring(radius: float, zz: float, a: float) -> tuple[float, float, float]:
        return (cx + ax * radius * circ * np.cos(a), cy + ay * radius * circ * np.sin(a), zz)

    parts: Parts = [
        _hull([ring(bottom, zz, a) for a in angles[:-1] for zz in (z[0], z[0] + floor)]),
    ]
    for a0, a1 in itertools.pairwise(angles):
        points = []
        for radius, zz in ((bottom, z[0]), (1.0, z[1])):
            for a in (a0, a1):
                points.append(ring(radius, zz, a))
                points.append(ring(radius - wall_u, zz, a))
        parts.append(_hull(points))
    return parts


def _tub(
    x: Interval, y: Interval, z: Interval, *, floor: float, wall: float, lid: float = 0.0
) -> tuple[Parts, Box6]:
    """A rectangular container: floor, four walls, an optional lid. Returns the parts and the inside."""
    wx = min(wall, 0.2 * (x[1] - x[0]))
    wy = min(wall, 0.2 * (y[1] - y[0]))
    height = z[1] - z[0]
    floor = min(floor, 0.2 * height)
    lid = min(lid, 0.2 * height)
    ix, iy = (x[0] + wx, x[1] - wx), (y[0] + wy, y[1] - wy)
    top = z[1] - lid
    parts = [
        _box(x, y, (z[0], z[0] + floor)),
        _box((x[0], ix[0]), y, (z[0], top)),
        _box((ix[1], x[1]), y, (z[0], top)),
        _box(ix, (y[0], iy[0]), (z[0], top)),
        _box(ix, (iy[1], y[1]), (z[0], top)),
    ]
    if lid > 0:
        parts.append(_box(x, y, (top, z[1])))
    return parts, (ix[0], ix[1], iy[0], iy[1], z[0] + floor, top)


def _cap(size: float, fraction: float, limit: float) -> float:
    """A board/leg thickness: ``fraction`` of ``size`` but at most ``limit`` metres."""
    return min(size * fraction, limit)


def _centered(half: float, fraction: float) -> Interval:
    return (-half * fraction, half * fraction)


def _legs(x: Interval, y: Interval, z: Interval, tx: float, ty: float, *, round_legs: bool = False) -> Parts:
    """Four legs in the corners of the rectangle ``x * y``."""
    make = _cyl if round_legs else _box
    out: Parts = []
    for xs in ((x[0], x[0] + tx), (x[1] - tx, x[1])):
        for ys in ((y[0], y[0] + ty), (y[1] - ty, y[1])):
            out.append(make(xs, ys, z))
    return out


def _split(lo: float, hi: float, n: int, gap: float) -> list[Interval]:
    """``n`` equal intervals over ``[lo, hi]`` separated by ``gap``."""
    gap = min(gap, 0.2 * (hi - lo) / max(n, 1))
    step = (hi - lo - gap * (n - 1)) / n
    return [(lo + i * (step + gap), lo + i * (step + gap) + step) for i in range(n)]


def _box6(mesh: trimesh.Trimesh) -> Box6:
    (x0, y0, z0), (x1, y1, z1) = np.asarray(mesh.bounds, dtype=np.float64)
    return (float(x0), float(x1), float(y0), float(y1), float(z0), float(z1))


Articulated = tuple[Parts, list[Box6], list[PartSpec]]
"""What the builder of a model that opens returns: its pieces, its free compartments (inside its
drawers, behind its doors) and its movable parts."""


def _drawers(
    parts: Parts,
    x: Interval,
    z: Interval,
    front: float,
    back: float,
    inner: Interval,
    rows: int,
    cols: int,
    *,
    handle: float,
    thickness: float,
) -> tuple[list[Box6], list[PartSpec]]:
    """Drawers in a rows x cols grid on the plane ``y = front``, appended to ``parts``.

    Each drawer is four pieces: its front (``y in [front + handle, front + handle + thickness]``),
    a handle standing out to ``front``, a bottom board and a back panel reaching to ``y = back``,
    the box between them within ``inner`` (the carcass's inner width). Rows go bottom to top,
    columns left (-X) to right; drawers are numbered in that order. Returns the inside of each
    drawer (over its bottom, from its front to its back panel, up to the top of its front) and the
    drawers' :class:`PartSpec`.
    """
    insides: list[Box6] = []
    specs: list[PartSpec] = []
    fy = (front + handle, front + handle + thickness)
    for zr in _split(z[0], z[1], rows, 0.01):
        height = zr[1] - zr[0]
        board = min(0.012, 0.1 * height)
        for xr in _split(x[0], x[1], cols, 0.01):
            bx = (max(xr[0], inner[0]) + 0.002, min(xr[1], inner[1]) - 0.002)
            cx, cz = 0.5 * (xr[0] + xr[1]), 0.5 * (zr[0] + zr[1])
            hw, hh = 0.2 * (xr[1] - xr[0]), 0.1 * height
            pieces = [
                _box(xr, fy, zr),
                _box((cx - hw, cx + hw), (front, fy[0]), (cz - hh, cz + hh)),
                _box(bx, (fy[1], back), (zr[0], zr[0] + board)),
                _box(bx, (back - board, back), (zr[0] + board, zr[0] + 0.75 * height)),
            ]
            start = len(parts)
            parts.extend(pieces)
            specs.append(
                drawer(
                    f"drawer_{len(specs)}",
                    range(start, start + 4),
                    start + 1,
                    [_box6(piece) for piece in pieces],
                )
            )
            insides.append((bx[0], bx[1], fy[1], back - board, zr[0] + board, zr[1]))
    return insides, specs


def _hinge_sides(n: int) -> list[HingeSide]:
    """Which edge each of ``n`` doors side by side hangs on, left to right (the hinge-side rule).

    One door hangs on its left (-X) edge, its handle at the right: the common right-handed door.
    Several are hung in pairs meeting in the middle: the left door of a pair on its left edge, the
    right one on its right edge; a last door without a partner hangs on its right (outer) edge.
    """
    if n == 1:
        return ["-x"]
    return ["-x" if i % 2 == 0 and i + 1 < n else "+x" for i in range(n)]




# --------------------------------------------------------------------------------------------
# household objects: small things on surfaces and in containers, kitchen and bathroom fixtures
# --------------------------------------------------------------------------------------------
def _frame(w: float, d: float, h: float) -> list[Interval]:
    return [(-w / 2, w / 2), (-d / 2, d / 2), (0.0, h)]


def _frac(span: Interval, a: float, b: float) -> Interval:
    """The part ``[a, b]`` (fractions) of an interval."""
    size = span[1] - span[0]
    return (span[0] + a * size, span[0] + b * size)


def _narrow(spans: list[Interval], axis: int, fraction: float) -> Interval:
    """A ``fraction`` of the span on ``axis``: centred across, resting on the bottom when vertical."""
    lo, hi = spans[axis]
    if axis == 2:
        return (lo, lo + fraction * (hi - lo))
    mid, half = 0.5 * (lo + hi), 0.5 * fraction * (hi - lo)
    return (mid - half, mid + half)


def _with(spans: list[Interval], **changes: Interval) -> trimesh.Trimesh:
    """A box over ``spans`` with some axes (``a0``, ``a1``, ``a2``) replaced."""
    out = list(spans)
    for key, value in changes.items():
        out[int(key[1])] = value
    return _box(out[0], out[1], out[2])


def _axes(w: float, d: float, h: float) -> tuple[int, int, int]:
    """The long axis (longest of the three), then the wide and the thin one of the other two."""
    size = (w, d, h)
    long = int(np.argmax(size))
    a, b = (i for i in range(3) if i != long)
    wide, thin = (a, b) if size[a] >= size[b] else (b, a)
    return long, wide, thin


def _along(spans: list[Interval], axis: int, part: Interval, **across: Interval) -> list[Interval]:
    out = list(spans)
    out[axis] = _frac(spans[axis], *part)
    for key, value in across.items():
        out[int(key[1])] = value
    return out



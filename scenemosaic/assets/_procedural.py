"""The procedural furniture library: low-poly furniture built from convex primitives.

Every builder fills the box ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]`` exactly
(the union of its parts has those bounds) with the object's **front toward -Y**: a chair's open
side and a wardrobe's doors face -Y, backrests and headboards sit at +Y. Each part is a convex,
watertight primitive (box, few-sided prism or frustum, low-poly blob), so it can serve directly
as a collision geom; part counts stay at or below :data:`MAX_PARTS`.

Sizes come from the caller; builders pick proportions as fractions of the box and cap the
absolute thickness of boards, legs and rails, so any positive size gives a valid model.

Builders of furniture that opens (chests of drawers, cabinets, wardrobes, fridges, microwaves,
washing machines, toilets, boxes) draw each drawer, door and lid as its own pieces and say how it
moves (:class:`~scenemosaic.assets.PartSpec`, read with :func:`procedural_articulation`): the
articulation of a category lives with its builder. The pieces are drawn closed.
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic.assets._articulation import (
    ROOM_DOOR_OPEN_DEG,
    TOILET_LID_OPEN_DEG,
    Box6,
    HingeSide,
    PartSpec,
    drawer,
    drop_door,
    front_door,
    lid,
)
from scenemosaic.exceptions import AssetError
from scenemosaic.scene import normalize_category

__all__ = [
    "MAX_PARTS",
    "ROOM_DOOR_CATEGORIES",
    "ROOM_DOOR_HANDLE_PROUD_M",
    "ROOM_DOOR_JAMB_M",
    "ROOM_DOOR_LEAF_M",
    "SHELF_PITCH",
    "Box6",
    "interior_boards",
    "known_categories",
    "procedural_articulation",
    "procedural_key",
    "procedural_mesh",
    "procedural_parts",
]

log = structlog.get_logger(__name__)

FloatArray = npt.NDArray[np.float64]
Parts = list[trimesh.Trimesh]
Builder = Callable[[float, float, float], Parts]

MAX_PARTS = 32
"""Upper bound on the parts of one procedural model (each part becomes a physics geom). Rigid
models stay within 20; a chest of six drawers, each a front, a handle, a bottom and a back, needs 30."""

_SECTIONS = 8
"""Sides of prisms and frustums; a multiple of 4 so a round part touches all four sides of its box."""

_warned_unknown: set[str] = set()


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
# builders: (w, d, h) -> convex parts filling [-w/2, w/2] x [-d/2, d/2] x [0, h], front -Y
# --------------------------------------------------------------------------------------------
ROOM_DOOR_LEAF_M = 0.04
"""Thickness of a room door's leaf, metres (a hollow-core interior door)."""
ROOM_DOOR_JAMB_M = 0.02
"""Width of each jamb of a room door's frame, metres: the jambs line the hole's sides (never in the
wall itself), the leaf hangs between them."""
ROOM_DOOR_HANDLE_PROUD_M = 0.06
"""How far a room door's lever handle stands proud of each face of the leaf, metres."""
ROOM_DOOR_CATEGORIES: dict[tuple[HingeSide, ...], str] = {
    ("-x",): "room_door",
    ("+x",): "room_door_right",
    ("-x", "+x"): "room_double_door",
}
"""The procedural model of a room's door by the jambs its leaves hang on, seen from the side they
swing to: one leaf on its left (-X) jamb, one on its right (+X), a pair meeting in the middle."""
_ROOM_DOOR_GAP_M = 0.005  # between a leaf's free edge and its jamb (or the other leaf)
_ROOM_DOOR_FLOOR_GAP_M = 0.015  # under the leaf: it clears a rug


def _room_door(w: float, d: float, h: float, *, hinges: tuple[HingeSide, ...]) -> Articulated:
    """A room's door: the two jambs of its frame (what does not move) and one leaf per hinge side
    between them, closed in the plane of the frame; a lever handle on each face of a leaf near its
    free edge, the one on the front (-Y, the side it swings to) the handle a gripper takes. Each
    leaf turns about the front edge on its jamb (:func:`front_door`, up to
    :data:`ROOM_DOOR_OPEN_DEG`). ``w`` is the hole's width, ``d`` the leaf's thickness plus both
    handles."""
    hx = w / 2
    jamb = min(ROOM_DOOR_JAMB_M, 0.05 * w)
    proud = d * ROOM_DOOR_HANDLE_PROUD_M / (ROOM_DOOR_LEAF_M + 2 * ROOM_DOOR_HANDLE_PROUD_M)
    t = d - 2 * proud
    x0, x1 = -hx + jamb, hx - jamb
    parts: Parts = [_box((-hx, x0), (-t / 2, t / 2), (0.0, h)), _box((x1, hx), (-t / 2, t / 2), (0.0, h))]
    gap = min(_ROOM_DOOR_GAP_M, 0.01 * (x1 - x0))
    if len(hinges) == 1:
        spans = [(x0, x1 - gap) if hinges[0] == "-x" else (x0 + gap, x1)]
    else:
        mid = 0.5 * (x0 + x1)
        spans = [(x0, mid - gap / 2), (mid + gap / 2, x1)]
    z = (min(_ROOM_DOOR_FLOOR_GAP_M, 0.01 * h), h - min(_ROOM_DOOR_GAP_M, 0.005 * h))
    zc, zh = min(1.0, 0.5 * h), min(0.015, 0.01 * h)
    specs: list[PartSpec] = []
    for i, (xr, side) in enumerate(zip(spans, hinges, strict=True)):
        free = xr[1] if side == "-x" else xr[0]
        inward = -1.0 if side == "-x" else 1.0  # from the free edge toward the hinge
        length = min(0.12, 0.3 * (xr[1] - xr[0]))
        a = free + inward * min(0.05, 0.1 * (xr[1] - xr[0]))
        hxr = (min(a, a + inward * length), max(a, a + inward * length))
        pieces = [
            _box(xr, (-t / 2, t / 2), z),
            _box(hxr, (-d / 2, -t / 2), (zc - zh, zc + zh)),
            _box(hxr, (t / 2, d / 2), (zc - zh, zc + zh)),
        ]
        start = len(parts)
        parts.extend(pieces)
        boxes = [_box6(p) for p in pieces]
        name = "leaf" if len(hinges) == 1 else f"leaf_{i}"
        specs.append(
            front_door(name, range(start, start + 3), start + 1, boxes, hinge=side, open_deg=ROOM_DOOR_OPEN_DEG)
        )
    return parts, [], specs


def _room_door_left(w: float, d: float, h: float) -> Articulated:
    """A room's door hung on its left (-X) jamb, seen from the side it swings to."""
    return _room_door(w, d, h, hinges=("-x",))


def _room_door_right(w: float, d: float, h: float) -> Articulated:
    """A room's door hung on its right (+X) jamb, seen from the side it swings to."""
    return _room_door(w, d, h, hinges=("+x",))


def _room_double_door(w: float, d: float, h: float) -> Articulated:
    """A room's double door: two leaves, one on each jamb, meeting in the middle."""
    return _room_door(w, d, h, hinges=("-x", "+x"))


def _bed(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    head_t = _cap(d, 0.06, 0.08)
    leg_h, frame_top, mattress_top = 0.15 * h, 0.32 * h, 0.5 * h
    foot_y = (-hy, hy - head_t)
    parts = _legs((-hx, hx), foot_y, (0.0, leg_h), _cap(w, 0.08, 0.08), _cap(d, 0.06, 0.08))
    parts.append(_box((-hx, hx), foot_y, (leg_h, frame_top)))
    parts.append(
        _box((-hx + 0.02 * w, hx - 0.02 * w), (-hy + 0.02 * d, hy - head_t), (frame_top, mattress_top))
    )
    parts.append(_box((-hx, hx), (hy - head_t, hy), (0.0, h)))  # headboard at the back (+Y)
    pillow_y = (hy - head_t - 0.18 * d, hy - head_t - 0.03 * d)
    pillow_z = (mattress_top, mattress_top + 0.08 * h)
    n_pillows = 2 if w > 1.1 else 1
    for xr in _split(-hx + 0.08 * w, hx - 0.08 * w, n_pillows, 0.06 * w):
        parts.append(_blob(xr, pillow_y, pillow_z))
    return parts


def _nightstand_layout(w: float, d: float, h: float) -> Articulated:
    """Hollow bedside chest: two drawers at the front (-Y), each a box that slides out."""
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.02), _cap(d, 0.04, 0.02)
    parts, _, body_z = _hollow_case(
        w, d, h, plinth=0.08 * h, top=_cap(h, 0.06, 0.03), front=handle + front, boards=[]
    )
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    insides, specs = _drawers(
        parts,
        (-hx + 0.05 * w, hx - 0.05 * w),
        (body_z[0] + 0.04 * h, body_z[1] - 0.04 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        2,
        1,
        handle=handle,
        thickness=front,
    )
    return parts, insides, specs


SHELF_PITCH = 0.4
"""Target height (m) of one compartment of a hollow container: a board every 0.35-0.45 m or so."""


def _shelf_centres(z0: float, z1: float, board: float, most: int = 5) -> list[float]:
    """Centres of evenly spaced boards between the free heights ``z0`` and ``z1`` (one per ~0.4 m)."""
    free = z1 - z0
    n = int(np.clip(round(free / SHELF_PITCH) - 1, 0, most))
    if n == 0 or free <= n * board:
        return []
    gap = (free - n * board) / (n + 1)
    return [z0 + i * gap + (i - 0.5) * board for i in range(1, n + 1)]


def _hollow_case(
    w: float,
    d: float,
    h: float,
    *,
    plinth: float,
    top: float,
    front: float,
    boards: Sequence[float] | None = None,
) -> tuple[Parts, list[Box6], Interval]:
    """A hollow carcass open to -Y behind a front band of depth ``front`` (left for doors/drawer fronts).

    Side walls and back from the floor up, an inset plinth, a bottom board on it, a full-size top
    board, and interior boards at ``boards`` (their centre heights; default: one per ~0.4 m of
    inner height). Returns the parts, the free compartments (inside the walls, from the carcass
    front plane to the back, from one board's top to the next one's underside) and the body's z
    (plinth top to top board), where the fronts go.
    """
    hx, hy = w / 2, d / 2
    wall = _cap(w, 0.04, 0.018)
    back = _cap(d, 0.04, 0.012)
    board = _cap(h, 0.03, 0.018)
    y0 = -hy + front
    ceiling = h - top
    ix, iy = (-hx + wall, hx - wall), (y0, hy - back)
    floor = plinth + board
    parts = [
        _box((-hx, -hx + wall), (y0, hy), (0.0, ceiling)),
        _box((hx - wall, hx), (y0, hy), (0.0, ceiling)),
        _box(ix, (hy - back, hy), (0.0, ceiling)),
        _box(ix, (y0 + 0.05 * (iy[1] - y0), iy[1]), (0.0, plinth)),
        _box(ix, iy, (plinth, floor)),
        _box((-hx, hx), (-hy, hy), (ceiling, h)),
    ]
    centres = _shelf_centres(floor, ceiling, board) if boards is None else list(boards)
    levels = [floor]
    for zc in centres:
        lo_z, hi_z = max(zc - board / 2, levels[-1]), min(zc + board / 2, ceiling)
        if hi_z - lo_z <= 0.2 * board or hi_z >= ceiling:
            continue
        parts.append(_box(ix, iy, (lo_z, hi_z)))
        levels += [lo_z, hi_z]
    levels.append(ceiling)
    compartments = [
        (ix[0], ix[1], iy[0], iy[1], levels[i], levels[i + 1])
        for i in range(0, len(levels), 2)
        if levels[i + 1] > levels[i]
    ]
    return parts, compartments, (plinth, ceiling)


def _dresser_layout(w: float, d: float, h: float) -> Articulated:
    """Hollow chest of three rows of drawers (two columns when wider than 0.9 m), each drawer a
    box that slides out; what is in the chest is in its drawers."""
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.02), _cap(d, 0.04, 0.02)
    plinth, top = 0.07 * h, _cap(h, 0.05, 0.03)
    rows, cols = 3, (2 if w > 0.9 else 1)
    parts, _, _ = _hollow_case(w, d, h, plinth=plinth, top=top, front=handle + front, boards=[])
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    insides, specs = _drawers(
        parts,
        (-hx + 0.04 * w, hx - 0.04 * w),
        (plinth + 0.03 * h, h - top - 0.03 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        rows,
        cols,
        handle=handle,
        thickness=front,
    )
    return parts, insides, specs


def _door_count(w: float) -> int:
    """One door up to 0.6 m of width, else pairs of doors about 0.55 m wide each (at most six)."""
    if w <= 0.6:
        return 1
    return int(min(6, 2 * max(1, round(w / 1.1))))


def _doored_layout(w: float, d: float, h: float, *, cornice: float) -> Articulated:
    """Wardrobe/cabinet: hollow carcass with shelves, doors at the front (-Y) hung by the
    hinge-side rule (``_hinge_sides``), a vertical handle near each door's free edge."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.04, 0.025), _cap(d, 0.04, 0.025)
    parts, compartments, body_z = _hollow_case(
        w, d, h, plinth=_cap(h, 0.05, 0.1), top=cornice, front=handle + door
    )
    n_doors = _door_count(w)
    door_z = (body_z[0] + 0.01 * h, body_z[1] - 0.01 * h)
    specs: list[PartSpec] = []
    xrs = _split(-hx + 0.02 * w, hx - 0.02 * w, n_doors, 0.01)
    for i, (xr, side) in enumerate(zip(xrs, _hinge_sides(n_doors), strict=True)):
        # the handle near the door's free edge: the right one for a door hung on its left edge
        edge = xr[1] - 0.1 * (xr[1] - xr[0]) if side == "-x" else xr[0] + 0.1 * (xr[1] - xr[0])
        hw = 0.02 * (xr[1] - xr[0])
        zc, zh = 0.5 * (door_z[0] + door_z[1]), 0.12 * (door_z[1] - door_z[0])
        pieces = [
            _box(xr, (-hy + handle, -hy + handle + door), door_z),
            _box((edge - hw, edge + hw), (-hy, -hy + handle), (zc - zh, zc + zh)),
        ]
        start = len(parts)
        parts.extend(pieces)
        boxes = [_box6(p) for p in pieces]
        specs.append(front_door(f"door_{i}", (start, start + 1), start + 1, boxes, hinge=side))
    return parts, compartments, specs


def _counter_layout(w: float, d: float, h: float) -> Articulated:
    """Kitchen counter: a row of drawers under the top (one over each pair of doors), a board
    under them, and a cupboard below behind doors hung by the hinge-side rule; what is in the
    counter is in its drawers or on the cupboard's floor."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.04, 0.025), _cap(d, 0.04, 0.025)
    top, plinth, board = _cap(h, 0.05, 0.04), _cap(h, 0.05, 0.1), _cap(h, 0.03, 0.018)
    split = h - top - min(0.2 * h, 0.18)
    parts, compartments, body_z = _hollow_case(
        w, d, h, plinth=plinth, top=top, front=handle + door, boards=[split - board / 2]
    )
    n_doors = _door_count(w)
    specs: list[PartSpec] = []
    door_z = (body_z[0] + 0.01 * h, split - 0.01 * h)
    xrs = _split(-hx + 0.02 * w, hx - 0.02 * w, n_doors, 0.01)
    for i, (xr, side) in enumerate(zip(xrs, _hinge_sides(n_doors), strict=True)):
        edge = xr[1] - 0.1 * (xr[1] - xr[0]) if side == "-x" else xr[0] + 0.1 * (xr[1] - xr[0])
        hw = 0.02 * (xr[1] - xr[0])
        zc, zh = door_z[1] - 0.15 * (door_z[1] - door_z[0]), 0.08 * (door_z[1] - door_z[0])
        pieces = [
            _box(xr, (-hy + handle, -hy + handle + door), door_z),
            _box((edge - hw, edge + hw), (-hy, -hy + handle), (zc - zh, zc + zh)),
        ]
        start = len(parts)
        parts.extend(pieces)
        specs.append(
            front_door(f"door_{i}", (start, start + 1), start + 1, [_box6(p) for p in pieces], hinge=side)
        )
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    insides, drawers = _drawers(
        parts,
        (-hx + 0.02 * w, hx - 0.02 * w),
        (split + 0.01 * h, body_z[1] - 0.01 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        1,
        (n_doors + 1) // 2,
        handle=handle,
        thickness=door,
    )
    return parts, [*compartments[:-1], *insides], [*specs, *drawers]


def _wardrobe_layout(w: float, d: float, h: float) -> Articulated:
    return _doored_layout(w, d, h, cornice=_cap(h, 0.04, 0.06))


def _cabinet_layout(w: float, d: float, h: float) -> Articulated:
    return _doored_layout(w, d, h, cornice=_cap(h, 0.05, 0.03))


def _fridge_layout(w: float, d: float, h: float) -> Articulated:
    """Hollow fridge: a freezer door above a larger fridge door, a board behind the split, shelves.
    Both doors hang on their left (-X) edge, their handles at the right."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.05, 0.035), _cap(d, 0.05, 0.04)
    plinth, top = _cap(h, 0.03, 0.04), _cap(h, 0.03, 0.03)
    board = _cap(h, 0.03, 0.018)
    floor, ceiling = plinth + board, h - top
    split = floor + 0.68 * (ceiling - floor)
    boards = [
        *_shelf_centres(floor, split - board / 2, board),
        split,
        *_shelf_centres(split + board / 2, ceiling, board, most=3),
    ]
    parts, compartments, body_z = _hollow_case(
        w, d, h, plinth=plinth, top=top, front=handle + door, boards=boards
    )
    gap = 0.005 * h
    door_x = (-hx + 0.01 * w, hx - 0.01 * w)
    specs: list[PartSpec] = []
    for name, zr in (("door_fridge", (body_z[0], split - gap)), ("door_freezer", (split + gap, body_z[1]))):
        span = zr[1] - zr[0]
        pieces = [
            _box(door_x, (-hy + handle, -hy + handle + door), zr),
            _box((hx - 0.14 * w, hx - 0.1 * w), (-hy, -hy + handle), (zr[0] + 0.2 * span, zr[1] - 0.2 * span)),
        ]
        start = len(parts)
        parts.extend(pieces)
        specs.append(front_door(name, (start, start + 1), start + 1, [_box6(p) for p in pieces], hinge="-x"))
    return parts, compartments, specs


def _table(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.05, 0.04)
    inset_x, inset_y = 0.04 * w, 0.04 * d
    legs = _legs(
        (-hx + inset_x, hx - inset_x),
        (-hy + inset_y, hy - inset_y),
        (0.0, h - top),
        _cap(w, 0.06, 0.06),
        _cap(d, 0.06, 0.06),
    )
    apron_z = (h - top - 0.1 * h, h - top)
    aprons = [
        _box((-hx + inset_x, hx - inset_x), (-hy + inset_y, -hy + inset_y + _cap(d, 0.02, 0.02)), apron_z),
        _box((-hx + inset_x, hx - inset_x), (hy - inset_y - _cap(d, 0.02, 0.02), hy - inset_y), apron_z),
    ]
    return [_box((-hx, hx), (-hy, hy), (h - top, h)), *legs, *aprons]


def _low_table(w: float, d: float, h: float, *, drawer: bool) -> Parts:
    """Coffee/side table: top, four legs, a lower shelf, optionally a drawer at the front."""
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.08, 0.04)
    inset_x, inset_y = 0.03 * w, 0.03 * d
    leg_x, leg_y = _cap(w, 0.08, 0.05), _cap(d, 0.08, 0.05)
    parts = [_box((-hx, hx), (-hy, hy), (h - top, h))]
    parts += _legs((-hx + inset_x, hx - inset_x), (-hy + inset_y, hy - inset_y), (0.0, h - top), leg_x, leg_y)
    shelf_z = (0.15 * h, 0.15 * h + _cap(h, 0.05, 0.025))
    parts.append(_box((-hx + inset_x, hx - inset_x), (-hy + inset_y, hy - inset_y), shelf_z))
    if drawer:
        dz = (h - top - 0.2 * h, h - top)
        parts.append(_box((-hx + inset_x + leg_x, hx - inset_x - leg_x), (-hy + inset_y, hy - inset_y), dz))
    return parts


def _coffee_table(w: float, d: float, h: float) -> Parts:
    return _low_table(w, d, h, drawer=False)


def _side_table(w: float, d: float, h: float) -> Articulated:
    """Side table: a coffee table's top, legs and lower shelf, and a drawer under the top that
    slides out of the front (-Y) between the front legs."""
    parts = _low_table(w, d, h, drawer=False)
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.08, 0.04)
    inset_x, inset_y = 0.03 * w, 0.03 * d
    leg_x = _cap(w, 0.08, 0.05)
    inner = (-hx + inset_x + leg_x, hx - inset_x - leg_x)
    _, specs = _drawers(
        parts,
        inner,
        (h - top - 0.2 * h, h - top - 0.01 * h),
        -hy,
        hy - inset_y,
        inner,
        1,
        1,
        handle=inset_y,
        thickness=_cap(d, 0.04, 0.02),
    )
    return parts, [], specs


def _desk(w: float, d: float, h: float) -> Articulated:
    """Desk: top, a side panel at -X, a hollow pedestal of three drawers at +X, a modesty panel at
    the back (+Y); knee space open to -Y."""
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.05, 0.035)
    panel = _cap(w, 0.04, 0.03)
    under = (0.0, h - top)
    ped_w = min(0.3 * w, 0.45)
    handle, front = _cap(d, 0.03, 0.015), _cap(d, 0.03, 0.02)
    px = (hx - 0.01 * w - ped_w, hx - 0.01 * w)
    py = (-hy + 0.03 * d + handle + front, hy - 0.03 * d)
    wall, back = _cap(ped_w, 0.06, 0.018), _cap(d, 0.04, 0.012)
    inner = (px[0] + wall, px[1] - wall)
    parts = [
        _box((-hx, hx), (-hy, hy), (h - top, h)),
        _box((-hx + 0.01 * w, -hx + 0.01 * w + panel), (-hy + 0.03 * d, hy - 0.03 * d), under),
        _box(
            (-hx + 0.01 * w + panel, px[0]),
            (hy - 0.03 * d - panel, hy - 0.03 * d),
            (0.35 * h, h - top),
        ),
        _box((px[0], inner[0]), py, under),
        _box((inner[1], px[1]), py, under),
        _box(inner, (py[1] - back, py[1]), under),
        _box(inner, (py[0], py[1] - back), (0.0, 0.02 * h)),
    ]
    _, specs = _drawers(
        parts,
        (px[0] + 0.01 * w, hx - 0.02 * w),
        (0.03 * h, h - top - 0.02 * h),
        -hy + 0.03 * d,
        py[1] - back - 0.005,
        inner,
        3,
        1,
        handle=handle,
        thickness=front,
    )
    return parts, [], specs


def _dressing_table(w: float, d: float, h: float) -> Articulated:
    """A small table with a drawer under its top that slides out of the front (-Y), and a mirror
    standing on it at the back (+Y)."""
    hx, hy = w / 2, d / 2
    table_h = 0.55 * h
    top = _cap(h, 0.03, 0.03)
    parts = [_box((-hx, hx), (-hy, hy), (table_h - top, table_h))]
    parts += _legs(
        (-hx + 0.03 * w, hx - 0.03 * w),
        (-hy + 0.03 * d, hy - 0.03 * d),
        (0.0, table_h - top),
        _cap(w, 0.06, 0.04),
        _cap(d, 0.08, 0.04),
    )
    mirror_t = _cap(d, 0.08, 0.03)
    parts.append(_box((-hx + 0.1 * w, hx - 0.1 * w), (hy - mirror_t, hy), (table_h, h)))
    inner = (-hx + 0.15 * w, hx - 0.15 * w)
    _, specs = _drawers(
        parts,
        inner,
        (table_h - top - 0.12 * h, table_h - top - 0.01 * h),
        -hy,
        hy - 0.1 * d,
        inner,
        1,
        1,
        handle=0.03 * d,
        thickness=_cap(d, 0.04, 0.02),
    )
    return parts, [], specs


def _chair(w: float, d: float, h: float) -> Parts:
    """Dining chair: four legs, seat, two back posts and a back panel at +Y; open front at -Y."""
    hx, hy = w / 2, d / 2
    seat_top = 0.5 * h
    seat_t = _cap(h, 0.06, 0.05)
    leg_x, leg_y = _cap(w, 0.1, 0.045), _cap(d, 0.1, 0.045)
    back_t = _cap(d, 0.08, 0.05)
    parts = _legs((-hx, hx), (-hy, hy - back_t), (0.0, seat_top - seat_t), leg_x, leg_y)
    parts.append(_box((-hx, hx), (-hy, hy - back_t), (seat_top - seat_t, seat_top)))
    for xr in ((-hx, -hx + leg_x), (hx - leg_x, hx)):
        parts.append(_box(xr, (hy - back_t, hy), (0.0, h)))  # back legs run up as posts
    parts.append(_box((-hx + leg_x, hx - leg_x), (hy - back_t, hy), (seat_top + 0.3 * (h - seat_top), h)))
    return parts


def _office_chair(w: float, d: float, h: float) -> Parts:
    """Swivel chair: cross base, column, seat, back at +Y on a support, armrests."""
    hx, hy = w / 2, d / 2
    base_h = _cap(h, 0.06, 0.06)
    bar_w, bar_d = _cap(w, 0.1, 0.06), _cap(d, 0.1, 0.06)
    seat_lo, seat_hi = 0.4 * h, 0.48 * h
    back_t = _cap(d, 0.1, 0.06)
    arm_w = _cap(w, 0.1, 0.06)
    parts = [
        _box((-hx, hx), (-bar_d / 2, bar_d / 2), (0.0, base_h)),
        _box((-bar_w / 2, bar_w / 2), (-hy, hy), (0.0, base_h)),
        _cyl(_centered(hx, 0.12), _centered(hy, 0.12), (base_h, seat_lo)),
        _box((-hx + arm_w, hx - arm_w), (-hy + 0.05 * d, hy - back_t - 0.05 * d), (seat_lo, seat_hi)),
        _box(_centered(hx, 0.15), (hy - back_t - 0.05 * d, hy - back_t), (seat_lo, 0.6 * h)),
        _box((-hx + arm_w, hx - arm_w), (hy - back_t, hy), (0.55 * h, h)),
    ]
    arm_y = (-hy + 0.2 * d, hy - back_t - 0.1 * d)
    for xr in ((-hx, -hx + arm_w), (hx - arm_w, hx)):
        mid = 0.5 * (arm_y[0] + arm_y[1])
        parts.append(_box(xr, (mid - 0.05 * d, mid + 0.05 * d), (seat_lo, 0.62 * h)))
        parts.append(_box(xr, arm_y, (0.62 * h, 0.66 * h)))
    return parts


def _upholstered(w: float, d: float, h: float, *, seats: int) -> Parts:
    """Armchair/sofa: short legs, base, seat and back cushions, arms at +-X, back at +Y."""
    hx, hy = w / 2, d / 2
    leg_h, base_top, seat_top = 0.1 * h, 0.38 * h, 0.48 * h
    back_t = _cap(d, 0.18, 0.2)
    arm_w = _cap(w, 0.12, 0.18)
    parts = _legs(
        (-hx + 0.02 * w, hx - 0.02 * w),
        (-hy + 0.02 * d, hy - 0.02 * d),
        (0.0, leg_h),
        _cap(w, 0.05, 0.05),
        _cap(d, 0.05, 0.05),
    )
    parts.append(_box((-hx, hx), (-hy, hy - back_t), (leg_h, base_top)))
    parts.append(_box((-hx, hx), (hy - back_t, hy), (leg_h, 0.8 * h)))
    for xr in ((-hx, -hx + arm_w), (hx - arm_w, hx)):
        parts.append(_box(xr, (-hy, hy - back_t), (base_top, 0.65 * h)))
    cushion_back = _cap(d, 0.15, 0.15)
    for xr in _split(-hx + arm_w, hx - arm_w, seats, 0.01):
        parts.append(_box(xr, (-hy + 0.02 * d, hy - back_t), (base_top, seat_top)))
        parts.append(_box(xr, (hy - back_t - cushion_back, hy - back_t), (seat_top, h)))
    return parts


def _armchair(w: float, d: float, h: float) -> Parts:
    return _upholstered(w, d, h, seats=1)


def _sofa(w: float, d: float, h: float) -> Parts:
    seats = int(np.clip(round((w * 0.76) / 0.6), 1, 4))
    return _upholstered(w, d, h, seats=seats)


def _l_shaped_sofa(w: float, d: float, h: float) -> Parts:
    """Sofa along X with its back at +Y and a chaise on the -X end that reaches forward to -Y."""
    hx, hy = w / 2, d / 2
    leg_h, base_top, seat_top = 0.1 * h, 0.38 * h, 0.48 * h
    back_t = _cap(d, 0.12, 0.2)
    arm_w = _cap(w, 0.06, 0.18)
    main_d = 0.5 * d
    chaise_w = 0.35 * w
    main_y = (hy - main_d, hy - back_t)
    lx, ly = _cap(w, 0.03, 0.05), _cap(d, 0.03, 0.05)
    parts = [
        _box((-hx, -hx + lx), (-hy, -hy + ly), (0.0, leg_h)),
        _box((-hx + chaise_w - lx, -hx + chaise_w), (-hy, -hy + ly), (0.0, leg_h)),
        _box((hx - lx, hx), (hy - main_d, hy - main_d + ly), (0.0, leg_h)),
        _box((hx - lx, hx), (hy - ly, hy), (0.0, leg_h)),
        _box((-hx, -hx + lx), (hy - ly, hy), (0.0, leg_h)),
        _box((-hx, hx), (hy - main_d, hy - back_t), (leg_h, base_top)),
        _box((-hx, -hx + chaise_w), (-hy, hy - main_d), (leg_h, base_top)),
        _box((-hx, hx), (hy - back_t, hy), (leg_h, 0.8 * h)),
        _box((hx - arm_w, hx), main_y, (base_top, 0.65 * h)),
        _box((-hx, -hx + arm_w), (-hy, hy - back_t), (base_top, 0.65 * h)),
        _box((-hx + arm_w, -hx + chaise_w), (-hy + 0.02 * d, hy - main_d), (base_top, seat_top)),
    ]
    seats = int(np.clip(round((w - chaise_w) / 0.7), 1, 3))
    cushion_back = _cap(d, 0.1, 0.15)
    for xr in _split(-hx + arm_w, hx - arm_w, seats + 1, 0.01):
        parts.append(_box(xr, (hy - back_t - cushion_back, hy - back_t), (seat_top, h)))
        parts.append(_box(xr, (main_y[0], main_y[1] - cushion_back), (base_top, seat_top)))
    return parts


def _stool(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    seat_t = _cap(h, 0.08, 0.05)
    parts = [_cyl((-hx, hx), (-hy, hy), (h - seat_t, h))]
    leg_x, leg_y = _cap(w, 0.12, 0.04), _cap(d, 0.12, 0.04)
    legs_x, legs_y = (-0.65 * hx, 0.65 * hx), (-0.65 * hy, 0.65 * hy)
    parts += _legs(legs_x, legs_y, (0.0, h - seat_t), leg_x, leg_y, round_legs=True)
    rung_z = (0.3 * h, 0.3 * h + _cap(h, 0.04, 0.025))
    parts.append(_box(legs_x, (-leg_y / 2, leg_y / 2), rung_z))
    parts.append(_box((-leg_x / 2, leg_x / 2), legs_y, (rung_z[0] + 0.05 * h, rung_z[1] + 0.05 * h)))
    return parts


def _bookshelf_layout(w: float, d: float, h: float) -> tuple[Parts, list[Box6]]:
    """Open shelving: side boards, top and bottom, back panel at +Y, shelves open to -Y."""
    hx, hy = w / 2, d / 2
    board = _cap(min(w, h), 0.05, 0.025)
    back = _cap(d, 0.05, 0.01)
    inner_x, inner_y = (-hx + board, hx - board), (-hy, hy - back)
    parts = [
        _box((-hx, -hx + board), (-hy, hy), (0.0, h)),
        _box((hx - board, hx), (-hy, hy), (0.0, h)),
        _box(inner_x, inner_y, (0.0, board)),
        _box(inner_x, inner_y, (h - board, h)),
        _box(inner_x, (hy - back, hy), (0.0, h)),
    ]
    n_shelves = int(np.clip(round(h / 0.35) - 1, 0, 6))
    step = (h - board) / (n_shelves + 1)
    levels = [board]
    for i in range(1, n_shelves + 1):
        z0 = i * step
        parts.append(_box(inner_x, inner_y, (z0, z0 + board)))
        levels += [z0, z0 + board]
    levels.append(h - board)
    compartments = [(*inner_x, *inner_y, levels[i], levels[i + 1]) for i in range(0, len(levels), 2)]
    return parts, compartments


def _tv_stand_layout(w: float, d: float, h: float) -> Articulated:
    """Low hollow cabinet with a row of drawers at -Y that slide out (one per ~0.6 m of width, at
    most four); what is in the stand is in its drawers."""
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.015), _cap(d, 0.04, 0.02)
    parts, _, body_z = _hollow_case(
        w, d, h, plinth=0.12 * h, top=_cap(h, 0.08, 0.03), front=handle + front, boards=[]
    )
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    cols = int(np.clip(round(w / 0.6), 1, 4))
    insides, specs = _drawers(
        parts,
        (-hx + 0.03 * w, hx - 0.03 * w),
        (body_z[0] + 0.05 * h, body_z[1] - 0.05 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        1,
        cols,
        handle=handle,
        thickness=front,
    )
    return parts, insides, specs


def _tv(w: float, d: float, h: float) -> Parts:
    """Flat screen facing -Y: on a foot and neck when the box is deep, a wall panel when it is thin."""
    hx, hy = w / 2, d / 2
    if d <= 0.12:
        bezel = _cap(d, 0.3, 0.01)
        return [
            _box((-hx + 0.02 * w, hx - 0.02 * w), (-hy + bezel, hy), (0.02 * h, 0.98 * h)),
            _box((-hx, hx), (-hy, -hy + bezel), (0.0, h)),
            _box(_centered(hx, 0.5), (-hy, hy), (0.0, 0.02 * h)),  # a low foot under the full depth
        ]
    screen_t = _cap(d, 0.25, 0.06)
    screen_z = (0.12 * h, h)
    return [
        _box((-hx, hx), (-screen_t / 2, screen_t / 2), screen_z),
        _box(_centered(hx, 0.35), (-hy, hy), (0.0, _cap(h, 0.04, 0.03))),
        _box(
            _centered(hx, 0.08), (-screen_t / 2 + 0.3 * screen_t, screen_t / 2), (0.0, screen_z[0] + 0.2 * h)
        ),
    ]


def _floor_lamp(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _cyl(_centered(hx, 0.6), _centered(hy, 0.6), (0.0, _cap(h, 0.03, 0.03))),
        _cyl(_centered(hx, 0.08), _centered(hy, 0.08), (0.0, 0.78 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.75 * h, h), bottom=1.0, top=0.7),
    ]


def _table_lamp(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _frustum(_centered(hx, 0.6), _centered(hy, 0.6), (0.0, 0.1 * h), bottom=1.0, top=0.7),
        _profile(_centered(hx, 0.35), _centered(hy, 0.35), (0.1 * h, 0.45 * h), (0.7, 1.0, 0.5)),
        _cyl(_centered(hx, 0.08), _centered(hy, 0.08), (0.45 * h, 0.6 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.5 * h, h), bottom=1.0, top=0.65),
    ]


def _ceiling_lamp(w: float, d: float, h: float) -> Parts:
    """Hangs from the top of its box: canopy at z = h, a cord, a shade opening downward to z = 0."""
    hx, hy = w / 2, d / 2
    canopy_t = _cap(h, 0.08, 0.04)
    shade_top = min(0.5 * h, max(0.3 * w, 0.3 * h))
    return [
        _cyl(_centered(hx, 0.3), _centered(hy, 0.3), (h - canopy_t, h)),
        _cyl(_centered(hx, 0.03), _centered(hy, 0.03), (shade_top * 0.9, h - canopy_t)),
        _frustum((-hx, hx), (-hy, hy), (0.0, shade_top), bottom=1.0, top=0.35),
        _blob(_centered(hx, 0.25), _centered(hy, 0.25), (0.05 * shade_top, 0.55 * shade_top)),
    ]


def _plant(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    pot_h = 0.3 * h
    return [
        _frustum(_centered(hx, 0.55), _centered(hy, 0.55), (0.0, pot_h), bottom=0.75, top=1.0),
        _cyl(_centered(hx, 0.06), _centered(hy, 0.06), (pot_h * 0.8, 0.5 * h)),
        _blob((-hx, hx), (-hy, hy), (0.4 * h, h)),
        _blob(_centered(hx, 0.7), _centered(hy, 0.7), (0.3 * h, 0.75 * h)),
    ]


def _rug(w: float, d: float, h: float) -> Parts:
    return [_box((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


def _plain_box(w: float, d: float, h: float) -> Parts:
    return [_box((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


def _mug(w: float, d: float, h: float) -> Parts:
    """Cylindrical body with a three-piece handle on the +X side."""
    hx, hy = w / 2, d / 2
    handle_w = 0.25 * w
    bar = _cap(w, 0.06, 0.008)
    body_x = (-hx, hx - handle_w)
    hy_bar = _centered(hy, 0.15)
    return [
        _cyl(body_x, (-hy, hy), (0.0, h)),
        _box((body_x[1] - 0.1 * w, hx), hy_bar, (0.72 * h, 0.72 * h + _cap(h, 0.1, 0.01))),
        _box((body_x[1] - 0.1 * w, hx), hy_bar, (0.22 * h, 0.22 * h + _cap(h, 0.1, 0.01))),
        _box((hx - bar, hx), hy_bar, (0.22 * h, 0.72 * h + _cap(h, 0.1, 0.01))),
    ]


def _book(w: float, d: float, h: float) -> Parts:
    """Two covers across the thinnest axis, a page block inset on the open sides, a spine."""
    size = (w, d, h)
    lo = [-w / 2, -d / 2, 0.0]
    thin = int(np.argmin(size))
    spine, other = (axis for axis in range(3) if axis != thin)
    cover = 0.12 * size[thin]

    def make(spans: dict[int, Interval]) -> trimesh.Trimesh:
        return _box(spans[0], spans[1], spans[2])

    full = {i: (lo[i], lo[i] + size[i]) for i in range(3)}
    parts = []
    for side in ((lo[thin], lo[thin] + cover), (lo[thin] + size[thin] - cover, lo[thin] + size[thin])):
        parts.append(make({**full, thin: side}))
    pages = {
        thin: (lo[thin] + cover, lo[thin] + size[thin] - cover),
        spine: (lo[spine] + cover, lo[spine] + size[spine] - 0.03 * size[spine]),
        other: (lo[other] + 0.03 * size[other], lo[other] + size[other] - 0.03 * size[other]),
    }
    parts.append(make(pages))
    parts.append(make({thin: pages[thin], spine: (lo[spine], lo[spine] + cover), other: full[other]}))
    return parts


def _vase(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _cyl(_centered(hx, 0.5), _centered(hy, 0.5), (0.0, 0.06 * h)),
        _profile((-hx, hx), (-hy, hy), (0.05 * h, 0.75 * h), (0.55, 1.0, 0.45)),
        _cyl(_centered(hx, 0.4), _centered(hy, 0.4), (0.74 * h, 0.92 * h)),
        _cyl(_centered(hx, 0.55), _centered(hy, 0.55), (0.92 * h, h)),
    ]


def _laptop(w: float, d: float, h: float) -> Articulated:
    """Open laptop: keyboard base toward -Y, screen lid hinged at the back, leaning back to +Y.

    Its box is the open laptop, so it is built open, as far as it opens: the lid's joint (about -X
    through the back edge of the base, a positive angle leaning it back) runs from shut (a negative
    angle, the lid on the keyboard) to 0 (as built), where the lid's weight holds it."""
    hx, hy = w / 2, d / 2
    base_t = _cap(h, 0.1, 0.02)
    lid_t = _cap(d, 0.05, 0.01)
    lean = 0.25 * d
    hinge = hy - lean
    parts = [_box((-hx, hx), (-hy, hinge), (0.0, base_t))]
    parts.append(
        _hull(
            [
                (sx, y, z)
                for sx in (-hx, hx)
                for (y, z) in ((hinge - lid_t, 0.0), (hinge, 0.0), (hy - lid_t, h), (hy, h))
            ]
        )
    )
    parts.append(
        _box(_centered(hx, 0.85), (-hy + 0.45 * d, hinge - 0.05 * d), (base_t, base_t + _cap(h, 0.02, 0.003)))
    )
    # the lid turns about the back edge of the base; shut, it lies on the base (turned by the
    # right angle plus its lean, less a little)
    lean_deg = math.degrees(math.atan2(lean, h))
    screen = _box6(parts[1])
    grip = (*_frac((screen[0], screen[1]), 0.3, 0.7), screen[3] - lid_t, screen[3], 0.9 * h, h)
    spec = lid("lid", (1,), 1, [screen], handle_box=grip)
    shut = math.radians(90.0 + lean_deg - 2.0)
    spec = replace(spec, anchor=(0.0, hinge - lid_t / 2, base_t / 2), limits=(-shut, 0.0))
    return parts, [], [spec]


def _printer(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    out_tray = 0.15 * d
    in_tray = 0.12 * d
    return [
        _box((-hx, hx), (-hy + out_tray, hy - in_tray), (0.0, 0.72 * h)),
        _box((-hx, hx), (-hy + out_tray, hy - in_tray), (0.72 * h, 0.82 * h)),
        _box(_centered(hx, 0.7), (-hy, -hy + out_tray), (0.2 * h, 0.25 * h)),
        _box(_centered(hx, 0.7), (hy - in_tray, hy), (0.5 * h, h)),
        _box(
            (hx - 0.3 * w, hx - 0.05 * w), (-hy + out_tray, -hy + out_tray + 0.15 * d), (0.82 * h, 0.86 * h)
        ),
    ]


def _painting(w: float, d: float, h: float) -> Parts:
    """Framed picture or mirror, thin along Y, picture face toward -Y: four frame bars and a canvas."""
    hx, hy = w / 2, d / 2
    frame = _cap(min(w, h), 0.06, 0.05)
    return [
        _box((-hx, hx), (-hy, hy), (0.0, frame)),
        _box((-hx, hx), (-hy, hy), (h - frame, h)),
        _box((-hx, -hx + frame), (-hy, hy), (frame, h - frame)),
        _box((hx - frame, hx), (-hy, hy), (frame, h - frame)),
        _box((-hx + frame, hx - frame), (-hy + 0.3 * d, hy), (frame, h - frame)),
    ]


def _pillow(w: float, d: float, h: float) -> Parts:
    """One low-poly lump with a flat underside (it rests on a face, not on a vertex)."""
    return [_lump((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h), cut=0.6)]


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


def _fruit(w: float, d: float, h: float) -> Parts:
    """Apple, tomato, orange...: a rounded lump with a flat underside and a short stem."""
    hx, hy = w / 2, d / 2
    return [
        _lump((-hx, hx), (-hy, hy), (0.0, 0.9 * h)),
        _rod(_centered(hx, 0.1), _centered(hy, 0.1), (0.8 * h, h), (1.0, 0.7)),
    ]


def _potato(w: float, d: float, h: float) -> Parts:
    """Potato, lettuce, bread, egg, soap bar: one rounded lump resting on a flat underside."""
    return [_lump((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


def _ball(w: float, d: float, h: float) -> Parts:
    """Sports ball: a low-poly sphere with a small flat patch underneath (it rests, barely rolls)."""
    return [_lump((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h), cut=0.9)]


def _garbage_bag(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _lump((-hx, hx), (-hy, hy), (0.0, 0.85 * h), cut=0.6),
        _rod(_centered(hx, 0.2), _centered(hy, 0.2), (0.8 * h, h), (0.6, 1.0)),
    ]


def _baseball_bat(w: float, d: float, h: float) -> Parts:
    """A bat along its longest axis: barrel, tapering handle, knob. Upright it stands on the barrel;
    lying down its underside is flat, so it does not roll."""
    spans = _frame(w, d, h)
    long, _, _ = _axes(w, d, h)
    if long == 2:
        return [
            _rod(spans[0], spans[1], (0.0, 0.96 * h), (1.0, 0.85, 0.4, 0.3)),
            _rod(_centered(w / 2, 0.45), _centered(d / 2, 0.45), (0.95 * h, h), (1.0, 1.0)),
        ]
    across = 1 - long  # the other horizontal axis
    knob = _along(
        spans, long, (0.0, 0.05), **{f"a{across}": _narrow(spans, across, 0.45), "a2": (0.0, 0.45 * h)}
    )
    body = _along(spans, long, (0.04, 1.0))
    return [
        _rod_in(body, (0.3, 0.35, 0.85, 1.0), axis=long),
        _rod_in(knob, (1.0, 1.0), axis=long),
    ]


def _bottle(w: float, d: float, h: float) -> Parts:
    """Body, shoulder, neck and cap."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.62 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.6 * h, 0.8 * h), bottom=1.0, top=0.4),
        _cyl(_centered(hx, 0.36), _centered(hy, 0.36), (0.78 * h, 0.94 * h)),
        _cyl(_centered(hx, 0.42), _centered(hy, 0.42), (0.92 * h, h)),
    ]


def _jar(w: float, d: float, h: float) -> Parts:
    """Salt/pepper shaker, jar, canister: a round body and a slightly narrower domed lid."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.8 * h)),
        _frustum(_centered(hx, 0.92), _centered(hy, 0.92), (0.78 * h, h), bottom=1.0, top=0.6),
    ]


def _candle(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.93 * h)),
        _cyl(_centered(hx, 0.08), _centered(hy, 0.08), (0.9 * h, h)),
    ]


def _plate(w: float, d: float, h: float) -> Parts:
    """A low dish: a foot ring under a flat, flaring plate."""
    hx, hy = w / 2, d / 2
    return [
        _cyl(_centered(hx, 0.6), _centered(hy, 0.6), (0.0, 0.3 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.25 * h, h), bottom=0.6, top=1.0),
    ]


def _bowl(w: float, d: float, h: float) -> Parts:
    """Open, hollow bowl: a floor disc and flaring wall segments."""
    return _vessel(
        (-w / 2, w / 2),
        (-d / 2, d / 2),
        (0.0, h),
        floor=_cap(h, 0.15, 0.01),
        wall=_cap(min(w, d), 0.06, 0.008),
        bottom=0.6,
    )


def _pot(w: float, d: float, h: float) -> Parts:
    """Cooking pot: a hollow straight-walled vessel with two handles at +-X."""
    hx, hy = w / 2, d / 2
    lug = 0.1 * w
    parts = _vessel(
        (-hx + lug, hx - lug),
        (-hy, hy),
        (0.0, h),
        floor=_cap(h, 0.1, 0.01),
        wall=_cap(min(w, d), 0.05, 0.008),
        bottom=0.95,
    )
    for xr in ((-hx, -hx + lug + 0.02 * w), (hx - lug - 0.02 * w, hx)):
        parts.append(_box(xr, _centered(hy, 0.3), (0.72 * h, 0.86 * h)))
    return parts


def _pan(w: float, d: float, h: float) -> Parts:
    """Frying pan: a shallow hollow vessel and a long handle toward +X."""
    hx, hy = w / 2, d / 2
    handle = float(np.clip(w - d, 0.15 * w, 0.55 * w))
    parts = _vessel(
        (-hx, hx - handle),
        (-hy, hy),
        (0.0, h),
        floor=_cap(h, 0.2, 0.006),
        wall=_cap(min(w, d), 0.04, 0.006),
        bottom=0.85,
    )
    parts.append(_box((hx - handle - 0.03 * w, hx), _centered(hy, 0.12), (0.45 * h, 0.75 * h)))
    return parts


def _knife(w: float, d: float, h: float) -> Parts:
    """Knife, fork: a handle and a thinner blade along the longest axis."""
    spans = _frame(w, d, h)
    long, _, thin = _axes(w, d, h)
    return [
        _box(*_along(spans, long, (0.0, 0.4))),
        _box(*_along(spans, long, (0.38, 1.0), **{f"a{thin}": _narrow(spans, thin, 0.45)})),
    ]


def _spoon(w: float, d: float, h: float) -> Parts:
    """Spoon, ladle: a narrow handle and a rounded bowl at the far end of the longest axis."""
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    handle = _along(
        spans,
        long,
        (0.0, 0.7),
        **{f"a{wide}": _narrow(spans, wide, 0.3), f"a{thin}": _narrow(spans, thin, 0.5)},
    )
    return [_box(*handle), _lump(*_along(spans, long, (0.62, 1.0)))]


def _paddle(w: float, d: float, h: float) -> Parts:
    """Spatula, tennis racket: a handle and a flat head across the thinnest axis."""
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    handle = _along(spans, long, (0.0, 0.45), **{f"a{wide}": _narrow(spans, wide, 0.2)})
    head = _along(spans, long, (0.4, 1.0))
    return [_box(*handle), _rod_in(head, (1.0, 1.0), axis=thin)]


def _pencil(w: float, d: float, h: float) -> Parts:
    """Pencil, pen: an eight-sided body along the longest axis (resting on a face) and a pointed tip."""
    spans = _frame(w, d, h)
    long, _, _ = _axes(w, d, h)
    return [
        _rod_in(_along(spans, long, (0.0, 0.84)), (1.0, 1.0), axis=long),
        _rod_in(_along(spans, long, (0.82, 1.0)), (1.0, 0.25), axis=long),
    ]


def _cell_phone(w: float, d: float, h: float) -> Parts:
    """Phone, remote control, card, sponge: a slab across its thinnest axis with an inset face on top."""
    spans = _frame(w, d, h)
    _, wide, thin = _axes(w, d, h)
    long = 3 - wide - thin
    body = _with(spans, **{f"a{thin}": _frac(spans[thin], 0.0, 0.85)})
    face = _with(
        spans,
        **{
            f"a{thin}": _frac(spans[thin], 0.8, 1.0),
            f"a{wide}": _frac(spans[wide], 0.08, 0.92),
            f"a{long}": _frac(spans[long], 0.06, 0.94),
        },
    )
    return [body, face]


def _disc(w: float, d: float, h: float) -> Parts:
    """CD, coaster, burner: a flat eight-sided disc across the thinnest axis."""
    spans = _frame(w, d, h)
    _, _, thin = _axes(w, d, h)
    return [_rod_in(spans, (1.0, 1.0), axis=thin)]


def _watch(w: float, d: float, h: float) -> Parts:
    """A wrist watch lying down: a strap slab along the longest horizontal axis and a round face."""
    hx, hy = w / 2, d / 2
    strap_x, strap_y = ((-hx, hx), _centered(hy, 0.55)) if w >= d else (_centered(hx, 0.55), (-hy, hy))
    side = min(w, d)
    return [
        _box(strap_x, strap_y, (0.0, 0.35 * h)),
        _cyl((-side / 2, side / 2), (-side / 2, side / 2), (0.0, h)),
    ]


def _key_chain(w: float, d: float, h: float) -> Parts:
    """A ring at one end of the longest axis and a key slab beside it."""
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    ring = _along(spans, long, (0.0, 0.35))
    key = _along(
        spans,
        long,
        (0.3, 1.0),
        **{f"a{wide}": _narrow(spans, wide, 0.6), f"a{thin}": _narrow(spans, thin, 0.7)},
    )
    return [_rod_in(ring, (1.0, 1.0), axis=thin), _box(*key)]


def _alarm_clock(w: float, d: float, h: float) -> Parts:
    """A body with its face toward -Y on two feet, a bell button on top."""
    hx, hy = w / 2, d / 2
    foot = 0.08 * h
    return [
        _rod((-hx, hx), (-hy, hy), (foot, 0.9 * h), (1.0, 1.0), axis=1),
        _box((-hx + 0.1 * w, -hx + 0.3 * w), _centered(hy, 0.6), (0.0, foot + 0.05 * h)),
        _box((hx - 0.3 * w, hx - 0.1 * w), _centered(hy, 0.6), (0.0, foot + 0.05 * h)),
        _cyl(_centered(hx, 0.15), _centered(hy, 0.3), (0.85 * h, h)),
    ]


def _dumbbell(w: float, d: float, h: float) -> Parts:
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    if long == 2:
        long, wide, thin = (0, 1, 2) if w >= d else (1, 0, 2)
    bar = _along(
        spans,
        long,
        (0.2, 0.8),
        **{f"a{wide}": _narrow(spans, wide, 0.3), f"a{thin}": _narrow(spans, thin, 0.3)},
    )
    bar[2] = _frac(spans[2], 0.35, 0.65)
    return [
        _rod_in(_along(spans, long, (0.0, 0.25)), (1.0, 1.0), axis=long),
        _box(*bar),
        _rod_in(_along(spans, long, (0.75, 1.0)), (1.0, 1.0), axis=long),
    ]


def _toilet(w: float, d: float, h: float) -> Articulated:
    """Bowl toward -Y on a pedestal, cistern at the back (+Y), a lid over the bowl hinged at its
    back edge just before the cistern."""
    hx, hy = w / 2, d / 2
    tank_d = _cap(d, 0.25, 0.22)
    seat = 0.42 * h
    bowl_y = (-hy, hy - tank_d + 0.02 * d)
    lid_piece = _cyl(
        (-hx + 0.03 * w, hx - 0.03 * w), (-hy, hy - tank_d - 0.01 * d), (seat, seat + _cap(h, 0.04, 0.035))
    )
    parts = [
        _frustum(_centered(hx, 0.7), (-hy + 0.2 * d, hy - tank_d), (0.0, 0.25 * h), bottom=1.0, top=0.8),
        _profile((-hx + 0.04 * w, hx - 0.04 * w), bowl_y, (0.2 * h, seat), (0.55, 0.9, 1.0)),
        lid_piece,
        _box((-hx, hx), (hy - tank_d, hy), (0.4 * h, h)),
        _box(_centered(hx, 0.6), (hy - tank_d - 0.03 * d, hy), (0.2 * h, 0.42 * h)),
    ]
    box = _box6(lid_piece)
    grip = (*_frac((box[0], box[1]), 0.35, 0.65), box[2], box[2] + 0.04, box[4], box[5])
    return parts, [], [lid("lid", (2,), 2, [box], handle_box=grip, open_deg=TOILET_LID_OPEN_DEG)]


def _toilet_paper(w: float, d: float, h: float) -> Parts:
    """A roll standing on its end, with its cardboard core showing at the top."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.97 * h)),
        _cyl(_centered(hx, 0.4), _centered(hy, 0.4), (0.5 * h, h)),
    ]


def _paper_towel_roll(w: float, d: float, h: float) -> Parts:
    """A roll on a holder: base disc, the roll, a pole knob on top."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.05 * h)),
        _cyl(_centered(hx, 0.92), _centered(hy, 0.92), (0.04 * h, 0.94 * h)),
        _cyl(_centered(hx, 0.25), _centered(hy, 0.25), (0.9 * h, h)),
    ]


def _plunger(w: float, d: float, h: float) -> Parts:
    """Plunger, broom, mop, toilet brush: a wide foot on the floor and a handle."""
    hx, hy = w / 2, d / 2
    return [
        _frustum((-hx, hx), (-hy, hy), (0.0, 0.2 * h), bottom=1.0, top=0.55),
        _cyl(_centered(hx, 0.18), _centered(hy, 0.18), (0.15 * h, h)),
    ]


def _garbage_can_layout(w: float, d: float, h: float) -> tuple[Parts, list[Box6]]:
    """Open-top bin (garbage can, basket): a floor and four walls, hollow."""
    parts, inside = _tub(
        _frame(w, d, h)[0],
        _frame(w, d, h)[1],
        (0.0, h),
        floor=_cap(h, 0.05, 0.02),
        wall=_cap(min(w, d), 0.05, 0.015),
    )
    return parts, [inside]


def _box_layout(w: float, d: float, h: float) -> Articulated:
    """A closed box: floor, four walls and a lid hinged at its back edge, hollow inside."""
    wall = _cap(min(w, d), 0.05, 0.01)
    parts, inside = _tub(
        (-w / 2, w / 2),
        (-d / 2, d / 2),
        (0.0, h),
        floor=_cap(h, 0.05, 0.01),
        wall=wall,
        lid=_cap(h, 0.05, 0.01),
    )
    box = _box6(parts[-1])
    grip = (*_frac((box[0], box[1]), 0.3, 0.7), box[2], box[2] + min(0.03, 0.2 * d), box[4], box[5])
    k = len(parts) - 1
    return parts, [inside], [lid("lid", (k,), k, [box], handle_box=grip)]


def _sink(w: float, d: float, h: float) -> Parts:
    """Pedestal sink: a column and an open basin on top (a low box is the basin alone)."""
    hx, hy = w / 2, d / 2
    basin_z = (0.75 * h, h) if h > 0.5 else (0.0, h)
    parts, _ = _tub(
        (-hx, hx), (-hy, hy), basin_z, floor=_cap(h, 0.04, 0.03), wall=_cap(min(w, d), 0.08, 0.04)
    )
    if h > 0.5:
        parts.append(
            _frustum(
                _centered(hx, 0.35),
                (-hy + 0.3 * d, hy - 0.05 * d),
                (0.0, basin_z[0] + 0.01 * h),
                bottom=1.2,
                top=0.8,
            )
        )
    return parts


def _faucet(w: float, d: float, h: float) -> Parts:
    """A base at the back (+Y), a riser, a spout reaching to -Y, two handles at +-X."""
    hx, hy = w / 2, d / 2
    riser = min(0.2 * w, 0.8 * d)
    return [
        _box((-hx, hx), (0.0, hy), (0.0, 0.1 * h)),
        _cyl((-riser / 2, riser / 2), (hy - 0.5 * d, hy - 0.1 * d), (0.0, h)),
        _box(_centered(hx, 0.1), (-hy, hy - 0.3 * d), (0.8 * h, 0.95 * h)),
        _cyl((-hx, -hx + 0.12 * w), (0.1 * d, 0.4 * d), (0.0, 0.45 * h)),
        _cyl((hx - 0.12 * w, hx), (0.1 * d, 0.4 * d), (0.0, 0.45 * h)),
    ]


def _microwave(w: float, d: float, h: float) -> Articulated:
    """Microwave, oven: a body, a door on the left of the front (-Y) hung on its left edge with a
    handle bar at its right, a control panel on the right."""
    hx, hy = w / 2, d / 2
    door = _cap(d, 0.06, 0.03)
    grip = 0.4 * door
    door_x, door_z = (-hx + 0.03 * w, hx - 0.3 * w), (0.06 * h, 0.94 * h)
    parts = [
        _box((-hx, hx), (-hy + door, hy), (0.0, h)),
        _box((hx - 0.27 * w, hx - 0.03 * w), (-hy + 0.4 * door, -hy + door), (0.06 * h, 0.94 * h)),
    ]
    pieces = [
        _box(door_x, (-hy + grip, -hy + door), door_z),
        _box((door_x[1] - 0.06 * w, door_x[1] - 0.03 * w), (-hy, -hy + grip), (0.2 * h, 0.8 * h)),
    ]
    parts.extend(pieces)
    return parts, [], [front_door("door", (2, 3), 3, [_box6(p) for p in pieces], hinge="-x")]


def _washing_machine(w: float, d: float, h: float) -> Articulated:
    """Washing machine, dryer: a body, a round door at the front (-Y) hung on its left edge with a
    grip at its right, a control strip on top."""
    hx, hy = w / 2, d / 2
    door = _cap(d, 0.06, 0.05)
    grip = 0.4 * door
    side = min(0.7 * w, 0.55 * h)
    door_z = (0.3 * h, 0.3 * h + side)
    parts = [
        _box((-hx, hx), (-hy + door, hy), (0.0, h)),
        _box((-hx + 0.05 * w, hx - 0.05 * w), (-hy + 0.5 * door, -hy + door), (0.85 * h, 0.97 * h)),
    ]
    pieces = [
        _rod((-side / 2, side / 2), (-hy + grip, -hy + door), door_z, (1.0, 1.0), axis=1),
        _box(
            (side / 2 - 0.12 * side, side / 2 - 0.04 * side),
            (-hy, -hy + grip),
            (door_z[0] + 0.35 * side, door_z[0] + 0.65 * side),
        ),
    ]
    parts.extend(pieces)
    return parts, [], [front_door("door", (2, 3), 3, [_box6(p) for p in pieces], hinge="-x")]


def _drop_door_appliance(w: float, d: float, h: float, *, door_top: float) -> Articulated:
    """A body, a door over the front (-Y) up to ``door_top`` (a fraction of the height) hinged
    along its bottom edge with a handle bar across its top, a control panel above it."""
    hx, hy = w / 2, d / 2
    door = _cap(d, 0.06, 0.04)
    grip = 0.4 * door
    door_x, door_z = (-hx + 0.02 * w, hx - 0.02 * w), (0.04 * h, door_top * h)
    tall = door_z[1] - door_z[0]
    parts = [
        _box((-hx, hx), (-hy + door, hy), (0.0, h)),
        _box(door_x, (-hy + 0.4 * door, -hy + door), (door_z[1] + 0.01 * h, 0.98 * h)),
    ]
    bar = (door_z[1] - 0.12 * tall, door_z[1] - 0.06 * tall)
    pieces = [
        _box(door_x, (-hy + grip, -hy + door), door_z),
        _box((door_x[0] + 0.15 * w, door_x[1] - 0.15 * w), (-hy, -hy + grip), bar),
    ]
    parts.extend(pieces)
    return parts, [], [drop_door("door", (2, 3), 3, [_box6(p) for p in pieces])]


def _oven(w: float, d: float, h: float) -> Articulated:
    """Oven, stove: a drop-down door over the lower three quarters of the front, controls above."""
    return _drop_door_appliance(w, d, h, door_top=0.78)


def _dishwasher(w: float, d: float, h: float) -> Articulated:
    """Dishwasher: a drop-down door over nearly all of the front, a control strip above it."""
    return _drop_door_appliance(w, d, h, door_top=0.9)


def _toaster(w: float, d: float, h: float) -> Parts:
    """A rounded body and a lever on the +X side."""
    hx, hy = w / 2, d / 2
    lever = 0.12 * w
    return [
        _rod((-hx, hx - lever), (-hy, hy), (0.0, h), (1.0, 1.0), axis=0),
        _box((hx - lever - 0.02 * w, hx), _centered(hy, 0.2), (0.45 * h, 0.6 * h)),
    ]


def _coffee_machine(w: float, d: float, h: float) -> Parts:
    """A base, a column at the back (+Y), a head over the front, a carafe standing on the base."""
    hx, hy = w / 2, d / 2
    base = 0.12 * h
    column = (hy - 0.45 * d, hy)
    return [
        _box((-hx, hx), (-hy, hy), (0.0, base)),
        _box((-hx, hx), column, (base, h)),
        _box(_centered(hx, 0.8), (-hy + 0.1 * d, column[0] + 0.01 * d), (0.78 * h, h)),
        _cyl(_centered(hx, 0.5), (-hy + 0.12 * d, column[0]), (base, 0.62 * h)),
    ]


def _kettle(w: float, d: float, h: float) -> Parts:
    """Kettle, watering can: a body, a lid knob, a spout to -X and a handle over the +X side."""
    hx, hy = w / 2, d / 2
    spout, grip = 0.2 * w, 0.14 * w
    body_x = (-hx + spout, hx - grip)
    cx = 0.5 * (body_x[0] + body_x[1])
    knob = 0.1 * (body_x[1] - body_x[0])
    tip = _cap(d, 0.06, 0.015)
    return [
        _frustum(body_x, (-hy, hy), (0.0, 0.85 * h), bottom=1.0, top=0.7),
        _cyl((cx - knob, cx + knob), _centered(hy, 0.1), (0.8 * h, 0.92 * h)),
        _hull(
            [(body_x[0] + 0.1 * w, s * 0.12 * d, z) for s in (-1, 1) for z in (0.15 * h, 0.45 * h)]
            + [(-hx, s * tip, z) for s in (-1, 1) for z in (0.66 * h, 0.76 * h)]
        ),
        _box((hx - 0.06 * w, hx), _centered(hy, 0.12), (0.25 * h, h)),
        _box((cx, hx), _centered(hy, 0.12), (0.92 * h, h)),
    ]


def _teddy_bear(w: float, d: float, h: float) -> Parts:
    """A sitting bear facing -Y: body, head, ears, arms, legs reaching forward; it sits on its body and legs."""
    hx, hy = w / 2, d / 2
    return [
        _lump(_centered(hx, 0.6), (-hy + 0.25 * d, hy), (0.0, 0.62 * h)),
        _lump(_centered(hx, 0.46), (-hy + 0.2 * d, hy - 0.1 * d), (0.55 * h, 0.95 * h)),
        _lump((-hx * 0.46, -hx * 0.2), (-hy + 0.4 * d, hy - 0.3 * d), (0.85 * h, h)),
        _lump((hx * 0.2, hx * 0.46), (-hy + 0.4 * d, hy - 0.3 * d), (0.85 * h, h)),
        _lump((-hx, -hx + 0.3 * w), (-hy + 0.2 * d, hy - 0.2 * d), (0.2 * h, 0.5 * h)),
        _lump((hx - 0.3 * w, hx), (-hy + 0.2 * d, hy - 0.2 * d), (0.2 * h, 0.5 * h)),
        _lump((-hx + 0.15 * w, -0.02 * w), (-hy, hy - 0.35 * d), (0.0, 0.25 * h)),
        _lump((0.02 * w, hx - 0.15 * w), (-hy, hy - 0.35 * d), (0.0, 0.25 * h)),
    ]


def _statue(w: float, d: float, h: float) -> Parts:
    """Statue, figurine, decor piece: a plinth, a rounded body and a head."""
    hx, hy = w / 2, d / 2
    return [
        _box(_centered(hx, 0.85), _centered(hy, 0.85), (0.0, 0.1 * h)),
        _profile((-hx, hx), (-hy, hy), (0.08 * h, 0.75 * h), (0.7, 1.0, 0.55)),
        _lump(_centered(hx, 0.5), _centered(hy, 0.5), (0.7 * h, h)),
    ]


def _towel_holder(w: float, d: float, h: float) -> Parts:
    """Wall bar (towel holder, paper hanger): two brackets at the wall (+Y) and a bar toward -Y."""
    hx, hy = w / 2, d / 2
    post = _cap(w, 0.08, 0.03)
    return [
        _box((-hx, -hx + post), (-hy, hy), (0.0, h)),
        _box((hx - post, hx), (-hy, hy), (0.0, h)),
        _box((-hx, hx), (-hy, -hy + 0.4 * d), (0.3 * h, 0.7 * h)),
    ]


def _vacuum_cleaner(w: float, d: float, h: float) -> Parts:
    """Upright vacuum: a floor head at the front (-Y), a body behind it, a handle up to the top."""
    hx, hy = w / 2, d / 2
    return [
        _box((-hx, hx), (-hy, hy - 0.2 * d), (0.0, 0.12 * h)),
        _box(_centered(hx, 0.6), (-hy + 0.3 * d, hy), (0.05 * h, 0.6 * h)),
        _cyl(_centered(hx, 0.15), (hy - 0.35 * d, hy - 0.15 * d), (0.55 * h, 0.95 * h)),
        _box(_centered(hx, 0.35), (hy - 0.35 * d, hy - 0.1 * d), (0.93 * h, h)),
    ]


def _boots(w: float, d: float, h: float) -> Parts:
    """A pair of boots side by side: a foot toward -Y and a shaft at the back, each."""
    hx, hy = w / 2, d / 2
    parts: Parts = []
    for xr in _split(-hx, hx, 2, 0.05 * w):
        parts.append(_box(xr, (-hy, hy), (0.0, 0.25 * h)))
        parts.append(_box(xr, (0.0, hy), (0.2 * h, h)))
    return parts


Layout = Callable[[float, float, float], tuple[Parts, list[Box6]]]
ArticulatedBuilder = Callable[[float, float, float], Articulated]

# Furniture that opens: the builder also says how each drawer, door and lid moves.
_ARTICULATED: dict[str, ArticulatedBuilder] = {
    "box": _box_layout,
    "cabinet": _cabinet_layout,
    "counter": _counter_layout,
    "desk": _desk,
    "dishwasher": _dishwasher,
    "dresser": _dresser_layout,
    "dressing_table": _dressing_table,
    "fridge": _fridge_layout,
    "laptop": _laptop,
    "microwave": _microwave,
    "nightstand": _nightstand_layout,
    "oven": _oven,
    ROOM_DOOR_CATEGORIES[("-x",)]: _room_door_left,
    ROOM_DOOR_CATEGORIES[("+x",)]: _room_door_right,
    ROOM_DOOR_CATEGORIES[("-x", "+x")]: _room_double_door,
    "side_table": _side_table,
    "toilet": _toilet,
    "tv_stand": _tv_stand_layout,
    "wardrobe": _wardrobe_layout,
    "washing_machine": _washing_machine,
}


def _layout_of(build: ArticulatedBuilder) -> Layout:
    def layout(w: float, d: float, h: float) -> tuple[Parts, list[Box6]]:
        parts, compartments, _ = build(w, d, h)
        return parts, compartments

    layout.__doc__ = build.__doc__
    return layout


_CONTAINERS_THAT_OPEN = ("box", "cabinet", "counter", "dresser", "fridge", "tv_stand", "wardrobe")
"""Articulated models that are also hollow containers (their compartments are ``interior_boards``)."""

# Hollow containers: their builders also say where the free compartments are (``interior_boards``).
_LAYOUTS: dict[str, Layout] = {
    "bookshelf": _bookshelf_layout,
    "garbage_can": _garbage_can_layout,
    **{key: _layout_of(_ARTICULATED[key]) for key in _CONTAINERS_THAT_OPEN},
}


def _parts_only(layout: Layout) -> Builder:
    def build(w: float, d: float, h: float) -> Parts:
        return layout(w, d, h)[0]

    build.__doc__ = layout.__doc__
    return build


_BUILDERS: dict[str, Builder] = {
    "alarm_clock": _alarm_clock,
    "armchair": _armchair,
    "ball": _ball,
    "baseball_bat": _baseball_bat,
    "bed": _bed,
    "book": _book,
    "boots": _boots,
    "bottle": _bottle,
    "bowl": _bowl,
    "candle": _candle,
    "cd": _disc,
    "ceiling_lamp": _ceiling_lamp,
    "cell_phone": _cell_phone,
    "chair": _chair,
    "coffee_machine": _coffee_machine,
    "coffee_table": _coffee_table,
    "dumbbell": _dumbbell,
    "faucet": _faucet,
    "floor_lamp": _floor_lamp,
    "fruit": _fruit,
    "garbage_bag": _garbage_bag,
    "jar": _jar,
    "kettle": _kettle,
    "key_chain": _key_chain,
    "knife": _knife,
    "l_shaped_sofa": _l_shaped_sofa,
    "mug": _mug,
    "office_chair": _office_chair,
    "paddle": _paddle,
    "painting": _painting,
    "pan": _pan,
    "paper_towel_roll": _paper_towel_roll,
    "pencil": _pencil,
    "pillow": _pillow,
    "plant": _plant,
    "plate": _plate,
    "plunger": _plunger,
    "pot": _pot,
    "potato": _potato,
    "printer": _printer,
    "rug": _rug,
    "sink": _sink,
    "sofa": _sofa,
    "spoon": _spoon,
    "statue": _statue,
    "stool": _stool,
    "table": _table,
    "table_lamp": _table_lamp,
    "teddy_bear": _teddy_bear,
    "television": _tv,
    "toaster": _toaster,
    "toilet_paper": _toilet_paper,
    "towel_holder": _towel_holder,
    "vacuum_cleaner": _vacuum_cleaner,
    "vase": _vase,
    "watch": _watch,
    **{key: _parts_only(layout) for key, layout in _LAYOUTS.items()},
    **{key: _parts_only(_layout_of(build)) for key, build in _ARTICULATED.items()},
}

# Builder keys are categories of the scene vocabulary (``scene.normalize_category``), which maps the
# true synonyms (tv -> television, couch -> sofa...) before the lookup. This table only says which
# builder draws a category that has none of its own (a dining chair is drawn as a chair), as
# ``_snake`` and ``normalize_category`` write the category.
_SYNONYMS: dict[str, tuple[str, ...]] = {
    "bed": ("double_bed", "single_bed", "kids_bed", "king_bed", "queen_bed", "bunk_bed", "dog_bed"),
    "bookshelf": ("bookcase", "shelf", "shelving_unit", "shelves", "cart", "kitchen_cart"),
    "cabinet": (
        "wine_cabinet",
        "children_cabinet",
        "sideboard",
        "kitchen_cabinet",
        "safe",
    ),
    "counter": ("countertop", "kitchen_counter", "kitchen_island"),
    "dresser": ("drawer_chest", "chest_of_drawers"),
    "nightstand": ("nightstand_table",),
    "dressing_table": ("vanity", "makeup_table"),
    "tv_stand": ("media_console", "t_v_stand"),
    "table": ("dining_table", "kitchen_table", "round_table"),
    "side_table": ("corner_side_table", "console_table", "round_end_table"),
    "coffee_table": ("tea_table",),
    "desk": ("work_desk",),
    "chair": ("dining_chair", "chinese_chair", "dressing_chair", "side_chair"),
    "office_chair": ("desk_chair", "swivel_chair", "gaming_chair"),
    "armchair": ("lounge_chair", "lazy_sofa", "accent_chair"),
    "sofa": (
        "multi_seat_sofa",
        "loveseat_sofa",
        "loveseat",
        "chaise_longue_sofa",
        "two_seat_sofa",
    ),
    "l_shaped_sofa": ("l_sofa", "sectional_sofa", "corner_sofa"),
    "stool": ("barstool", "bar_stool", "footstool", "foot_stool", "ottoman"),
    "television": ("tv_set", "t_v", "monitor", "desktop", "computer_monitor", "screen"),
    "laptop": ("notebook_computer",),
    "ceiling_lamp": ("pendant_lamp", "pendant_light", "chandelier"),
    "floor_lamp": ("floor_light", "standing_lamp"),
    "table_lamp": ("desk_lamp", "lamp", "bedside_lamp"),
    "plant": ("flower_pot",),
    "rug": ("carpet", "mat", "floor_mat", "towel", "hand_towel", "cloth", "blanket", "bath_mat"),
    "mug": ("cup", "coffee_mug", "teacup"),
    "book": ("notebook", "newspaper", "magazine"),
    "vase": ("flower_vase",),
    "painting": ("picture", "picture_frame", "poster", "mirror", "wall_art", "artwork", "photo_frame"),
    "pillow": ("cushion", "throw_pillow"),
    # a laundry hamper has a lid (AI2-THOR's opens): a closed box hinged at its back edge
    "box": ("cardboard_box", "storage_box", "crate", "tissue_box", "aluminum_foil", "shoe_box", "laundry_hamper", "hamper"),
    # household objects (AI2-THOR / ProcTHOR object types and common names)
    "fruit": ("apple", "tomato", "orange", "lemon", "lime", "peach", "pear", "plum", "pomegranate", "mango"),
    "potato": ("lettuce", "bread", "egg", "onion", "cabbage", "loaf", "soap_bar", "vegetable", "avocado"),
    "ball": ("basket_ball", "basketball", "soccer_ball", "football", "tennis_ball", "baseball", "volleyball"),
    "baseball_bat": ("bat", "cricket_bat", "rolling_pin"),
    "bottle": ("wine_bottle", "soap_bottle", "spray_bottle", "water_bottle", "beer_bottle", "shampoo"),
    "jar": ("salt_shaker", "pepper_shaker", "shaker", "canister", "spice_jar", "glass_jar"),
    "candle": ("candlestick", "tea_light"),
    "plate": ("dish", "saucer", "platter", "stove_burner"),
    "bowl": ("salad_bowl", "mixing_bowl", "fruit_bowl"),
    "pot": ("cooking_pot", "saucepan", "stock_pot"),
    "pan": ("frying_pan", "skillet", "wok"),
    "knife": ("butter_knife", "kitchen_knife", "fork", "table_knife"),
    "spoon": ("ladle", "teaspoon", "tablespoon"),
    "paddle": ("spatula", "tennis_racket", "racket", "hairbrush"),
    "pencil": ("pen", "marker", "crayon", "chopsticks", "toothbrush"),
    "cell_phone": (
        "remote_control",
        "remote",
        "phone",
        "smartphone",
        "mobile_phone",
        "credit_card",
        "card",
        "tablet",
        "calculator",
        "dish_sponge",
        "sponge",
        "keyboard",
    ),
    "cd": ("disc", "dvd", "coaster"),
    "watch": ("wristwatch", "bracelet"),
    "key_chain": ("keys", "key", "keychain"),
    "alarm_clock": ("clock", "table_clock"),
    "toilet_paper": ("toilet_roll", "toilet_paper_roll"),
    "paper_towel_roll": ("paper_towel", "kitchen_roll"),
    "plunger": ("broom", "mop", "scrub_brush", "toilet_brush"),
    "garbage_can": (
        "basket",
        "storage_bin",
        "bin",
        "trash_bin",
        "recycling_bin",
        "wastebasket",
        "waste_basket",
    ),
    "garbage_bag": ("trash_bag", "sack", "bag"),
    "fridge": ("refrigerator", "freezer"),
    "microwave": ("toaster_oven",),
    "oven": ("stove", "range", "cooker", "wall_oven"),
    "washing_machine": ("clothes_dryer", "dryer", "washer", "laundry_machine"),
    "coffee_machine": ("coffee_maker", "espresso_machine"),
    "kettle": ("watering_can", "teapot", "tea_kettle"),
    "teddy_bear": ("stuffed_animal", "plush_toy", "toy"),
    "statue": ("sculpture", "figurine", "room_decor", "table_top_decor", "decoration", "decor", "trophy"),
    "faucet": ("shower_head", "tap"),
    "sink": ("sink_basin", "wash_basin", "basin"),
    "towel_holder": ("hand_towel_holder", "toilet_paper_hanger", "towel_rack", "towel_bar"),
    "boots": ("shoes", "shoe", "sneakers"),
    "dumbbell": ("kettlebell", "weights"),
}
_ALIASES: dict[str, str] = {synonym: key for key, names in _SYNONYMS.items() for synonym in names}


def _snake(label: str) -> str:
    text = label.strip().split("|", 1)[0]  # AI2-THOR object ids look like "Chair|+01.2|..."
    text = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", text)
    text = re.sub(r"(?<=[A-Z])(?=[A-Z][a-z])", "_", text)
    text = re.sub(r"[^0-9a-zA-Z]+", "_", text).strip("_").lower()
    text = re.sub(r"(_\d+)+$", "", text)  # numbered instances: "dining_chair_2"
    return text


def _lookup(name: str) -> str | None:
    if name in _BUILDERS:
        return name
    return _ALIASES.get(name)


def procedural_key(label: str) -> str:
    """Map a label to a builder key of the procedural library.

    The label is first put in the scene vocabulary (:func:`scenemosaic.scene.normalize_category`:
    snake case, instance numbers dropped, synonyms mapped), then looked up among the builders.
    Accepts 3D-FRONT labels (``double_bed``, ``multi_seat_sofa``, ``pendant_lamp`` ...), AI2-THOR
    object types (``ArmChair``, ``HousePlant``, ``TVStand`` ...) and common synonyms, in any case
    or separator style. A label that is not known outright is matched by its trailing words
    (``modern_floor_lamp`` -> ``floor_lamp``) and then without a plural ``s``. A label that matches
    nothing comes back in snake case; :func:`procedural_parts` then builds a plain box for it.
    """
    name = normalize_category(_snake(label)) if _snake(label) else ""
    if not name or name == "object":
        return "box"
    found = _lookup(name)
    if found:
        return found
    tokens = name.split("_")
    for start in range(1, len(tokens)):
        found = _lookup("_".join(tokens[start:]))
        if found:
            return found
    if name.endswith("s"):
        found = _lookup(name[:-1])
        if found:
            return found
    return name


def known_categories() -> list[str]:
    """Builder keys of the procedural library, sorted."""
    return sorted(_BUILDERS)


def _fit_union(parts: Parts, w: float, d: float, h: float) -> Parts:
    """Map the union's bounds onto the requested box (removes float drift; a no-op for exact builders)."""
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    target_lo = np.array([-w / 2, -d / 2, 0.0])
    target_hi = np.array([w / 2, d / 2, h])
    if np.allclose(lo, target_lo, atol=1e-12, rtol=0) and np.allclose(hi, target_hi, atol=1e-12, rtol=0):
        return parts
    scale = (target_hi - target_lo) / (hi - lo)
    out: Parts = []
    for p in parts:
        vertices = np.clip((np.asarray(p.vertices) - lo) * scale + target_lo, target_lo, target_hi)
        out.append(trimesh.Trimesh(vertices=vertices, faces=np.asarray(p.faces), process=False))
    return out


@functools.lru_cache(maxsize=512)
def _build(key: str, w: float, d: float, h: float) -> tuple[trimesh.Trimesh, ...]:
    builder = _BUILDERS.get(key)
    if builder is None:
        if key not in _warned_unknown:
            _warned_unknown.add(key)
            log.warning("unknown_procedural_category", category=key, fallback="box")
        builder = _plain_box
    parts = _fit_union(builder(w, d, h), w, d, h)
    if len(parts) > MAX_PARTS:  # pragma: no cover - guarded by the tests of every builder
        raise AssetError(f"procedural {key!r} has {len(parts)} parts (max {MAX_PARTS})")
    return tuple(parts)


def _check_extents(category: str, extents: Sequence[float]) -> tuple[float, float, float]:
    if len(extents) != 3:
        raise AssetError(f"procedural {category!r}: extents must be 3 numbers, got {list(extents)}")
    w, d, h = (float(v) for v in extents)
    if not all(np.isfinite(v) and v > 0 for v in (w, d, h)):
        raise AssetError(f"procedural {category!r}: extents must be positive and finite, got {[w, d, h]}")
    return w, d, h


def procedural_parts(category: str, extents: tuple[float, float, float]) -> list[trimesh.Trimesh]:
    """Convex, watertight pieces of a procedural model filling the box ``extents`` exactly.

    ``category`` may be any label :func:`procedural_key` understands. The box is
    ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]`` with ``extents = (w, d, h)``; the
    model's front faces -Y. An unknown category gives one box, with a warning logged once per category.
    Returns fresh copies (safe to modify).
    """
    w, d, h = _check_extents(category, extents)
    key = procedural_key(category)
    return [p.copy() for p in _build(key, w, d, h)]


@functools.lru_cache(maxsize=512)
def _articulation(key: str, w: float, d: float, h: float) -> tuple[PartSpec, ...]:
    build = _ARTICULATED.get(key)
    return tuple(build(w, d, h)[2]) if build is not None else ()


def procedural_articulation(category: str, extents: tuple[float, float, float]) -> list[PartSpec]:
    """The parts of a procedural model that open (drawers, doors, lids), as its builder draws them.

    Each :class:`~scenemosaic.assets.PartSpec` names the indices of its pieces in
    :func:`procedural_parts` (same category and extents), its joint (a slide for a drawer, a hinge
    for a door or a lid, with its axis, a point on it and its limits) and its handle, in the
    object frame with the parts closed. Categories that do not open give ``[]``. See
    ``docs/articulation.md`` for the categories and the hinge-side rule.
    """
    w, d, h = _check_extents(category, extents)
    return list(_articulation(procedural_key(category), w, d, h))


@functools.lru_cache(maxsize=512)
def _compartments(key: str, w: float, d: float, h: float) -> tuple[Box6, ...]:
    layout = _LAYOUTS.get(key)
    if layout is None:
        return ()
    parts, compartments = layout(w, d, h)
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    if not (
        np.allclose(lo, [-w / 2, -d / 2, 0.0], atol=1e-9) and np.allclose(hi, [w / 2, d / 2, h], atol=1e-9)
    ):
        raise AssetError(f"procedural {key!r}: container layout does not fill its box")  # pragma: no cover
    out: list[Box6] = []
    for x0, x1, y0, y1, z0, z1 in compartments:
        if x1 > x0 and y1 > y0 and z1 > z0:
            out.append((float(x0), float(x1), float(y0), float(y1), float(z0), float(z1)))
    return tuple(out)


def interior_boards(category: str, extents: tuple[float, float, float]) -> list[Box6]:
    """The free compartments of a hollow procedural container, bottom to top (left to right
    within a row of drawers).

    Each is an axis-aligned box ``(x0, x1, y0, y1, z_bottom, z_top)`` in the object frame (the
    frame of :func:`procedural_parts`: ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]``,
    front toward -Y): inside the side walls, from the inner face of the doors/drawer fronts (or the
    open front of a bookshelf) to the back panel, from the top of one board to the underside of the
    next; in a chest of drawers (dresser), the inside of each drawer, over its bottom, up to the
    top of its front. An item whose box lies inside a compartment, resting on ``z_bottom``,
    touches no part.
    Front-opening containers (cabinet, wardrobe, dresser, tv stand, fridge, bookshelf and what the
    alias table draws with them) have one compartment per board; top-opening ones (garbage can,
    hamper, basket, box) have one, above the floor. Any other category gives ``[]``.
    """
    w, d, h = _check_extents(category, extents)
    return list(_compartments(procedural_key(category), w, d, h))


COMPARTMENT_CLEARANCE_M = 0.005
"""Headroom an item needs under the next board to count as fitting a compartment, metres."""


def compartment_fits(size: tuple[float, float, float], compartment: Box6) -> bool:
    """Whether a box of ``size`` (width, depth, height) fits ``compartment`` (one of
    :func:`interior_boards`), either way round in plan and under the next board."""
    x0, x1, y0, y1, zb, zt = compartment
    w, d = sorted(size[:2], reverse=True)
    a, b = sorted((x1 - x0, y1 - y0), reverse=True)
    return w <= a and d <= b and size[2] + COMPARTMENT_CLEARANCE_M <= zt - zb


def procedural_mesh(category: str, extents: tuple[float, float, float]) -> trimesh.Trimesh:
    """The procedural model as one mesh: the concatenation of :func:`procedural_parts` (a fresh
    copy: safe to modify)."""
    w, d, h = _check_extents(category, extents)
    return _joined(procedural_key(category), w, d, h).copy()


@functools.lru_cache(maxsize=512)
def _joined(key: str, w: float, d: float, h: float) -> trimesh.Trimesh:
    parts = _build(key, w, d, h)
    if len(parts) == 1:
        return parts[0]
    mesh = trimesh.util.concatenate(list(parts))
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh

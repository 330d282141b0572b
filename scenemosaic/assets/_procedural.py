"""The procedural furniture library: low-poly furniture built from convex primitives.

Every builder fills the box ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]`` exactly
(the union of its parts has those bounds) with the object's **front toward -Y**: a chair's open
side and a wardrobe's doors face -Y, backrests and headboards sit at +Y. Each part is a convex,
watertight primitive (box, few-sided prism or frustum, low-poly blob), so it can serve directly
as a collision geom; part counts stay at or below :data:`MAX_PARTS`.

Sizes come from the caller; builders pick proportions as fractions of the box and cap the
absolute thickness of boards, legs and rails, so any positive size gives a valid model.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic.exceptions import AssetError
from scenemosaic.scene import normalize_category

__all__ = [
    "MAX_PARTS",
    "known_categories",
    "procedural_key",
    "procedural_mesh",
    "procedural_parts",
]

log = structlog.get_logger(__name__)

FloatArray = npt.NDArray[np.float64]
Parts = list[trimesh.Trimesh]
Builder = Callable[[float, float, float], Parts]

MAX_PARTS = 20
"""Upper bound on the parts of one procedural model (each part becomes a physics geom)."""

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


def _drawer_fronts(
    x: Interval, z: Interval, front: float, rows: int, cols: int, *, handle: float, thickness: float
) -> Parts:
    """Drawer fronts in a rows x cols grid on the plane ``y = front`` (toward -Y), with handles.

    Fronts occupy ``y in [front + handle, front + handle + thickness]``; handles stick out to ``front``.
    """
    out: Parts = []
    fy = (front + handle, front + handle + thickness)
    for zr in _split(z[0], z[1], rows, 0.01):
        for xr in _split(x[0], x[1], cols, 0.01):
            out.append(_box(xr, fy, zr))
            if handle > 0:
                cx, cz = 0.5 * (xr[0] + xr[1]), 0.5 * (zr[0] + zr[1])
                hw, hh = 0.2 * (xr[1] - xr[0]), 0.1 * (zr[1] - zr[0])
                out.append(_box((cx - hw, cx + hw), (front, front + handle), (cz - hh, cz + hh)))
    return out


# --------------------------------------------------------------------------------------------
# builders: (w, d, h) -> convex parts filling [-w/2, w/2] x [-d/2, d/2] x [0, h], front -Y
# --------------------------------------------------------------------------------------------
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


def _case(w: float, d: float, h: float, *, plinth: float, top: float, front: float) -> tuple[Parts, Interval]:
    """A carcass: plinth (inset), body set back by ``front``, full-size top. Returns parts and the body's z."""
    hx, hy = w / 2, d / 2
    parts = [_box((-hx + 0.02 * w, hx - 0.02 * w), (-hy + front + 0.02 * d, hy - 0.02 * d), (0.0, plinth))]
    body_z = (plinth, h - top)
    parts.append(_box((-hx, hx), (-hy + front, hy), body_z))
    parts.append(_box((-hx, hx), (-hy, hy), (h - top, h)))
    return parts, body_z


def _nightstand(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.02), _cap(d, 0.04, 0.02)
    parts, body_z = _case(w, d, h, plinth=0.08 * h, top=_cap(h, 0.06, 0.03), front=handle + front)
    inset = 0.05 * w
    parts += _drawer_fronts(
        (-hx + inset, hx - inset),
        (body_z[0] + 0.04 * h, body_z[1] - 0.04 * h),
        -hy,
        2,
        1,
        handle=handle,
        thickness=front,
    )
    return parts


def _dresser(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.02), _cap(d, 0.04, 0.02)
    parts, body_z = _case(w, d, h, plinth=0.07 * h, top=_cap(h, 0.05, 0.03), front=handle + front)
    cols = 2 if w > 0.9 else 1
    parts += _drawer_fronts(
        (-hx + 0.04 * w, hx - 0.04 * w),
        (body_z[0] + 0.03 * h, body_z[1] - 0.03 * h),
        -hy,
        3,
        cols,
        handle=handle,
        thickness=front,
    )
    return parts


def _doored(w: float, d: float, h: float, *, cornice: float) -> Parts:
    """Wardrobe/cabinet: carcass with one or two doors at the front (-Y) and vertical handles."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.04, 0.025), _cap(d, 0.04, 0.025)
    parts, body_z = _case(w, d, h, plinth=_cap(h, 0.05, 0.1), top=cornice, front=handle + door)
    n_doors = 2 if w > 0.6 else 1
    door_z = (body_z[0] + 0.01 * h, body_z[1] - 0.01 * h)
    for i, xr in enumerate(_split(-hx + 0.02 * w, hx - 0.02 * w, n_doors, 0.01)):
        parts.append(_box(xr, (-hy + handle, -hy + handle + door), door_z))
        # handles near the meeting edge of the doors (or the free edge of a single door)
        edge = xr[1] - 0.1 * (xr[1] - xr[0]) if (i == 0) else xr[0] + 0.1 * (xr[1] - xr[0])
        hw = 0.02 * (xr[1] - xr[0])
        zc, zh = 0.5 * (door_z[0] + door_z[1]), 0.12 * (door_z[1] - door_z[0])
        parts.append(_box((edge - hw, edge + hw), (-hy, -hy + handle), (zc - zh, zc + zh)))
    return parts


def _wardrobe(w: float, d: float, h: float) -> Parts:
    return _doored(w, d, h, cornice=_cap(h, 0.04, 0.06))


def _cabinet(w: float, d: float, h: float) -> Parts:
    return _doored(w, d, h, cornice=_cap(h, 0.05, 0.03))


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


def _side_table(w: float, d: float, h: float) -> Parts:
    return _low_table(w, d, h, drawer=True)


def _desk(w: float, d: float, h: float) -> Parts:
    """Desk: top, a side panel at -X, a drawer pedestal at +X, a modesty panel at the back (+Y)."""
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.05, 0.035)
    panel = _cap(w, 0.04, 0.03)
    under = (0.0, h - top)
    ped_w = min(0.3 * w, 0.45)
    handle, front = _cap(d, 0.03, 0.015), _cap(d, 0.03, 0.02)
    parts = [
        _box((-hx, hx), (-hy, hy), (h - top, h)),
        _box((-hx + 0.01 * w, -hx + 0.01 * w + panel), (-hy + 0.03 * d, hy - 0.03 * d), under),
        _box((hx - 0.01 * w - ped_w, hx - 0.01 * w), (-hy + 0.03 * d + handle + front, hy - 0.03 * d), under),
        _box(
            (-hx + 0.01 * w + panel, hx - 0.01 * w - ped_w),
            (hy - 0.03 * d - panel, hy - 0.03 * d),
            (0.35 * h, h - top),
        ),
    ]
    parts += _drawer_fronts(
        (hx - 0.01 * w - ped_w + 0.01 * w, hx - 0.02 * w),
        (0.03 * h, h - top - 0.02 * h),
        -hy + 0.03 * d,
        3,
        1,
        handle=handle,
        thickness=front,
    )
    return parts


def _dressing_table(w: float, d: float, h: float) -> Parts:
    """A small table with a drawer and a mirror standing on it at the back (+Y)."""
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
    parts.append(
        _box(
            (-hx + 0.15 * w, hx - 0.15 * w),
            (-hy + 0.03 * d, hy - 0.1 * d),
            (table_h - top - 0.12 * h, table_h - top),
        )
    )
    mirror_t = _cap(d, 0.08, 0.03)
    parts.append(_box((-hx + 0.1 * w, hx - 0.1 * w), (hy - mirror_t, hy), (table_h, h)))
    return parts


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


def _bookshelf(w: float, d: float, h: float) -> Parts:
    """Open shelving: side boards, top and bottom, back panel at +Y, shelves open to -Y."""
    hx, hy = w / 2, d / 2
    board = _cap(min(w, h), 0.05, 0.025)
    back = _cap(d, 0.05, 0.01)
    inner_x = (-hx + board, hx - board)
    parts = [
        _box((-hx, -hx + board), (-hy, hy), (0.0, h)),
        _box((hx - board, hx), (-hy, hy), (0.0, h)),
        _box(inner_x, (-hy, hy - back), (0.0, board)),
        _box(inner_x, (-hy, hy - back), (h - board, h)),
        _box(inner_x, (hy - back, hy), (0.0, h)),
    ]
    n_shelves = int(np.clip(round(h / 0.35) - 1, 0, 6))
    step = (h - board) / (n_shelves + 1)
    for i in range(1, n_shelves + 1):
        z0 = i * step
        parts.append(_box(inner_x, (-hy, hy - back), (z0, z0 + board)))
    return parts


def _tv_stand(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.015), _cap(d, 0.04, 0.02)
    parts, body_z = _case(w, d, h, plinth=0.12 * h, top=_cap(h, 0.08, 0.03), front=handle + front)
    cols = int(np.clip(round(w / 0.6), 1, 4))
    parts += _drawer_fronts(
        (-hx + 0.03 * w, hx - 0.03 * w),
        (body_z[0] + 0.05 * h, body_z[1] - 0.05 * h),
        -hy,
        1,
        cols,
        handle=handle,
        thickness=front,
    )
    return parts


def _tv(w: float, d: float, h: float) -> Parts:
    """Flat screen facing -Y: on a foot and neck when the box is deep, a wall panel when it is thin."""
    hx, hy = w / 2, d / 2
    if d <= 0.12:
        bezel = _cap(d, 0.3, 0.01)
        return [
            _box((-hx + 0.02 * w, hx - 0.02 * w), (-hy + bezel, hy), (0.02 * h, 0.98 * h)),
            _box((-hx, hx), (-hy, -hy + bezel), (0.0, h)),
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


def _laptop(w: float, d: float, h: float) -> Parts:
    """Open laptop: keyboard base toward -Y, screen lid hinged at the back, leaning back to +Y."""
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
    return parts


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
    return [_blob((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


_BUILDERS: dict[str, Builder] = {
    "armchair": _armchair,
    "bed": _bed,
    "book": _book,
    "bookshelf": _bookshelf,
    "box": _plain_box,
    "cabinet": _cabinet,
    "ceiling_lamp": _ceiling_lamp,
    "chair": _chair,
    "coffee_table": _coffee_table,
    "desk": _desk,
    "dresser": _dresser,
    "dressing_table": _dressing_table,
    "floor_lamp": _floor_lamp,
    "l_shaped_sofa": _l_shaped_sofa,
    "laptop": _laptop,
    "mug": _mug,
    "nightstand": _nightstand,
    "office_chair": _office_chair,
    "painting": _painting,
    "pillow": _pillow,
    "plant": _plant,
    "printer": _printer,
    "rug": _rug,
    "side_table": _side_table,
    "sofa": _sofa,
    "stool": _stool,
    "table": _table,
    "table_lamp": _table_lamp,
    "television": _tv,
    "tv_stand": _tv_stand,
    "vase": _vase,
    "wardrobe": _wardrobe,
}

# Builder keys are categories of the scene vocabulary (``scene.normalize_category``), which maps the
# true synonyms (tv -> television, couch -> sofa...) before the lookup. This table only says which
# builder draws a category that has none of its own (a dining chair is drawn as a chair), as
# ``_snake`` and ``normalize_category`` write the category.
_SYNONYMS: dict[str, tuple[str, ...]] = {
    "bed": ("double_bed", "single_bed", "kids_bed", "king_bed", "queen_bed", "bunk_bed", "dog_bed"),
    "bookshelf": ("bookcase", "shelf", "shelving_unit", "shelves"),
    "cabinet": (
        "wine_cabinet",
        "children_cabinet",
        "sideboard",
        "countertop",
        "kitchen_cabinet",
        "safe",
    ),
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
    "rug": ("carpet", "mat", "floor_mat"),
    "mug": ("cup", "coffee_mug", "teacup"),
    "book": ("notebook", "newspaper", "magazine"),
    "vase": ("flower_vase",),
    "painting": ("picture", "picture_frame", "poster", "mirror", "wall_art", "artwork", "photo_frame"),
    "pillow": ("cushion", "throw_pillow"),
    "box": ("cardboard_box", "storage_box", "crate"),
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


def procedural_mesh(category: str, extents: tuple[float, float, float]) -> trimesh.Trimesh:
    """The procedural model as one mesh: the concatenation of :func:`procedural_parts`."""
    parts = procedural_parts(category, extents)
    if len(parts) == 1:
        return parts[0]
    mesh = trimesh.util.concatenate(parts)
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh

"""Packing footprints onto a surface: where a crowded table top, shelf board or counter puts its items.

:func:`pack_surface` places the oriented boxes of a support's items inside its surface polygon
without overlap, with a clearance between them:

1. items are taken largest first; fixed items (static, or not to be moved) are obstacles;
2. an item that fits where it stands (after the least shift that brings it inside the surface)
   and overlaps nothing already placed stays there;
3. otherwise it goes to the free position nearest to where it stood, found on a raster of the
   surface (:data:`PACK_CELL_M` cells): the surface less the placed items, grown by the clearance,
   correlated with the item's own raster; an item that may turn also tries a quarter turn;
4. an item with no free position is returned as unplaced (the caller re-parents it or reports it).

The structuring agents ask it whether a surface can take its items (capacity), and physics uses
it to lay them out before settling, so both agree on what fits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from shapely import affinity, contains
from shapely.geometry import Polygon

from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._planar import minimal_containing_shift

__all__ = ["PACK_CELL_M", "PACK_CLEARANCE_M", "PACK_EDGE_M", "PackItem", "PackResult", "pack_surface"]

PACK_CELL_M = 0.01
"""Raster cell of the free-space search, metres."""
PACK_CLEARANCE_M = 0.01
"""Gap kept between packed items, metres."""
PACK_EDGE_M = 0.02
"""Margin kept from the surface's edge, metres: an item settling a few millimetres stays on it."""
_MAX_CELLS = 400_000
"""A surface larger than this many cells is searched on a coarser raster."""


@dataclass(frozen=True)
class PackItem:
    """One item on the surface: its id, its footprint's corners (N x 2, in the surface's plane),
    whether it may move and whether it may turn a quarter turn."""

    id: str
    corners: FloatArray
    movable: bool = True
    may_turn: bool = False


@dataclass
class PackResult:
    """Where each item went: a shift of its footprint (and whether it turned 90 degrees about its
    centre), and the items that found no place."""

    shifts: dict[str, FloatArray] = field(default_factory=dict)
    turned: set[str] = field(default_factory=set)
    unplaced: list[str] = field(default_factory=list)
    kept: list[str] = field(default_factory=list)
    """Items that stayed where they stood (after at most the least shift into the surface)."""

    @property
    def fits(self) -> bool:
        """Whether every item found a place."""
        return not self.unplaced

    def footprint(self, item: PackItem) -> FloatArray:
        """Where ``item``'s footprint ended: turned (when it turned) and shifted; as given when unplaced."""
        corners = _turned(item.corners) if item.id in self.turned else item.corners
        shift = self.shifts.get(item.id)
        return corners + shift if shift is not None else corners

    def merge(self, other: PackResult) -> None:
        """Add the outcome of another packing (of other items) to this one."""
        self.shifts.update(other.shifts)
        self.turned |= other.turned
        self.kept += other.kept
        self.unplaced += other.unplaced


def _raster(poly: Polygon, x0: float, y0: float, nx: int, ny: int, cell: float) -> np.ndarray:
    """Cells whose centre lies inside ``poly`` (rows: y, columns: x)."""
    from shapely import contains_xy

    xs = x0 + (np.arange(nx) + 0.5) * cell
    ys = y0 + (np.arange(ny) + 0.5) * cell
    gx, gy = np.meshgrid(xs, ys)
    return np.asarray(contains_xy(poly, gx, gy), dtype=bool)


def _turned(corners: FloatArray) -> FloatArray:
    centre = corners.mean(axis=0)
    rel = corners - centre
    turned: FloatArray = np.stack([-rel[:, 1], rel[:, 0]], axis=1) + centre
    return turned


def pack_surface(
    surface: Polygon,
    items: Sequence[PackItem],
    *,
    clearance: float = PACK_CLEARANCE_M,
    edge: float = PACK_EDGE_M,
    cell: float = PACK_CELL_M,
) -> PackResult:
    """Lay ``items`` out on ``surface`` without overlap (see the module docstring)."""
    result = PackResult()
    inner = surface.buffer(-edge, join_style="mitre")
    if inner.is_empty:
        result.unplaced = [i.id for i in items if i.movable]
        return result
    minx, miny, maxx, maxy = surface.bounds
    while ((maxx - minx) / cell) * ((maxy - miny) / cell) > _MAX_CELLS:
        cell *= 2
    nx, ny = max(1, math.ceil((maxx - minx) / cell)), max(1, math.ceil((maxy - miny) / cell))
    free = _raster(inner.buffer(-0.75 * cell, join_style="mitre"), minx, miny, nx, ny, cell)
    placed: list[Polygon] = []
    grow = clearance + cell  # a cell-wide margin: rasters see centres, footprints have edges

    def block(poly: Polygon) -> None:
        placed.append(poly)
        free[_raster(poly.buffer(grow, join_style="mitre"), minx, miny, nx, ny, cell)] = False

    for item in items:
        if not item.movable:
            block(Polygon(item.corners))
    movers = sorted((i for i in items if i.movable), key=lambda i: -Polygon(i.corners).area)
    for item in movers:
        poly = Polygon(item.corners)
        shift = minimal_containing_shift(item.corners, surface)  # what stands inside stays put
        if shift is not None:
            moved = affinity.translate(poly, float(shift[0]), float(shift[1]))
            # the corner test behind the least shift is exact for a convex surface only (a mattress
            # less its pillows is not): the moved footprint itself must lie on the surface
            on_surface = contains(surface.buffer(1e-6), moved)
            if on_surface and not any(moved.buffer(clearance / 2).intersects(p) for p in placed):
                result.shifts[item.id] = np.asarray(shift, dtype=np.float64)
                result.kept.append(item.id)
                block(moved)
                continue
        best: tuple[float, FloatArray, bool] | None = None
        for turn in (False, True) if item.may_turn else (False,):
            corners = _turned(item.corners) if turn else item.corners
            found = _nearest_free(corners, free, minx, miny, cell, inner)
            if found is not None and (best is None or found[0] < best[0]):
                best = (found[0], found[1], turn)
        if best is None:
            result.unplaced.append(item.id)
            continue
        _, delta, turn = best
        corners = _turned(item.corners) if turn else item.corners
        result.shifts[item.id] = delta
        if turn:
            result.turned.add(item.id)
        block(affinity.translate(Polygon(corners), float(delta[0]), float(delta[1])))
    return result


def _correlate_valid(image: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """For every placement of ``kernel`` fully inside ``image``, the sum of ``image`` under the
    kernel's cells (a "valid" cross-correlation), by FFT with NumPy (scipy.signal's import alone
    costs more than half a second)."""
    ih, iw = image.shape
    kh, kw = kernel.shape
    fh, fw = ih + kh - 1, iw + kw - 1
    spectrum = np.fft.rfft2(image, s=(fh, fw)) * np.fft.rfft2(kernel[::-1, ::-1], s=(fh, fw))
    full = np.fft.irfft2(spectrum, s=(fh, fw))
    out: np.ndarray = full[kh - 1 : ih, kw - 1 : iw]
    return out


def _nearest_free(
    corners: FloatArray, free: np.ndarray, minx: float, miny: float, cell: float, inner: Polygon
) -> tuple[float, FloatArray] | None:
    """The smallest shift that puts the footprint on free cells only (and inside ``inner``)."""
    poly = Polygon(corners)
    bx0, by0, bx1, by1 = poly.bounds
    kw, kh = max(1, math.ceil((bx1 - bx0) / cell)), max(1, math.ceil((by1 - by0) / cell))
    if kw > free.shape[1] or kh > free.shape[0]:
        return None
    kernel = _raster(poly, bx0, by0, kw, kh, cell)
    if not kernel.any():
        kernel[kh // 2, kw // 2] = True
    hits = _correlate_valid((~free).astype(np.float64), kernel.astype(np.float64))
    ok = np.argwhere(hits < 0.5)
    if ok.size == 0:
        return None
    # offset (row j, col i): the kernel's lower-left cell sits on cell (j, i)
    shifts = np.stack([minx + ok[:, 1] * cell - bx0, miny + ok[:, 0] * cell - by0], axis=1)
    order = np.argsort(np.hypot(shifts[:, 0], shifts[:, 1]), kind="stable")
    for k in order[:64]:  # the raster is exact to a cell; confirm with the polygon itself
        moved = affinity.translate(poly, float(shifts[k, 0]), float(shifts[k, 1]))
        if contains(inner, moved):
            return float(np.hypot(*shifts[k])), shifts[k].astype(np.float64)
    return None

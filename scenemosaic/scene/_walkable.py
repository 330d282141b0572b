"""Walkable floor: one raster of free floor that both the NAV metric and the layout critic read.

The floor region is rasterized on a square grid, the footprints of the things standing on it
are drawn in, and the free cells are eroded by a disk of the robot's radius: a cell stays free
when a robot centred there touches nothing. The free cells then split into 4-connected pieces;
:attr:`Walkable.share` is the largest piece over all free cells (1.0: one piece, the whole
floor reachable from anywhere on it).

The constants are the NAV definition the field uses (SceneEval): a 256 x 256 raster over the
floor's bounding box, a robot of 0.2 m radius, objects whose bottom is below 2 m in the way.
``WALK_MIN_SHARE`` is our bar for "one connected floor": the share a layout should keep.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from shapely import contains_xy
from shapely.geometry import Polygon

from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._model import SceneObject

__all__ = [
    "NAV_SLACK",
    "ROBOT_RADIUS",
    "THIN_RATIO",
    "WALK_GRID",
    "WALK_MAX_HEIGHT",
    "WALK_MIN_SHARE",
    "FloorRaster",
    "Walkable",
    "is_thin",
    "kept_floor_share",
    "mask_iou",
]

WALK_GRID = 256
"""Raster cells along the longer side of the floor's bounding box (SceneEval's NAV grid)."""
ROBOT_RADIUS = 0.2
"""Radius of the robot (or person) that must get through, metres (SceneEval's NAV)."""
WALK_MAX_HEIGHT = 2.0
"""Objects whose bottom is at least this high, metres, are walked under (SceneEval's NAV)."""
THIN_RATIO = 0.02
"""An object is *thin* (rug, sheet of paper) when its vertical extent is below this fraction of
its larger planar extent: it is walked over, and left out of collision counting, as the method does."""
WALK_MIN_SHARE = 0.99
"""The share of free floor the largest connected piece should hold for the floor to count as
one piece (the variants' NAV bar; a room whose own layout cannot reach it keeps its own)."""
NAV_SLACK = 0.005
"""How much less connected floor than its base a variant may show: one raster cell's worth of noise."""


def kept_floor_share(base_share: float) -> float:
    """The share of its floor a variant's largest walkable piece must hold, given its base's (a
    room's NAV, or a house's over every room and doorway): :data:`WALK_MIN_SHARE`; where the base
    itself stays below it (its own furniture cuts the floor), the base's less :data:`NAV_SLACK`.
    The one rule of the room plans, the evolution and the composition of rooms and houses alike: a
    variant never cuts off floor its base leaves open. **Choice:** a base above
    :data:`WALK_MIN_SHARE` does not also hold its variants to its own NAV less :data:`NAV_SLACK`
    (0.995 for a base at 1.0): measured, that costs a shipped room its diversity (PhyScene
    LivingDiningRoom-13536's Div-IoU rose to 0.38, over issue 25's bar of 0.35), while every drop seen
    in held-out houses (1.0 -> 0.95, 0.999 -> 0.986, 1.0 -> 0.987) falls below 0.99."""
    return WALK_MIN_SHARE if base_share >= WALK_MIN_SHARE else base_share - NAV_SLACK


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean rasters of one grid (1.0 when both are empty): how
    much two top-down occupancy maps cover the same floor."""
    union = int((a | b).sum())
    return float((a & b).sum()) / union if union else 1.0


def is_thin(obj: SceneObject) -> bool:
    """Vertical extent below ``THIN_RATIO`` of the larger planar extent (rugs, paper)."""
    sx, sy, sz = (float(v) for v in obj.size)
    return sz < THIN_RATIO * max(sx, sy)


_ERODE_BY_DISTANCE_FROM = 4
"""Disk radii (cells) above which :meth:`FloorRaster.walkable` erodes through the distance
transform: a disk's erosion costs its area per cell (16 ms for a 256-cell floor and a 10-cell
robot), the distance transform a few passes (3 ms); below, the disk is the cheaper."""


@dataclass(frozen=True)
class Walkable:
    """The eroded free cells of a floor raster, split into connected pieces."""

    free: np.ndarray
    """Boolean (nx, ny): a robot centred on the cell touches nothing."""
    labels: np.ndarray
    """Integer (nx, ny): 0 for blocked cells, else the piece (1..n) the cell belongs to."""
    sizes: np.ndarray
    """Cells per piece, ``sizes[i]`` for label ``i + 1``."""

    @property
    def total(self) -> int:
        """All free cells."""
        return int(self.sizes.sum())

    @property
    def share(self) -> float:
        """The largest piece over all free cells; 0.0 when nothing is free."""
        total = self.total
        return float(self.sizes.max()) / total if total else 0.0

    @property
    def main(self) -> int:
        """The label of the largest piece (0 when nothing is free)."""
        return int(np.argmax(self.sizes)) + 1 if len(self.sizes) else 0


class FloorRaster:
    """A square-celled raster over a floor region (any polygon, in metres).

    ``cell`` is the side of a cell; by default the region's longer side over :data:`WALK_GRID`.
    Cell centres are ``origin + (i + 0.5) * cell``.
    """

    def __init__(self, region: FloatArray, cell: float | None = None) -> None:
        pts = np.asarray(region, dtype=np.float64)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        ext = hi - lo
        self.cell = float(cell) if cell is not None else float(max(ext)) / WALK_GRID
        if not self.cell > 0:
            raise ValueError("the floor region has no extent")
        self.origin = lo
        self.shape = (max(1, math.ceil(ext[0] / self.cell - 1e-9)), max(1, math.ceil(ext[1] / self.cell - 1e-9)))
        self.xs = lo[0] + (np.arange(self.shape[0]) + 0.5) * self.cell
        self.ys = lo[1] + (np.arange(self.shape[1]) + 0.5) * self.cell
        self.inside = self.mask(pts)

    def mask(self, polygon: FloatArray | Polygon) -> np.ndarray:
        """The cells whose centre lies in ``polygon`` (only its bounding window is tested)."""
        poly = polygon if isinstance(polygon, Polygon) else Polygon(np.asarray(polygon, dtype=np.float64))
        out = np.zeros(self.shape, dtype=bool)
        if poly.is_empty:
            return out
        x0, y0, x1, y1 = poly.bounds
        i0, i1 = np.searchsorted(self.xs, x0), np.searchsorted(self.xs, x1, side="right")
        j0, j1 = np.searchsorted(self.ys, y0), np.searchsorted(self.ys, y1, side="right")
        if i0 >= i1 or j0 >= j1:
            return out
        gx, gy = np.meshgrid(self.xs[i0:i1], self.ys[j0:j1], indexing="ij")
        out[i0:i1, j0:j1] = contains_xy(poly, gx, gy)
        return out

    def blocked(self, footprints: Sequence[FloatArray | Polygon]) -> np.ndarray:
        """The union of the footprints' cells."""
        out = np.zeros(self.shape, dtype=bool)
        for f in footprints:
            out |= self.mask(f)
        return out

    def walkable(self, blocked: np.ndarray, radius: float = ROBOT_RADIUS) -> Walkable:
        """Free floor (inside the region, not ``blocked``) eroded by a disk of ``radius``, in pieces."""
        from scipy import ndimage

        free = self.inside & ~blocked
        r = max(1, round(radius / self.cell))
        if r > _ERODE_BY_DISTANCE_FROM:
            # the same cells as eroding by the disk (no blocked cell, nor one past the border, within r):
            # the exact distance to the nearest such cell, the cells beyond it by a one-cell ring
            free = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1] > r
        else:
            yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
            disk = (xx**2 + yy**2) <= r * r
            free = ndimage.binary_erosion(free, structure=disk, border_value=0)
        labels, n = ndimage.label(free)
        sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:] if n else np.zeros(0, dtype=np.int64)
        return Walkable(free, labels, sizes)

"""A unit's support plane: its frame and the region its children must stay in.

A unit is seen along its gravity axis (the orthographic projection of the method): ``n`` is
"up" (opposite gravity), ``(e1, e2)`` span the support plane. Footprints are convex polygons of
projected hull vertices; ``h = p . n`` is the height above the plane's origin. The convex
geometry itself (hulls, separating axes, containing shifts) is the scene layer's
(``scenemosaic.scene.convex_hull_2d`` and its neighbours).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from scenemosaic.scene import FloatArray, Scene

__all__ = ["UnitFrame", "unit_frame"]


@dataclass(frozen=True)
class UnitFrame:
    """The support plane of a unit: up axis, in-plane axes, support height and allowed region."""

    up: FloatArray
    e1: FloatArray
    e2: FloatArray
    support_h: float | None
    """Height of the support surface along ``up`` (``None`` for object anchors: read from the anchor)."""
    region: Polygon | None
    """Where children's footprints must lie, in (e1, e2) coordinates; ``None`` when unbounded."""

    def uv(self, points: FloatArray) -> FloatArray:
        """Plane coordinates (n, 2) of world points (n, 3)."""
        return np.stack([points @ self.e1, points @ self.e2], axis=1)

    def h(self, points: FloatArray) -> FloatArray:
        """Heights along ``up`` of world points."""
        return points @ self.up

    def lift(self, shift_uv: Sequence[float] | FloatArray) -> FloatArray:
        """World vector of an in-plane shift."""
        return float(shift_uv[0]) * self.e1 + float(shift_uv[1]) * self.e2


_Z = np.array([0.0, 0.0, 1.0])
_X = np.array([1.0, 0.0, 0.0])
_Y = np.array([0.0, 1.0, 0.0])


def unit_frame(
    scene: Scene, anchor_id: str, anchor_kind: str, anchor_footprint: FloatArray | None
) -> UnitFrame:
    """The frame of the unit anchored at ``anchor_id``.

    ``anchor_footprint`` (world XY polygon) is required for object anchors: it is the anchor's
    support surface seen from above.
    """
    room = scene.room
    floor_poly = Polygon(room.floor) if room is not None else None
    if anchor_kind == "floor":
        return UnitFrame(_Z, _X, _Y, 0.0, floor_poly)
    if anchor_kind == "ceiling":
        height = room.ceiling_height if room is not None else 2.8
        return UnitFrame(-_Z, _X, _Y, -height, floor_poly)
    if anchor_kind == "wall":
        if room is None:
            raise KeyError(anchor_id)
        wall = room.wall(anchor_id)
        n2 = wall.inward_normal
        d2 = wall.direction
        up = np.array([n2[0], n2[1], 0.0])
        e1 = np.array([d2[0], d2[1], 0.0])
        start = np.array([wall.start[0], wall.start[1], 0.0])
        u0 = float(start @ e1)
        region = Polygon(
            [(u0, 0.0), (u0 + wall.length, 0.0), (u0 + wall.length, wall.height), (u0, wall.height)]
        )
        return UnitFrame(up, e1, _Z, float(start @ up), region)
    if anchor_footprint is None:
        raise ValueError("an object anchor needs its footprint")
    return UnitFrame(_Z, _X, _Y, None, Polygon(anchor_footprint).convex_hull)

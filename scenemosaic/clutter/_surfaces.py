"""Where a receptacle takes small objects: its top and, for a hollow procedural piece, each
compartment, as flat regions of the world plane with a height and the headroom above.

The top is read from the receptacle's collision pieces (what the physics sees): the pieces' tops
are grouped by height to the centimetre, and the level with the largest area is the surface (a
table's top, a bed's mattress, a chair's seat rather than its back rail), less what rises above it
within reach. The compartments are :func:`scenemosaic.assets.interior_boards` in the world frame,
the boxes the stabilization packs contained items into.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

from scenemosaic.assets import interior_boards
from scenemosaic.physics import ObjectShape
from scenemosaic.scene import Relation, Scene, SceneObject, convex_hull_2d

__all__ = ["MAX_TOP_HEIGHT_M", "MIN_SURFACE_M2", "Surface", "receptacle_surfaces"]

MIN_SURFACE_M2 = 0.04
"""A level smaller than this (a 20 cm square) takes no objects: a rail, an armrest, a lamp's foot."""
MAX_TOP_HEIGHT_M = 1.8
"""A top higher than this above the floor (a wardrobe's) is out of reach and left bare."""
MIN_HEADROOM_M = 0.06
"""A surface with less free height above it than this takes nothing."""
_LEVEL_BAND_M = 0.03
"""Piece tops within this height of a level belong to it (as physics' resting surfaces group them)."""
_ABOVE_REACH_M = 0.6
"""Pieces whose bottom lies within this height above a level cut it (a shelf board over a desk
top); higher ones only limit the headroom."""


@dataclass(frozen=True)
class Surface:
    """One place on or in a receptacle: ``polygon`` in the world XY plane, the resting ``height``
    (world z), the free ``headroom`` above it, whether items stand ``on`` it or lie ``in`` it, the
    compartment's index (``None`` for the top) and ``yaw`` (the receptacle's heading: items in a
    compartment keep it, so their boxes stay square to its walls)."""

    receptacle: str
    placement: Literal["on", "in"]
    polygon: Polygon
    height: float
    headroom: float
    yaw: float
    compartment: int | None = None

    def support_relation(self, child: str) -> Relation:
        """The relation that puts ``child`` here: ``attach`` on a top, ``contain`` in a compartment."""
        return Relation(kind="attach" if self.placement == "on" else "contain", child=child, parent=self.receptacle, source="clutter")

    @property
    def key(self) -> str:
        """A stable name: ``<receptacle>/top`` or ``<receptacle>/in<k>``."""
        return (
            f"{self.receptacle}/top"
            if self.compartment is None
            else f"{self.receptacle}/in{self.compartment}"
        )


def _top(obj: SceneObject, shape: ObjectShape, ceiling: float) -> Surface | None:
    matrix = obj.pose.matrix(with_scale=False)
    pieces = []
    for verts in shape.world_vertices(matrix):
        if len(verts) < 3:
            continue
        hull = convex_hull_2d(verts[:, :2])
        if len(hull) >= 3:
            pieces.append((Polygon(hull), float(verts[:, 2].min()), float(verts[:, 2].max())))
    if not pieces:
        return None
    levels: dict[float, list[Polygon]] = {}
    for poly, _, hi in pieces:
        levels.setdefault(round(hi, 2), []).append(poly)
    best: Surface | None = None
    best_area = 0.0
    for level in sorted(levels):
        if level > MAX_TOP_HEIGHT_M:
            continue
        flat = unary_union([poly for poly, _, hi in pieces if abs(hi - level) <= _LEVEL_BAND_M])
        above = [
            poly for poly, lo, hi in pieces if hi > level + _LEVEL_BAND_M and lo < level + _ABOVE_REACH_M
        ]
        if above:
            flat = flat.difference(unary_union(above))
        if flat.geom_type == "MultiPolygon":
            flat = max(flat.geoms, key=lambda g: g.area)
        if flat.is_empty or flat.geom_type != "Polygon" or flat.area < MIN_SURFACE_M2:
            continue
        over = [lo - level for poly, lo, hi in pieces if lo > level + _LEVEL_BAND_M and poly.intersects(flat)]
        headroom = min([*over, ceiling - level])
        if headroom < MIN_HEADROOM_M:
            continue
        if flat.area > best_area:
            best_area = flat.area
            best = Surface(obj.id, "on", flat, level, headroom, _yaw(obj))
    return best


def _yaw(obj: SceneObject) -> float:
    m = obj.pose.matrix(with_scale=False)
    return float(np.arctan2(m[1, 0], m[0, 0]))


def _compartments(obj: SceneObject) -> list[Surface]:
    if obj.asset.kind != "procedural":
        return []
    size = tuple(float(v) for v in obj.size)
    boards = interior_boards(obj.asset.category or obj.category, (size[0], size[1], size[2]))
    m = obj.pose.matrix(with_scale=False)
    out = []
    for k, (x0, x1, y0, y1, zb, zt) in enumerate(boards):
        rect = np.array([[x0, y0, zb], [x1, y0, zb], [x1, y1, zb], [x0, y1, zb]]) @ m[:3, :3].T + m[:3, 3]
        poly = Polygon(convex_hull_2d(rect[:, :2]))
        if poly.area < MIN_SURFACE_M2 or zt - zb < MIN_HEADROOM_M:
            continue
        out.append(Surface(obj.id, "in", poly, float(rect[0, 2]), float(zt - zb), _yaw(obj), compartment=k))
    return out


def receptacle_surfaces(scene: Scene, receptacle: str, shapes: Mapping[str, ObjectShape]) -> list[Surface]:
    """The top of ``receptacle`` (when one is within reach and wide enough) and its compartments."""
    obj = scene.get(receptacle)
    ceiling = scene.room.ceiling_height if scene.room is not None else 2.8
    top = _top(obj, shapes[receptacle], ceiling)
    return ([top] if top is not None else []) + _compartments(obj)

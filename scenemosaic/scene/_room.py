"""Recover a room from furniture alone, for layouts that carry no floor polygon."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.scene._categories import traits
from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._model import Room, SceneObject

__all__ = [
    "CEILING_LAMP_CATEGORIES",
    "MIN_CEILING_HEIGHT",
    "ROOM_MARGIN",
    "TOP_CLEARANCE",
    "WALL_SNAP_GAP",
    "FootprintItem",
    "dominant_orientation",
    "footprint_items",
    "recover_room",
    "recovered_ceiling",
    "room_rectangle",
]

WALL_SNAP_GAP = 0.02
"""Gap (metres) between furniture that stands against a wall and the wall recovered behind it."""
ROOM_MARGIN = 0.3
"""Metres added on every side of the furniture's bounding rectangle, so wall-side objects do not touch it."""
MIN_CEILING_HEIGHT = 2.6
"""Lowest ceiling a recovered room gets, metres (a common residential ceiling)."""
TOP_CLEARANCE = 0.1
"""Metres kept between the tallest floor-standing object's top and the recovered ceiling."""
CEILING_LAMP_CATEGORIES = frozenset({"pendant_lamp", "ceiling_lamp", "chandelier"})
"""Categories hung from the ceiling: the ceiling is at least as high as their top (no clearance)."""
SNAP_TO_AXES_RAD = math.radians(1.0)
"""A dominant orientation this close to the world axes is snapped to them (radians)."""


@dataclass(frozen=True)
class FootprintItem:
    """What room recovery needs of one object: where it stands, where it faces, how tall it is."""

    points: FloatArray
    """World XY points the room must enclose (the box corners projected on the floor), shape (n, 2)."""
    yaw: float
    """Heading in radians (0 = front along -Y, counter-clockwise)."""
    category: str
    top: float
    """Height of the object's top above the floor, metres."""
    area: float
    """Footprint area, square metres (the weight of the object's vote for the room's heading)."""


def footprint_items(objects: Sequence[SceneObject]) -> list[FootprintItem]:
    """:class:`FootprintItem` of each object (ceiling lamps included, projected onto the floor)."""
    out = []
    for obj in objects:
        corners = obj.corners()
        size = obj.size
        out.append(
            FootprintItem(
                points=corners[:, :2],
                yaw=obj.pose.yaw,
                category=obj.category,
                top=float(corners[:, 2].max()),
                area=float(size[0] * size[1]),
            )
        )
    return out


def dominant_orientation(objects: Sequence[SceneObject] | Sequence[FootprintItem]) -> float:
    """The room's orientation modulo 90 degrees, in radians within [-pi/4, pi/4).

    Each object votes with its yaw times four (so yaws 90 degrees apart agree), weighted by the
    square of its footprint area, so the largest pieces (beds, sofas, tables) decide. The
    circular mean of the votes, divided by four, is the answer; within ``SNAP_TO_AXES_RAD``
    of the axes it is snapped to 0.
    """
    sx = sy = 0.0
    items = [o if isinstance(o, FootprintItem) else footprint_items([o])[0] for o in objects]
    for item in items:
        angle = 4.0 * item.yaw
        sx += item.area**2 * math.cos(angle)
        sy += item.area**2 * math.sin(angle)
    if math.hypot(sx, sy) < 1e-12:
        return 0.0
    theta = math.atan2(sy, sx) / 4.0
    return 0.0 if abs(theta) < SNAP_TO_AXES_RAD else theta


def room_rectangle(
    items: Sequence[FootprintItem],
    yaw: float,
    *,
    margin: float = ROOM_MARGIN,
    snap_gap: float | None = None,
) -> tuple[list[tuple[float, float]], float]:
    """The rectangle (counter-clockwise world corners) around every footprint in a frame turned
    by ``yaw``, each side ``margin`` metres out; and its area.

    With ``snap_gap``, a side whose outermost object is furniture that stands against a wall
    (:func:`~scenemosaic.scene.traits`) with its back to that side (within 30 degrees) is placed
    only ``snap_gap`` behind it: the wall that furniture implies.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    to_local = np.array([[c, s], [-s, c]])  # world -> rotated frame
    lo = np.array([np.inf, np.inf])
    hi = -lo
    per_item: list[tuple[FootprintItem, FloatArray, FloatArray]] = []
    for item in items:
        pts = np.asarray(item.points, dtype=np.float64) @ to_local.T
        a, b = pts.min(axis=0), pts.max(axis=0)
        per_item.append((item, a, b))
        lo, hi = np.minimum(lo, a), np.maximum(hi, b)
    sides = [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])]  # -x, -y, +x, +y
    outward_dirs = [np.array([-1.0, 0.0]), np.array([0.0, -1.0]), np.array([1.0, 0.0]), np.array([0.0, 1.0])]
    for k in range(4):
        axis, sign = k % 2, (-1.0 if k < 2 else 1.0)
        extreme = sides[k]
        gap = margin
        if snap_gap is not None:
            for item, a, b in per_item:
                edge = a[axis] if sign < 0 else b[axis]
                if abs(edge - extreme) > 0.05 or not traits(item.category).against_wall:
                    continue
                back_world = -np.array([math.sin(item.yaw), -math.cos(item.yaw)])
                if float((to_local @ back_world) @ outward_dirs[k]) > math.cos(math.radians(30)):
                    gap = snap_gap
                    break
        sides[k] = extreme + sign * gap
    x0, y0, x1, y1 = sides
    to_world = to_local.T
    corners = [to_world @ np.array(p) for p in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]
    return [(float(p[0]), float(p[1])) for p in corners], float((x1 - x0) * (y1 - y0))


def recovered_ceiling(items: Sequence[FootprintItem], min_ceiling: float = MIN_CEILING_HEIGHT) -> float:
    """Ceiling height = max(``min_ceiling``, tallest floor-standing top + ``TOP_CLEARANCE``, lamp tops)."""
    ceiling = min_ceiling
    for item in items:
        if item.category in CEILING_LAMP_CATEGORIES:
            ceiling = max(ceiling, item.top)
        else:
            ceiling = max(ceiling, item.top + TOP_CLEARANCE)
    return float(ceiling)


def recover_room(
    objects: Sequence[SceneObject],
    *,
    margin: float = ROOM_MARGIN,
    snap_gap: float | None = WALL_SNAP_GAP,
    min_ceiling: float = MIN_CEILING_HEIGHT,
    source: str = "",
) -> Room:
    """A rectangular room around the objects' footprints (see ``docs/importers.md``).

    The footprints of every object (ceiling lamps included, projected onto the floor) are
    enclosed in the smallest rectangle aligned with :func:`dominant_orientation`, grown by
    ``margin`` on each side — except a side that furniture standing against a wall backs onto:
    that wall is placed ``snap_gap`` behind it (the wall the furniture implies; ``None`` keeps the
    margin everywhere). The ceiling follows :func:`recovered_ceiling`. The room agent uses the
    same functions.
    """
    if not objects:
        raise ImportFormatError("no objects to recover a room from", path=source or None)
    items = footprint_items(objects)
    floor, _area = room_rectangle(items, dominant_orientation(items), margin=margin, snap_gap=snap_gap)
    try:
        return Room.from_polygon(floor, ceiling_height=recovered_ceiling(items, min_ceiling))
    except ValidationError as exc:  # objects at the edge of the limits can give a room beyond them
        detail = str(exc.errors()[0]["msg"]).removeprefix("Value error, ")
        raise ImportFormatError(f"the room recovered from the objects is unusable: {detail}", path=source or None) from exc

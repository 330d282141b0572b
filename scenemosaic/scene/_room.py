"""Recover a room from furniture alone, for layouts that carry no floor polygon."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._model import Room, SceneObject

__all__ = [
    "CEILING_LAMP_CATEGORIES",
    "MIN_CEILING_HEIGHT",
    "ROOM_MARGIN",
    "TOP_CLEARANCE",
    "dominant_orientation",
    "recover_room",
]

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


def dominant_orientation(objects: Sequence[SceneObject]) -> float:
    """The room's orientation modulo 90 degrees, in radians within [-pi/4, pi/4).

    Each object votes with its yaw times four (so yaws 90 degrees apart agree), weighted by the
    square of its footprint area, so the largest pieces (beds, sofas, tables) decide. The
    circular mean of the votes, divided by four, is the answer; within ``SNAP_TO_AXES_RAD``
    of the axes it is snapped to 0.
    """
    sx = sy = 0.0
    for obj in objects:
        size = obj.size
        weight = float(size[0] * size[1]) ** 2
        angle = 4.0 * obj.pose.yaw
        sx += weight * math.cos(angle)
        sy += weight * math.sin(angle)
    if math.hypot(sx, sy) < 1e-12:
        return 0.0
    theta = math.atan2(sy, sx) / 4.0
    return 0.0 if abs(theta) < SNAP_TO_AXES_RAD else theta


def recover_room(
    objects: Sequence[SceneObject],
    *,
    margin: float = ROOM_MARGIN,
    min_ceiling: float = MIN_CEILING_HEIGHT,
    source: str = "",
) -> Room:
    """A rectangular room around the objects' footprints (see ``docs/importers.md``).

    The footprints of every object (ceiling lamps included, projected onto the floor) are
    enclosed in the smallest rectangle aligned with :func:`dominant_orientation`, grown by
    ``margin`` on each side. Ceiling height = max(``min_ceiling``, tallest top of a
    floor-standing object + ``TOP_CLEARANCE``, top of every ceiling lamp).
    """
    if not objects:
        raise ImportFormatError("no objects to recover a room from", path=source or None)
    theta = dominant_orientation(objects)
    c, s = math.cos(theta), math.sin(theta)
    to_room = np.array([[c, s], [-s, c]])  # world -> room-aligned axes
    points: list[FloatArray] = []
    ceiling = min_ceiling
    for obj in objects:
        corners = obj.corners()
        points.append(corners[:, :2] @ to_room.T)
        top = float(corners[:, 2].max())
        if obj.category in CEILING_LAMP_CATEGORIES:
            ceiling = max(ceiling, top)
        else:
            ceiling = max(ceiling, top + TOP_CLEARANCE)
    pts = np.vstack(points)
    lo = pts.min(axis=0) - margin
    hi = pts.max(axis=0) + margin
    rect = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    world = rect @ to_room  # room-aligned -> world (inverse of an orthonormal matrix is its transpose)
    floor = [(float(x), float(y)) for x, y in world]
    return Room.from_polygon(floor, ceiling_height=float(ceiling))

"""The limits every scene and every mesh must respect, in one place.

Each limit keeps a hostile or broken input from reaching a stage that would take it badly:
MuJoCo with a one-nanometre box, CoACD with a five-million-face scan, a structuring prompt with
thousands of objects. The scene model's validators check the scene limits (so every reader and
every later stage gets them); the readers check them again on the raw file so their errors name
the file's own field; ``scenemosaic.assets`` checks the mesh limits. ``docs/conventions.md``
lists them all.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

__all__ = [
    "COACD_MAX_FACES",
    "MAX_COORDINATE",
    "MAX_FLOOR_POINTS",
    "MAX_HOUSE_ROOMS",
    "MAX_HOUSE_SPAN_M",
    "MAX_HULL_VERTICES",
    "MAX_MESH_FACES",
    "MAX_OBJECTS",
    "MAX_OBJECT_SIZE",
    "MAX_SCALE",
    "MIN_OBJECT_SIZE",
    "MIN_SCALE",
    "coordinate_problem",
    "house_problem",
    "object_count_problem",
    "scale_problem",
    "size_problem",
]

MAX_OBJECTS = 512
"""Most objects in one scene. The structuring agents bound every list they return to this many
items, so a larger scene could not be described to them."""

MAX_FLOOR_POINTS = 256
"""Most points of a room's floor polygon, and most walls of a room. A real room has a few dozen
corners (a round bay drawn point by point, a few more); the structuring agents' room outputs are
bounded to the same number."""

MAX_COORDINATE = 1000.0
"""Largest absolute value, in metres, of any coordinate of an object position, floor point or
wall end. A kilometre holds any indoor scene; beyond it float32 physics loses millimetres."""

MAX_HOUSE_ROOMS = 200
"""Most rooms in one house. Real homes hold a few dozen; past this a house is refused at import,
before any room is built (checks across rooms grow with the number of rooms)."""

MAX_HOUSE_SPAN_M = 200.0
"""Largest extent, in metres, of a house's plan along either axis (its rooms' floors together).
The house-wide walkable raster has 5 cm cells: 200 m is 4,000 cells a side (16 M cells, tens of
MB); rooms kilometres apart would need gigabytes, so such a house is refused at import."""

MIN_OBJECT_SIZE = 0.001
"""Smallest size, in metres, of an object along each of its axes (``asset.extents * pose.scale``).
Thinner bodies make MuJoCo's contact solver unstable."""

MAX_OBJECT_SIZE = 100.0
"""Largest size, in metres, of an object along each of its axes, and largest wall or ceiling height."""

MIN_SCALE = 0.001
"""Smallest per-axis pose scale."""

MAX_SCALE = 1000.0
"""Largest per-axis pose scale: a millimetre-unit mesh read as metres is the worst honest case."""

MAX_MESH_FACES = 5_000_000
"""Most triangles a mesh file may hold; a larger one is refused when it is loaded."""

COACD_MAX_FACES = 50_000
"""Meshes with more triangles are decimated to this many before convex decomposition, whatever
``CoacdParams.simplify_faces`` says (it usually asks for far fewer)."""

MAX_HULL_VERTICES = 256
"""Most vertices of the single convex hull used when convex decomposition fails or gives poor
pieces (CoACD's own per-piece default); a larger hull is simplified to this many."""


def _fmt(value: float) -> str:
    return f"{value:g}"


def object_count_problem(count: int) -> str | None:
    """Why ``count`` objects are too many for one scene, or ``None``."""
    if count > MAX_OBJECTS:
        return f"{count} objects; a scene holds at most {MAX_OBJECTS}"
    return None


def house_problem(rooms: int, xs: Iterable[float], ys: Iterable[float]) -> str | None:
    """Why a house of ``rooms`` rooms whose floor points have these coordinates (metres) is too
    large to work on as one, or ``None``."""
    if rooms > MAX_HOUSE_ROOMS:
        return f"{rooms} rooms; a house holds at most {MAX_HOUSE_ROOMS}"
    xs, ys = list(xs), list(ys)
    if xs and ys:
        span = max(max(xs) - min(xs), max(ys) - min(ys))
        if span > MAX_HOUSE_SPAN_M:
            return (
                f"its rooms spread over {span:,.0f} m; a house's plan spans at most {MAX_HOUSE_SPAN_M:g} m "
                "(generate rooms far apart one by one, with --room)"
            )
    return None


def coordinate_problem(values: Iterable[float]) -> str | None:
    """Why a point (any number of coordinates, metres) is unusable, or ``None``.

    Non-finite values and values beyond :data:`MAX_COORDINATE` are refused.
    """
    for i, v in enumerate(values):
        if not math.isfinite(v):
            return f"coordinate {i} must be finite, got {v!r}"
        if abs(v) > MAX_COORDINATE:
            return f"coordinate {i} is {_fmt(v)} m, beyond the +/-{_fmt(MAX_COORDINATE)} m allowed"
    return None


def size_problem(size: Iterable[float]) -> str | None:
    """Why an object size (metres, one value per axis) is unusable, or ``None``."""
    for axis, v in zip("xyz", size, strict=False):
        if not math.isfinite(v):
            return f"size along {axis} must be finite, got {v!r}"
        if v < MIN_OBJECT_SIZE:
            return f"size along {axis} is {_fmt(v)} m, below the {_fmt(MIN_OBJECT_SIZE)} m minimum"
        if v > MAX_OBJECT_SIZE:
            return f"size along {axis} is {_fmt(v)} m, above the {_fmt(MAX_OBJECT_SIZE)} m maximum"
    return None


def scale_problem(scale: Iterable[float]) -> str | None:
    """Why a per-axis pose scale is unusable, or ``None``."""
    for axis, v in zip("xyz", scale, strict=False):
        if not math.isfinite(v):
            return f"scale along {axis} must be finite, got {v!r}"
        if not MIN_SCALE <= v <= MAX_SCALE:
            return f"scale along {axis} is {_fmt(v)}, outside [{_fmt(MIN_SCALE)}, {_fmt(MAX_SCALE)}]"
    return None

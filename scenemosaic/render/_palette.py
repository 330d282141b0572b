"""Colours shared by the top-down views and the GLB export.

A category's colour is derived from a hash of its name, so it is stable across runs,
machines and processes (Python's ``hash`` is salted per process; this one is not).
"""

from __future__ import annotations

import colorsys
import hashlib

import numpy as np
import numpy.typing as npt

__all__ = [
    "BACKGROUND",
    "CEILING_COLOR",
    "DOOR_COLOR",
    "FLOOR_COLOR",
    "GRID_COLOR",
    "INK_COLOR",
    "RGB",
    "WALL_COLOR",
    "WINDOW_COLOR",
    "category_color",
    "shade",
    "shades",
]

RGB = tuple[int, int, int]

BACKGROUND: RGB = (255, 255, 255)
"""Image background, outside the floor."""
FLOOR_COLOR: RGB = (232, 228, 220)
WALL_COLOR: RGB = (70, 70, 78)
CEILING_COLOR: RGB = (245, 245, 245)
DOOR_COLOR: RGB = (80, 193, 102)
WINDOW_COLOR: RGB = (94, 193, 230)
GRID_COLOR: RGB = (200, 200, 205)
INK_COLOR: RGB = (25, 25, 30)
"""Outlines, arrows, labels and tick marks."""

SHADE_MIN = 0.55
"""Brightness factor of a surface at the bottom of a view's depth range (1.0 at the top)."""


def category_color(category: str) -> RGB:
    """A saturated, mid-bright colour for a category, stable across processes.

    The hue comes from the first bytes of the SHA-256 of the category name; saturation and
    value stay in a band that keeps black labels readable and leaves the floor colour distinct.
    """
    digest = hashlib.sha256(category.encode("utf-8")).digest()
    hue = int.from_bytes(digest[:2], "big") / 65536.0
    sat = 0.55 + 0.25 * digest[2] / 255.0
    val = 0.80 + 0.15 * digest[3] / 255.0
    r, g, b = colorsys.hsv_to_rgb(hue, sat, val)
    return (round(r * 255), round(g * 255), round(b * 255))


def shade(color: RGB, t: float) -> RGB:
    """``color`` darkened for a surface at fraction ``t`` (0 bottom .. 1 top) of the depth range.

    Higher surfaces are brighter, so stacked objects read apart in a top-down view.
    """
    return shades(color, np.array([t], dtype=np.float64))[0]


def shades(color: RGB, t: npt.NDArray[np.float64]) -> list[RGB]:
    """:func:`shade` of ``color`` at each fraction of ``t`` (N,), made at once (a view shades
    every triangle it draws): the fraction clamped to [0, 1], each channel scaled and rounded
    half to even."""
    k = SHADE_MIN + (1.0 - SHADE_MIN) * np.minimum(np.maximum(np.asarray(t, dtype=np.float64), 0.0), 1.0)
    rgb = np.rint(np.stack([color[0] * k, color[1] * k, color[2] * k], axis=-1)).astype(np.int64)
    return list(zip(*rgb.T.tolist(), strict=True))

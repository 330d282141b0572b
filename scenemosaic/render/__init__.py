"""Orthographic views of scenes as PNG images, drawn with Pillow (no GL context needed).

* :func:`render_topdown` — the floor plan of a whole scene (``base/topdown.png``).
* :func:`contact_sheet` — several pictures in one labelled grid (a run's base and variants).
* :func:`render_view` with an :class:`OrthoView` — any orthographic view of any subset of
  objects; the seam for per-unit views (wall units seen along their normal, containers from
  their front).
* :func:`object_world_mesh`, :func:`floor_mesh`, :func:`wall_mesh`, :func:`ceiling_mesh` —
  world-space meshes of a scene, shared with :mod:`scenemosaic.exchange`.
"""

from scenemosaic.render._geometry import (
    CEILING_THICKNESS,
    FLOOR_THICKNESS,
    ceiling_mesh,
    floor_mesh,
    object_local_mesh,
    object_world_mesh,
    wall_mesh,
    wall_panels,
)
from scenemosaic.render._palette import CEILING_COLOR, FLOOR_COLOR, RGB, WALL_COLOR, category_color, shade
from scenemosaic.render._sheet import contact_sheet
from scenemosaic.render._topdown import render_topdown, topdown_view
from scenemosaic.render._view import OrthoView, PixelMap, render_view

__all__ = [
    "CEILING_COLOR",
    "CEILING_THICKNESS",
    "FLOOR_COLOR",
    "FLOOR_THICKNESS",
    "RGB",
    "WALL_COLOR",
    "OrthoView",
    "PixelMap",
    "category_color",
    "ceiling_mesh",
    "contact_sheet",
    "floor_mesh",
    "object_local_mesh",
    "object_world_mesh",
    "render_topdown",
    "render_view",
    "shade",
    "topdown_view",
    "wall_mesh",
    "wall_panels",
]

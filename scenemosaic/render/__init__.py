"""Orthographic views of scenes as PNG images, drawn with Pillow (no GL context needed).

* :func:`render_topdown` — the floor plan of a whole scene (``base/topdown.png``);
  :func:`render_house_plan` — the plan of a whole house, each room named.
* :func:`contact_sheet` — several pictures in one labelled grid (a run's base and variants);
  :class:`ContactSheet` builds one a tile at a time.
* :func:`render_view` with an :class:`OrthoView` — any orthographic view of any subset of
  objects; the seam for per-unit views (wall units seen along their normal, containers from
  their front).
* :func:`object_world_mesh`, :func:`floor_mesh`, :func:`wall_mesh`, :func:`ceiling_mesh` —
  world-space meshes of a scene, shared with :mod:`scenemosaic.exchange`.
"""

from scenemosaic.render._geometry import (
    CEILING_THICKNESS,
    FLOOR_THICKNESS,
    SHARED_WALL_TOLERANCE_M,
    WallPanel,
    WallPiece,
    ceiling_mesh,
    floor_mesh,
    house_wall_pieces,
    moved_arrays,
    object_local_mesh,
    object_world_arrays,
    object_world_mesh,
    polygon_rectangles,
    subtract_panels,
    wall_ends,
    wall_mesh,
    wall_panels,
    wall_pieces,
)
from scenemosaic.render._palette import CEILING_COLOR, FLOOR_COLOR, RGB, WALL_COLOR, category_color, shade
from scenemosaic.render._sheet import ContactSheet, contact_sheet
from scenemosaic.render._topdown import (
    house_view,
    plan_png,
    render_house_plan,
    render_topdown,
    room_label,
    topdown_view,
)
from scenemosaic.render._view import PNG_COMPRESS_LEVEL, OrthoView, PixelMap, png_bytes, render_view
from scenemosaic.scene import register_plan_renderer

register_plan_renderer(plan_png)  # Scene._repr_png_ and House._repr_png_: a notebook shows a plan

__all__ = [
    "CEILING_COLOR",
    "CEILING_THICKNESS",
    "FLOOR_COLOR",
    "FLOOR_THICKNESS",
    "PNG_COMPRESS_LEVEL",
    "RGB",
    "SHARED_WALL_TOLERANCE_M",
    "WALL_COLOR",
    "ContactSheet",
    "OrthoView",
    "PixelMap",
    "WallPanel",
    "WallPiece",
    "category_color",
    "ceiling_mesh",
    "contact_sheet",
    "floor_mesh",
    "house_view",
    "house_wall_pieces",
    "moved_arrays",
    "object_local_mesh",
    "object_world_arrays",
    "object_world_mesh",
    "plan_png",
    "png_bytes",
    "polygon_rectangles",
    "render_house_plan",
    "render_topdown",
    "render_view",
    "room_label",
    "shade",
    "subtract_panels",
    "topdown_view",
    "wall_ends",
    "wall_mesh",
    "wall_panels",
    "wall_pieces",
]

"""The orthographic view of a unit: the anchor surface seen along the unit's projection.

The picture is :func:`scenemosaic.render.render_view` of the unit's children (and the anchor
object, when there is one) with the view plane set to the unit's surface, so the grid's tick
labels are the (u, v) coordinates the agents read and write; the surface boundary (the floor
polygon, the wall, the anchor's top or front) is drawn over it, with every object's box, id
and facing arrow. The meshes are rendered by MuJoCo offscreen (``MUJOCO_GL=egl``) when a GL
context can be made, else painted with Pillow from the same triangles.
"""

from __future__ import annotations

import io
from typing import Literal

import numpy as np
from PIL import Image, ImageDraw

from scenemosaic.render import OrthoView, PixelMap, png_bytes, render_view
from scenemosaic.scene import Scene, UnitLayout, rigid_moves

__all__ = ["VIEW_MARGIN_M", "VIEW_PX", "scene_with", "unit_view", "unit_view_png"]

VIEW_PX = 1024
"""Side of a unit view, pixels (the method's 1024 x 1024)."""
VIEW_MARGIN_M = 0.3
"""Margin around the anchor surface in the view, metres."""


def unit_view(layout: UnitLayout) -> OrthoView:
    """The view plane of a unit: origin at its surface's (0, 0), axes u and v."""
    s = layout.surface
    U, V = s.size
    span = max(U, V)
    m = max(VIEW_MARGIN_M, 0.05 * span)
    return OrthoView(
        origin=tuple(float(x) for x in s.origin),  # type: ignore[arg-type]
        u=tuple(float(x) for x in s.u_axis),  # type: ignore[arg-type]
        v=tuple(float(x) for x in s.v_axis),  # type: ignore[arg-type]
        extent=(-m, U + m, -m, V + m),
        depth_range=(-0.05, 3.0 if s.kind in ("floor", "ceiling") else max(0.5, span)),
    )


def scene_with(scene: Scene, layout: UnitLayout) -> Scene:
    """``scene`` with the unit's children posed as ``layout`` says (what they carry moves along);
    not re-validated: poses come from the layout's own conversion."""
    moved = rigid_moves(scene, layout.poses())
    objects = [o.model_copy(update={"pose": moved[o.id]}) if o.id in moved else o for o in scene.objects]
    return scene.model_copy(update={"objects": objects})


def unit_view_png(
    scene: Scene,
    layout: UnitLayout,
    *,
    base_dir: object = None,
    size_px: int = VIEW_PX,
    backend: Literal["pillow", "mujoco", "auto"] = "auto",
) -> bytes:
    """PNG of the unit's current layout (children posed as ``layout`` says): MuJoCo's offscreen
    render of the real meshes when GL is available (``MUJOCO_GL=egl``), else the Pillow painter;
    the grid, boxes, ids, facing arrows and the surface boundary drawn over it either way."""
    view = unit_view(layout)
    posed = scene_with(scene, layout)
    ids = list(layout.ids)
    anchor = layout.surface.anchor_id
    if layout.surface.kind == "object":
        ids = [anchor, *ids]
    png = render_view(posed, view, object_ids=ids, base_dir=base_dir, size_px=size_px, backend=backend)  # type: ignore[arg-type]
    image = Image.open(io.BytesIO(png)).convert("RGB")
    draw = ImageDraw.Draw(image)
    pm = PixelMap.for_size(view, size_px)
    region = np.asarray(layout.surface.region, dtype=np.float64)
    pts = [(float(x), float(y)) for x, y in pm.to_px(region)]
    draw.line([*pts, pts[0]], fill=(200, 40, 40), width=3)
    return png_bytes(image)

"""The floor plan: a top-down orthographic view of the whole scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenemosaic.render._view import OrthoView, render_view
from scenemosaic.scene import Scene

__all__ = ["PLAN_PADDING_M", "render_topdown", "topdown_view"]

PLAN_PADDING_M = 0.25
"""Empty border around the room (walls included) and the objects in a floor plan, metres."""


def topdown_view(scene: Scene) -> OrthoView:
    """The top-down view framing the room (walls included) and every object's footprint.

    Shading runs from the floor (z = 0) to the ceiling or the highest object top, whichever
    is higher. A scene with neither room nor objects gets a 2 m square around the origin.
    """
    xy: list[np.ndarray] = []
    top = 0.0
    if scene.room is not None:
        pts = np.asarray(scene.room.floor, dtype=np.float64)
        thick = max((w.thickness for w in scene.room.walls), default=0.0)
        xy += [pts.min(axis=0) - thick, pts.max(axis=0) + thick]
        top = scene.room.ceiling_height
    for obj in scene.objects:
        lo, hi = obj.aabb()
        xy += [lo[:2], hi[:2]]
        top = max(top, float(hi[2]))
    if not xy:
        xy = [np.array([-1.0, -1.0]), np.array([1.0, 1.0])]
    arr = np.asarray(xy)
    lo2, hi2 = arr.min(axis=0) - PLAN_PADDING_M, arr.max(axis=0) + PLAN_PADDING_M
    return OrthoView.top_down(
        float(lo2[0]), float(lo2[1]), float(hi2[0]), float(hi2[1]), z_range=(0.0, max(top, 1e-3))
    )


def render_topdown(
    scene: Scene, *, base_dir: Path | None = None, size_px: int = 1024, show_labels: bool = True
) -> bytes:
    """PNG bytes of the scene's floor plan, ``size_px`` square.

    World +X points right and +Y up in the image. Draws the floor polygon, walls with their
    doors (green) and windows (blue), a metric grid with tick labels in metres, and for each
    object its mesh silhouette (higher surfaces brighter), oriented box outline, an arrow along
    its front and its id. See :func:`scenemosaic.render.render_view` for the general view.
    """
    return render_view(
        scene, topdown_view(scene), base_dir=base_dir, size_px=size_px, show_labels=show_labels
    )

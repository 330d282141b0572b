"""The floor plan: a top-down orthographic view of the whole scene, or of a whole house."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import shapely
import shapely.affinity
from PIL import ImageDraw
from shapely.ops import polylabel

from scenemosaic.render._geometry import house_wall_pieces
from scenemosaic.render._palette import BACKGROUND, INK_COLOR
from scenemosaic.render._view import (
    OrthoView,
    PixelMap,
    _draw_annotations,
    _font,
    _paint,
    png_bytes,
    render_view,
)
from scenemosaic.scene import House, Scene

__all__ = [
    "NOTEBOOK_HOUSE_PLAN_PX",
    "NOTEBOOK_PLAN_PX",
    "PLAN_PADDING_M",
    "house_view",
    "plan_png",
    "render_house_plan",
    "render_topdown",
    "room_label",
    "topdown_view",
]

PLAN_PADDING_M = 0.25
"""Empty border around the room (walls included) and the objects in a floor plan, metres."""


def topdown_view(scene: Scene) -> OrthoView:
    """The top-down view framing the room (walls included) and every object's footprint.

    Shading runs from the floor (z = 0) to the ceiling or the highest object top, whichever
    is higher. A scene with neither room nor objects gets a 2 m square around the origin.
    """
    return _plan_view([scene])


def house_view(house: House) -> OrthoView:
    """The top-down view framing every room of a house (walls included) and every object, shaded
    from the floor to the highest ceiling or object top (:func:`topdown_view` over all rooms)."""
    return _plan_view(house.rooms)


def _plan_view(scenes: Sequence[Scene]) -> OrthoView:
    xy: list[np.ndarray] = []
    top = 0.0
    for scene in scenes:
        if scene.room is not None:
            pts = np.asarray(scene.room.floor, dtype=np.float64)
            thick = max((w.thickness for w in scene.room.walls), default=0.0)
            xy += [pts.min(axis=0) - thick, pts.max(axis=0) + thick]
            top = max(top, scene.room.ceiling_height)
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


NOTEBOOK_PLAN_PX = 512
"""Size of the plan a notebook shows for a scene (``Scene._repr_png_``)."""
NOTEBOOK_HOUSE_PLAN_PX = 768
"""Size of the plan a notebook shows for a house (``House._repr_png_``): larger than a room's, so
each room's name and objects stay legible."""


def plan_png(scene: Scene | House) -> bytes:
    """The plan for a notebook: a scene's (:func:`render_topdown` at :data:`NOTEBOOK_PLAN_PX`) or
    a whole house's (:func:`render_house_plan` at :data:`NOTEBOOK_HOUSE_PLAN_PX`), mesh files
    resolved next to the file or folder it was read from (its ``provenance.source_path``), else
    from the working directory. The renderer behind ``Scene._repr_png_`` and ``House._repr_png_``."""
    base_dir: Path | None = None
    source = scene.provenance.source_path
    if source:
        path = Path(source)
        base_dir = path if path.is_dir() else path.parent
    if isinstance(scene, House):
        return render_house_plan(scene, base_dir=base_dir, size_px=NOTEBOOK_HOUSE_PLAN_PX)
    return render_topdown(scene, base_dir=base_dir, size_px=NOTEBOOK_PLAN_PX)


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


_WORD_START = re.compile(r"(?<=[a-z0-9])(?=[A-Z])")


def room_label(scene: Scene) -> str:
    """How a house plan names a room: the room type its source gives, words split
    (``LivingRoom`` -> ``Living Room``), with its id, as ``Living Room (room_9)``; else its id."""
    kind = scene.provenance.room_type
    if isinstance(kind, str) and kind.strip():
        return f"{_WORD_START.sub(' ', kind.strip())} ({scene.id})"
    return scene.id


def render_house_plan(
    house: House, *, base_dir: Path | None = None, size_px: int = 1600, show_labels: bool = True
) -> bytes:
    """PNG bytes of a whole house's floor plan, ``size_px`` square.

    Drawn as :func:`render_topdown` draws a room (world +X right, +Y up, a metric grid in metres,
    objects' silhouettes in their category colours with box outline, front arrow and, with
    ``show_labels``, id), over every room: each floor, the walls as they stand at floor level
    (shared walls once, :func:`~scenemosaic.render.house_wall_pieces`), so a door is a gap,
    drawn green (windows blue). Each room's name (:func:`room_label`) is printed in large type
    over everything else, inside the room where it clears its walls and, if it can, its objects. ``base_dir`` resolves
    relative mesh uris. Equal houses give equal bytes.
    """
    pieces = house_wall_pieces(house)
    walls = [(w, pieces[(s.id, w.id)]) for s in house.rooms if s.room is not None for w in s.room.walls]
    objects = house.objects
    image, draw, pm, font = _paint(
        house.rooms, walls, objects, house_view(house),
        base_dir=base_dir, size_px=size_px, plan=True, show_grid=True, backend="pillow",
    )  # fmt: skip
    _draw_annotations(draw, objects, pm, font, show_labels)
    _draw_room_labels(draw, house.rooms, pm, size_px)
    return png_bytes(image)


def _fitting(region: shapely.Geometry, width: float, height: float) -> shapely.Geometry:
    """Where a ``width`` x ``height`` box centred on the point stays inside ``region``: the region
    eroded by that box (squeezed along x to make the box a square, eroded, stretched back)."""
    ratio = height / max(width, 1e-9)
    squeezed = shapely.affinity.scale(region, xfact=ratio, yfact=1.0, origin=(0.0, 0.0))
    eroded = squeezed.buffer(-height / 2.0, join_style="mitre")
    return shapely.affinity.scale(eroded, xfact=1.0 / ratio, yfact=1.0, origin=(0.0, 0.0))


def _label_regions(scene: Scene) -> list[shapely.Geometry]:
    """Where a room's name may go, best first: its floor less its objects' footprints, its floor."""
    assert scene.room is not None
    floor = shapely.Polygon(scene.room.floor).buffer(0)
    feet = [shapely.MultiPoint(o.corners()[:, :2]).convex_hull for o in scene.objects]
    return [floor.difference(shapely.union_all(feet)), floor] if feet else [floor]


def _label_spot(region: shapely.Geometry, width: float, height: float) -> tuple[float, float] | None:
    """The point of ``region`` farthest from its edges where a ``width`` x ``height`` box (metres)
    centred on it fits inside, or ``None`` if it fits nowhere."""
    room_for_it = _fitting(region, width, height)
    parts = [
        g for g in getattr(room_for_it, "geoms", [room_for_it]) if g.geom_type == "Polygon" and g.area > 0
    ]
    if not parts:
        return None
    spot = polylabel(max(parts, key=lambda g: g.area), tolerance=0.02)
    return float(spot.x), float(spot.y)


def _draw_room_labels(draw: ImageDraw.ImageDraw, rooms: Sequence[Scene], pm: PixelMap, size_px: int) -> None:
    """Each room's name inside the room: clear of its objects if it can be, in the largest type
    (down to 60 %) that fits, on one line or, in a narrow room, with the id on a second line."""
    largest = max(14, size_px // 50)
    smallest = max(10, round(largest * 0.6))
    stroke = max(3, size_px // 400)
    for scene in rooms:
        if scene.room is None:
            continue
        one_line = room_label(scene)
        texts = [one_line, one_line.replace(" (", "\n(")] if " (" in one_line else [one_line]
        choice: tuple[str, int, tuple[float, float]] | None = None
        for region in _label_regions(scene):
            for text in texts:
                for size in range(largest, smallest - 1, -2):
                    x0, y0, x1, y1 = draw.multiline_textbbox(
                        (0, 0), text, font=_font(size), anchor="mm", align="center", stroke_width=stroke
                    )
                    spot = _label_spot(region, (x1 - x0) / pm.scale, (y1 - y0) / pm.scale)
                    if spot is not None:
                        choice = (text, size, spot)
                        break
                if choice is not None:
                    break
            if choice is not None:
                break
        if choice is None:  # too narrow for any: the floor's point farthest from the walls
            centre = polylabel(shapely.Polygon(scene.room.floor).buffer(0), tolerance=0.05)
            choice = (texts[-1], smallest, (float(centre.x), float(centre.y)))
        text, size, spot = choice
        x, y = pm.world_to_px(np.array([[spot[0], spot[1], 0.0]]))[0]
        draw.multiline_text(
            (float(x), float(y)), text, fill=INK_COLOR, font=_font(size), anchor="mm", align="center",
            stroke_width=stroke, stroke_fill=BACKGROUND,
        )  # fmt: skip

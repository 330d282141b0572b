"""Orthographic views of a scene drawn with Pillow (no GL context needed).

A view is a plane: an ``origin``, a unit ``u`` axis drawn to the right and a unit ``v`` axis
drawn up (the orthographic-view convention of the method's prompts). Points are projected
onto the plane; their *depth* is their coordinate along ``u x v``, which points toward the
viewer, so surfaces with larger depth are drawn later (painter's order) and brighter.

:func:`render_view` draws any such view of any subset of objects; the floor plan
(:func:`scenemosaic.render.render_topdown`) is the case ``u = +X``, ``v = +Y`` (depth = height).
Per-unit views of later stages (a wall seen along its outward normal, a container seen from
its front) are the same call with another :class:`OrthoView` and the unit's object ids.
"""

from __future__ import annotations

import functools
import io
import math
import re
from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import structlog
from PIL import Image, ImageDraw, ImageFont

from scenemosaic._memo import Memo
from scenemosaic.exceptions import SceneValidationError
from scenemosaic.render._geometry import (
    WallPiece,
    object_world_arrays,
    object_world_mesh,
    wall_ends,
    wall_pieces,
)
from scenemosaic.render._palette import (
    BACKGROUND,
    DOOR_COLOR,
    FLOOR_COLOR,
    GRID_COLOR,
    INK_COLOR,
    RGB,
    WALL_COLOR,
    WINDOW_COLOR,
    category_color,
    shades,
)
from scenemosaic.scene import FloatArray, Scene, SceneObject, Wall

if TYPE_CHECKING:
    from PIL._imaging import ImagingCore

__all__ = ["GRID_STEPS_M", "LABEL_GAP_PX", "PNG_COMPRESS_LEVEL", "OrthoView", "PixelMap", "object_label", "png_bytes", "render_view"]

log = structlog.get_logger(__name__)

Vec3 = tuple[float, float, float]

GRID_STEPS_M = (0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
"""Candidate grid spacings in metres; the smallest giving at most :data:`MAX_GRID_LINES` lines wins."""
MAX_GRID_LINES = 12
ARROW_HEAD_M = 0.1
"""Largest length of a facing arrow's head, metres."""
PNG_COMPRESS_LEVEL = 2
"""zlib level of the pictures a run writes (plans, views, the contact sheet): on these flat-coloured
drawings a file within a few per cent of Pillow's default (6) (3 % smaller to 7 % larger on the
shipped houses), written in about two thirds of the time (a 1600 px plan 0.14 -> 0.09 s; the
4800 x 3280 px contact sheet 0.88 -> 0.54 s, all of it at the run's end)."""
LABEL_GAP_PX = 2
"""Clear space kept around each object label, pixels (labels never overlap)."""
LABEL_MIN_PX = 12
"""Smallest label font, pixels; a view's labels are ``size_px / 64`` (16 px in a 1024 px plan)."""
LEADER_COLOR = (90, 90, 100)
"""Colour of the line from an object to its label when the label had to move off the object."""
MIN_AREA_M2 = 1e-10
"""Triangles whose projection is smaller than this (edge-on to the view) are not drawn, m²."""


@dataclass(frozen=True)
class OrthoView:
    """An orthographic view: which plane to project on and which part of it to show.

    ``extent`` is ``(u_min, u_max, v_min, v_max)`` in metres of plane coordinates
    ``((p - origin)·u, (p - origin)·v)``. ``depth_range`` maps depth (along ``u x v``, toward
    the viewer) to shading: surfaces at its low end are darkest, at its high end brightest.
    """

    origin: Vec3
    u: Vec3
    v: Vec3
    extent: tuple[float, float, float, float]
    depth_range: tuple[float, float] = (0.0, 3.0)

    def __post_init__(self) -> None:
        u, v = np.asarray(self.u, dtype=np.float64), np.asarray(self.v, dtype=np.float64)
        if abs(np.linalg.norm(u) - 1) > 1e-6 or abs(np.linalg.norm(v) - 1) > 1e-6 or abs(u @ v) > 1e-6:
            raise SceneValidationError(f"view axes must be orthonormal, got u={self.u}, v={self.v}")
        u0, u1, v0, v1 = self.extent
        if not (u1 > u0 and v1 > v0) or not all(math.isfinite(x) for x in self.extent):
            raise SceneValidationError(f"view extent must be finite and non-empty, got {self.extent}")

    @classmethod
    def top_down(
        cls, xmin: float, ymin: float, xmax: float, ymax: float, *, z_range: tuple[float, float] = (0.0, 3.0)
    ) -> OrthoView:
        """Looking down -Z at the world rectangle ``[xmin, xmax] x [ymin, ymax]``: u = +X, v = +Y."""
        return cls(
            origin=(0.0, 0.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0),
            extent=(xmin, xmax, ymin, ymax), depth_range=z_range,
        )  # fmt: skip

    @property
    def normal(self) -> FloatArray:
        """Unit vector toward the viewer, ``u x v``."""
        return np.cross(np.asarray(self.u, dtype=np.float64), np.asarray(self.v, dtype=np.float64))

    @property
    def is_top_down(self) -> bool:
        """True when the view looks straight down (its normal is world +Z)."""
        return bool(self.normal[2] > 1.0 - 1e-9)

    def project(self, points: FloatArray) -> FloatArray:
        """Plane coordinates (N, 2) of world points (N, 3)."""
        p = np.asarray(points, dtype=np.float64) - np.asarray(self.origin, dtype=np.float64)
        return np.stack(
            [p @ np.asarray(self.u, dtype=np.float64), p @ np.asarray(self.v, dtype=np.float64)], axis=-1
        )

    def depth(self, points: FloatArray) -> FloatArray:
        """Depth (N,) of world points (N, 3) along the normal toward the viewer."""
        p = np.asarray(points, dtype=np.float64) - np.asarray(self.origin, dtype=np.float64)
        return np.asarray(p @ self.normal, dtype=np.float64)

    def shade_fraction(self, depth: FloatArray) -> FloatArray:
        """Where each depth lies in ``depth_range``, clipped to [0, 1]."""
        lo, hi = self.depth_range
        return np.clip((np.asarray(depth, dtype=np.float64) - lo) / max(hi - lo, 1e-9), 0.0, 1.0)


@dataclass(frozen=True)
class PixelMap:
    """Maps plane coordinates (metres) to pixel coordinates of a square image, keeping aspect."""

    view: OrthoView
    size_px: int
    margin_px: int

    @classmethod
    def for_size(cls, view: OrthoView, size_px: int) -> PixelMap:
        """The map :func:`render_view` uses for a ``size_px`` image (margin: 5 %, at least 24 px)."""
        return cls(view=view, size_px=size_px, margin_px=max(24, size_px // 20))

    @property
    def scale(self) -> float:
        """Pixels per metre."""
        u0, u1, v0, v1 = self.view.extent
        avail = self.size_px - 2 * self.margin_px
        return min(avail / (u1 - u0), avail / (v1 - v0))

    def to_px(self, ab: FloatArray) -> FloatArray:
        """Pixel coordinates (N, 2) (x right, y down) of plane coordinates (N, 2)."""
        u0, u1, v0, v1 = self.view.extent
        s = self.scale
        ox = self.margin_px + (self.size_px - 2 * self.margin_px - (u1 - u0) * s) / 2.0
        oy = self.margin_px + (self.size_px - 2 * self.margin_px - (v1 - v0) * s) / 2.0
        ab = np.asarray(ab, dtype=np.float64).reshape(-1, 2)
        return np.stack([ox + (ab[:, 0] - u0) * s, oy + (v1 - ab[:, 1]) * s], axis=-1)

    def world_to_px(self, points: FloatArray) -> FloatArray:
        """Pixel coordinates (N, 2) of world points (N, 3)."""
        return self.to_px(self.view.project(np.asarray(points, dtype=np.float64).reshape(-1, 3)))


_TEXT_PIXELS: Memo[tuple[Hashable, ...], Any] = Memo(2048)
"""What the label font measured (a text's box) and drew (a text's mask and offset), by font size,
text and every argument that shapes them, the mask's subpixel start included (object labels are
drawn at whole pixels, so their start is always zero): a picture's labels,
its grid's tick labels and a house's room names come again in every picture of a run, and
FreeType drawing them again dominated the cost of a plan."""


class _KeptFont(ImageFont.FreeTypeFont):
    """Pillow's default font at one size, keeping each box it measured and each mask it drew in
    :data:`_TEXT_PIXELS` (the same face: the same pixels, only made once)."""

    def __init__(self, font: ImageFont.FreeTypeFont) -> None:
        # the loaded face itself, not a second load of it: the same glyphs, the same metrics
        self.__dict__.update(font.__dict__)

    def _key(self, *parts: Any) -> tuple[Hashable, ...] | None:
        key = (self.size, self.layout_engine, *parts)
        try:
            hash(key)
        except TypeError:  # e.g. a features list: not kept
            return None
        return key

    def getbbox(
        self,
        text: str | bytes | bytearray,
        mode: str = "",
        direction: str | None = None,
        features: list[str] | None = None,
        language: str | None = None,
        stroke_width: float = 0,
        anchor: str | None = None,
    ) -> tuple[float, float, float, float]:
        """:meth:`PIL.ImageFont.FreeTypeFont.getbbox`, made once per text and arguments."""

        def make() -> tuple[float, float, float, float]:
            return super(_KeptFont, self).getbbox(
                text, mode, direction, features, language, stroke_width, anchor
            )

        plain = bytes(text) if isinstance(text, bytearray) else text
        key = self._key("bbox", plain, mode, direction, features, language, stroke_width, anchor)
        out: tuple[float, float, float, float] = make() if key is None else _TEXT_PIXELS.get(key, make)
        return out

    def getmask2(
        self,
        text: str | bytes,
        mode: str = "",
        direction: str | None = None,
        features: list[str] | None = None,
        language: str | None = None,
        stroke_width: float = 0,
        anchor: str | None = None,
        ink: int = 0,
        start: tuple[float, float] | None = None,
        *args: Any,
        **kwargs: Any,
    ) -> tuple[ImagingCore, tuple[int, int]]:
        """:meth:`PIL.ImageFont.FreeTypeFont.getmask2`, made once per text and arguments (the
        mask is only read when drawn; a colour mask, which the caller edits, is never kept)."""

        def make() -> tuple[ImagingCore, tuple[int, int]]:
            return super(_KeptFont, self).getmask2(
                text, mode, direction, features, language, stroke_width, anchor, ink, start, *args, **kwargs
            )

        key = None
        if mode != "RGBA" and not args:
            options = (mode, direction, features, language, stroke_width, anchor, ink, start)
            key = self._key("mask", text, *options, tuple(sorted(kwargs.items())))
        out: tuple[ImagingCore, tuple[int, int]] = make() if key is None else _TEXT_PIXELS.get(key, make)
        return out


@functools.lru_cache(maxsize=32)
def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """The label font at ``size`` pixels (one per size for the process: loading it is not free)."""
    try:
        font = ImageFont.load_default(size=size)
    except (OSError, ValueError, ImportError):  # Pillow without FreeType: the fixed bitmap font
        return ImageFont.load_default()
    return _KeptFont(font) if isinstance(font, ImageFont.FreeTypeFont) else font


def _poly(points: FloatArray) -> list[float]:
    # a flat list of Python floats: what Pillow reads fastest, the same coordinates as pairs
    return np.asarray(points, dtype=np.float64).reshape(-1).tolist()  # type: ignore[no-any-return]


def _hull_2d(points: FloatArray) -> FloatArray:
    """Convex hull (monotone chain) of 2D points, counter-clockwise."""
    pts = sorted({(round(float(x), 12), round(float(y), 12)) for x, y in points})
    if len(pts) <= 2:
        return np.asarray(pts, dtype=np.float64)

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.asarray(lower[:-1] + upper[:-1], dtype=np.float64)


def _grid_step(span: float) -> float:
    for step in GRID_STEPS_M:
        if span / step <= MAX_GRID_LINES:
            return step
    return GRID_STEPS_M[-1] * math.ceil(span / (GRID_STEPS_M[-1] * MAX_GRID_LINES))


def _draw_plan_floors(draw: ImageDraw.ImageDraw, rooms: Sequence[Scene], pm: PixelMap) -> None:
    """The floor polygon of each room of a top-down view."""
    for scene in rooms:
        if scene.room is not None:
            floor = np.array([[x, y, 0.0] for x, y in scene.room.floor])
            draw.polygon(_poly(pm.world_to_px(floor)), fill=FLOOR_COLOR)


def room_walls(scene: Scene) -> list[tuple[Wall, list[WallPiece]]]:
    """(Package-internal.) Each wall of a room with its pieces (openings cut, room-aware ends)."""
    room = scene.room
    return [] if room is None else [(w, wall_pieces(w, wall_ends(room, w))) for w in room.walls]


def _draw_plan_walls(
    draw: ImageDraw.ImageDraw, walls: Sequence[tuple[Wall, Sequence[WallPiece]]], pm: PixelMap
) -> None:
    """Wall footprints at floor level (the pieces standing on the floor: a door leaves a gap),
    then every opening's footprint over them: doors green, windows blue."""

    def rect(wall: Wall, s0: float, s1: float, w0: float, w1: float) -> FloatArray:
        d, out = np.array([*wall.direction, 0.0]), np.array([*wall.outward_normal, 0.0])
        start = np.array([wall.start[0], wall.start[1], 0.0])
        corners = [start + d * s + out * w for s, w in ((s0, w0), (s1, w0), (s1, w1), (s0, w1))]
        return pm.world_to_px(np.asarray(corners))

    for wall, pieces in walls:
        for piece in pieces:
            if piece.z0 <= 1e-9:
                draw.polygon(_poly(rect(wall, piece.s0, piece.s1, piece.w0, piece.w1)), fill=WALL_COLOR)
    for wall, _ in walls:
        for op in wall.openings:
            a, b = wall.span(op)
            if b <= a:
                continue
            color = WINDOW_COLOR if op.kind == "window" else DOOR_COLOR
            draw.polygon(_poly(rect(wall, a, b, 0.0, wall.thickness)), fill=color, outline=INK_COLOR)


def _draw_grid(
    draw: ImageDraw.ImageDraw, pm: PixelMap, font: ImageFont.FreeTypeFont | ImageFont.ImageFont
) -> None:
    """Grid lines over the drawing area and tick labels (metres) in the margins."""
    u0, u1, v0, v1 = pm.view.extent
    step = _grid_step(max(u1 - u0, v1 - v0))
    lo_px = pm.to_px(np.array([[u0, v0]]))[0]
    hi_px = pm.to_px(np.array([[u1, v1]]))[0]
    x_lo, y_hi, x_hi, y_lo = lo_px[0], lo_px[1], hi_px[0], hi_px[1]
    tick = max(3, pm.margin_px // 6)
    digits = 0 if step >= 1 else (1 if step * 10 == round(step * 10) else 2)
    for k in range(math.ceil(u0 / step - 1e-9), math.floor(u1 / step + 1e-9) + 1):
        x = float(pm.to_px(np.array([[k * step, v0]]))[0][0])
        draw.line([(x, y_lo), (x, y_hi)], fill=GRID_COLOR, width=1)
        draw.line([(x, y_hi), (x, y_hi + tick)], fill=INK_COLOR, width=1)
        draw.text((x, y_hi + tick + 1), f"{k * step:.{digits}f}", fill=INK_COLOR, font=font, anchor="ma")
    for k in range(math.ceil(v0 / step - 1e-9), math.floor(v1 / step + 1e-9) + 1):
        y = float(pm.to_px(np.array([[u0, k * step]]))[0][1])
        draw.line([(x_lo, y), (x_hi, y)], fill=GRID_COLOR, width=1)
        draw.line([(x_lo - tick, y), (x_lo, y)], fill=INK_COLOR, width=1)
        draw.text((x_lo - tick - 2, y), f"{k * step:.{digits}f}", fill=INK_COLOR, font=font, anchor="rm")
    draw.rectangle([x_lo, y_lo, x_hi, y_hi], outline=INK_COLOR, width=1)


def _object_triangles(
    objects: Sequence[SceneObject], view: OrthoView, pm: PixelMap, base_dir: Path | None
) -> tuple[FloatArray, FloatArray, list[RGB]]:
    """Every drawable triangle: pixel coordinates (T, 3, 2), sort keys (T, 3) and colours."""
    px_all, keys_all, colors = [], [], []
    for oi, obj in enumerate(objects):
        vertices, faces = object_world_arrays(obj, base_dir)  # object_world_mesh's, without the mesh
        tris = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]  # (F, 3, 3)
        if len(tris) == 0:
            continue
        ab = view.project(tris.reshape(-1, 3)).reshape(-1, 3, 2)
        e1, e2 = ab[:, 1] - ab[:, 0], ab[:, 2] - ab[:, 0]
        keep = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * 0.5 > MIN_AREA_M2
        if not keep.any():
            continue
        depth = view.depth(tris[keep].mean(axis=1))
        colors += shades(category_color(obj.category), view.shade_fraction(depth))
        px_all.append(pm.to_px(ab[keep].reshape(-1, 2)).reshape(-1, 3, 2))
        idx = np.flatnonzero(keep).astype(np.float64)
        keys_all.append(np.stack([depth, np.full(len(idx), float(oi)), idx], axis=-1))
    if not px_all:
        return np.zeros((0, 3, 2)), np.zeros((0, 3)), []
    return np.concatenate(px_all), np.concatenate(keys_all), colors


def _draw_annotations(
    draw: ImageDraw.ImageDraw,
    objects: Sequence[SceneObject],
    pm: PixelMap,
    font: ImageFont.FreeTypeFont | ImageFont.ImageFont,
    show_labels: bool,
) -> None:
    """Each object's projected box outline, facing arrow (its local -Y) and id label."""
    view = pm.view
    for obj in objects:
        corners = obj.corners()
        hull = _hull_2d(view.project(corners))
        if len(hull) >= 3:
            draw.polygon(_poly(pm.to_px(hull)), outline=INK_COLOR, width=1)
        centre = corners.mean(axis=0)
        front = obj.pose.rotation @ np.array([0.0, -1.0, 0.0])
        f2 = np.array([front @ np.asarray(view.u), front @ np.asarray(view.v)])
        if np.linalg.norm(f2) > 0.2:
            size = obj.size
            length = max(0.12, 0.45 * float(max(size[0], size[1])))
            c2 = view.project(centre[None])[0]
            tip = c2 + f2 / np.linalg.norm(f2) * length
            side = np.array([-f2[1], f2[0]]) / np.linalg.norm(f2)
            head = min(0.25 * length, ARROW_HEAD_M)
            back = tip - f2 / np.linalg.norm(f2) * head
            p = pm.to_px(np.array([c2, tip, back + side * head * 0.5, back - side * head * 0.5]))
            draw.line([tuple(p[0]), tuple(p[1])], fill=INK_COLOR, width=2)
            draw.polygon(_poly(p[[1, 2, 3]]), fill=INK_COLOR)
    if show_labels:
        _draw_labels(draw, objects, pm, font)


def object_label(obj: SceneObject) -> str:
    """How a picture names an object: its id when the id says what it is (shares a word with its
    category: ``dining_chair_0``, ``bed``), else the category and the id (``toilet 5_0`` for a
    ProcTHOR object whose id is only numbers)."""
    id_words = set(re.split(r"[^a-z]+", obj.id.lower())) - {""}
    category_words = set(re.split(r"[^a-z]+", obj.category.lower())) - {""}
    if id_words & category_words:
        return obj.id
    return f"{obj.category.replace('_', ' ')} {obj.id}"


@functools.lru_cache(maxsize=64)
def _label_offsets(step: float, reach: float) -> FloatArray:
    """Where a label may go around its object's centre, nearest first: rings of 16 directions
    (``(N, 2)``; made once per label height and picture size)."""
    offsets = [(0.0, 0.0)]
    radius = step
    while radius <= reach:
        offsets += [
            (radius * math.cos(k * math.pi / 8), radius * math.sin(k * math.pi / 8)) for k in range(16)
        ]
        radius += step
    out = np.asarray(offsets, dtype=np.float64)
    out.setflags(write=False)
    return out


def _draw_labels(
    draw: ImageDraw.ImageDraw,
    objects: Sequence[SceneObject],
    pm: PixelMap,
    font: ImageFont.FreeTypeFont | ImageFont.ImageFont,
) -> dict[str, tuple[float, float, float, float]]:
    """Each object's label (:func:`object_label`), no two overlapping: at the object's centre when
    that spot is free, else at the nearest free spot around it with a thin leader line back to
    the centre. Larger objects are placed first; the order is deterministic. Returns each
    object's label box (pixels, with :data:`LABEL_GAP_PX` around the text)."""
    width = height = pm.size_px
    placed: list[tuple[float, float, float, float]] = []
    boxes: dict[str, tuple[float, float, float, float]] = {}
    order = sorted(objects, key=lambda o: (-float(o.size[0] * o.size[1]), o.id))
    for obj in order:
        text = object_label(obj)
        centre = pm.world_to_px(obj.corners().mean(axis=0)[None])[0]
        cx, cy = float(centre[0]), float(centre[1])
        x0, y0, x1, y1 = draw.textbbox((cx, cy), text, font=font, anchor="mm", stroke_width=2)
        half_w, half_h = (x1 - x0) / 2 + LABEL_GAP_PX, (y1 - y0) / 2 + LABEL_GAP_PX
        # around the centre, then anywhere on a grid over the picture (rows top down)
        gx, gy = np.meshgrid(np.arange(half_w, width, half_w) - cx, np.arange(half_h, height, 2 * half_h) - cy)
        grid = np.stack([gx.ravel(), gy.ravel()], axis=-1)
        spots = np.concatenate([_label_offsets(2 * half_h, max(width, height) / 3), grid])
        free = _first_free_spot(spots, (cx, cy, half_w, half_h), placed, (width, height))
        if free is not None:
            dx, dy = (float(v) for v in spots[free])
            box = (cx + dx - half_w, cy + dy - half_h, cx + dx + half_w, cy + dy + half_h)
        else:  # pragma: no cover - a picture with no free spot left for a label
            dx = dy = 0.0
            box = (cx - half_w, cy - half_h, cx + half_w, cy + half_h)
        placed.append(box)
        boxes[obj.id] = box
        lx, ly = cx + dx, cy + dy
        if (dx, dy) != (0.0, 0.0):
            end = (min(max(cx, box[0]), box[2]), min(max(cy, box[1]), box[3]))  # the box's nearest point
            draw.line([(cx, cy), end], fill=LEADER_COLOR, width=1)
            draw.ellipse((cx - 2, cy - 2, cx + 2, cy + 2), fill=LEADER_COLOR)
        # at a whole pixel: crisp text, and the same text drawn anywhere is the same mask (drawn
        # once, :data:`_TEXT_PIXELS`); the box's gap covers the half pixel the label may move
        at = (round(lx), round(ly))
        draw.text(at, text, fill=INK_COLOR, font=font, anchor="mm", stroke_width=2, stroke_fill=BACKGROUND)
    return boxes


def _first_free_spot(
    spots: Sequence[tuple[float, float]] | FloatArray,
    label: tuple[float, float, float, float],
    placed: Sequence[tuple[float, float, float, float]],
    picture: tuple[int, int],
) -> int | None:
    """The index of the first of ``spots`` (offsets from the label's centre ``cx, cy``, its half
    size ``half_w, half_h`` in ``label``) where the label's box lies inside the picture and
    overlaps no box of ``placed``; ``None`` when none does. The spots are tried in batches, each
    at once, a small one first (the nearest spots are free most of the time) and larger ones after."""
    cx, cy, half_w, half_h = label
    offsets = np.asarray(spots, dtype=np.float64).reshape(-1, 2)
    taken = np.asarray(placed, dtype=np.float64).reshape(-1, 4)
    start, batch = 0, 64
    while start < len(offsets):
        part = offsets[start : start + batch]
        x0 = cx + part[:, 0] - half_w
        y0 = cy + part[:, 1] - half_h
        x1 = cx + part[:, 0] + half_w
        y1 = cy + part[:, 1] + half_h
        ok = (x0 >= 0) & (y0 >= 0) & (x1 <= picture[0]) & (y1 <= picture[1])
        if len(taken):
            overlaps = (
                (x0[:, None] < taken[None, :, 2])
                & (taken[None, :, 0] < x1[:, None])
                & (y0[:, None] < taken[None, :, 3])
                & (taken[None, :, 1] < y1[:, None])
            )
            ok &= ~overlaps.any(axis=1)
        hits = np.flatnonzero(ok)
        if len(hits):
            return start + int(hits[0])
        start, batch = start + batch, batch * 4
    return None


def _gl_image(
    rooms: Sequence[Scene],
    walls: Sequence[tuple[Wall, Sequence[WallPiece]]],
    view: OrthoView,
    objects: Sequence[SceneObject],
    pm: PixelMap,
    base_dir: Path | None,
    plan: bool,
) -> Image.Image | None:
    """The meshes rendered by MuJoCo's offscreen renderer, framed like ``pm``; ``None`` without GL."""
    from scenemosaic.render._geometry import floor_mesh, wall_mesh
    from scenemosaic.render._gl import gl_available, render_meshes_gl

    if not gl_available():
        return None
    meshes = [(object_world_mesh(o, base_dir), category_color(o.category)) for o in objects]
    if plan:
        meshes += [(floor_mesh(s.room), FLOOR_COLOR) for s in rooms if s.room is not None]
        meshes += [(wall_mesh(w, pieces), WALL_COLOR) for w, pieces in walls if pieces]
    u0, u1, v0, v1 = view.extent
    centre_ab = np.array([(u0 + u1) / 2.0, (v0 + v1) / 2.0])
    u, v = np.asarray(view.u, dtype=np.float64), np.asarray(view.v, dtype=np.float64)
    centre = np.asarray(view.origin, dtype=np.float64) + centre_ab[0] * u + centre_ab[1] * v
    top = max(
        (float(view.depth(np.asarray(m.vertices)).max()) for m, _ in meshes if len(m.vertices)), default=0.0
    )
    image = render_meshes_gl(
        meshes, center=centre, u=u, v=v, height_m=pm.size_px / pm.scale,
        distance_m=max(top, 0.0) + 1.0, size_px=pm.size_px, background=BACKGROUND,
    )  # fmt: skip
    return None if image is None else Image.fromarray(image, mode="RGB")


def render_view(
    scene: Scene,
    view: OrthoView,
    *,
    object_ids: Sequence[str] | None = None,
    base_dir: Path | None = None,
    size_px: int = 1024,
    show_labels: bool = True,
    show_room: bool = True,
    show_grid: bool = True,
    backend: Literal["pillow", "mujoco", "auto"] = "pillow",
) -> bytes:
    """Draw an orthographic view of a scene and return it as PNG bytes (``size_px`` square).

    Objects (all, or those in ``object_ids``, in scene order) are drawn as silhouettes of their
    visual meshes' triangles in painter's order by depth, each shaded from its category colour
    by depth (see :func:`scenemosaic.render.shade`), then outlined by their projected oriented
    box, with an arrow along their front (local -Y) and their id. In a top-down view the room
    is drawn as a plan (floor polygon, wall footprints, doors green, windows blue) and a metric
    grid with tick labels in metres frames the plane coordinates; other views draw no room yet.
    Equal inputs give identical bytes.

    ``backend="mujoco"`` renders the meshes (and the plan's floor and walls) with MuJoCo's
    offscreen renderer instead of the painter, lit and depth-tested, then draws the same grid and
    annotations over them; ``"auto"`` does so when an offscreen GL context can be made
    (``MUJOCO_GL=egl``) and falls back to the painter otherwise. GL output may differ in its last
    bits between machines and drivers; the painter's does not.
    """
    if size_px < 64:
        raise SceneValidationError(f"size_px must be at least 64, got {size_px}")
    if object_ids is None:
        objects = list(scene.objects)
    else:
        wanted = set(object_ids)
        unknown = wanted - {o.id for o in scene.objects}
        if unknown:
            raise SceneValidationError(
                f"unknown object ids in view: {sorted(unknown)}", object_id=sorted(unknown)[0]
            )
        objects = [o for o in scene.objects if o.id in wanted]
    plan = view.is_top_down and show_room
    image, draw, pm, font = _paint(
        [scene], room_walls(scene), objects, view,
        base_dir=base_dir, size_px=size_px, plan=plan, show_grid=show_grid, backend=backend,
    )  # fmt: skip
    _draw_annotations(draw, objects, pm, font, show_labels)
    return png_bytes(image)


def png_bytes(image: Image.Image) -> bytes:
    """``image`` as PNG bytes, at :data:`PNG_COMPRESS_LEVEL`: how every picture of a run is written."""
    buf = io.BytesIO()
    image.save(buf, format="PNG", compress_level=PNG_COMPRESS_LEVEL)
    return buf.getvalue()


def _paint(
    rooms: Sequence[Scene],
    walls: Sequence[tuple[Wall, Sequence[WallPiece]]],
    objects: Sequence[SceneObject],
    view: OrthoView,
    *,
    base_dir: Path | None,
    size_px: int,
    plan: bool,
    show_grid: bool,
    backend: Literal["pillow", "mujoco", "auto"],
) -> tuple[Image.Image, ImageDraw.ImageDraw, PixelMap, ImageFont.FreeTypeFont | ImageFont.ImageFont]:
    """(Package-internal.) The picture of a view before its annotations: with ``plan``, the rooms'
    floors and ``walls`` (openings drawn over them); the grid; the objects' meshes. Returns the
    image, a drawing context on it, its pixel map and the font for labels."""
    pm = PixelMap.for_size(view, size_px)
    font = _font(max(LABEL_MIN_PX, size_px // 64))
    gl = _gl_image(rooms, walls, view, objects, pm, base_dir, plan) if backend != "pillow" else None
    if backend == "mujoco" and gl is None:
        raise SceneValidationError(
            "backend='mujoco' needs an offscreen GL context (set MUJOCO_GL=egl or osmesa)"
        )
    if gl is not None:
        image = gl
        draw = ImageDraw.Draw(image)
        if show_grid:
            _draw_grid(draw, pm, font)
        n_tri = -1
    else:
        image = Image.new("RGB", (size_px, size_px), BACKGROUND)
        draw = ImageDraw.Draw(image)
        if plan:
            _draw_plan_floors(draw, rooms, pm)
        if show_grid:
            _draw_grid(draw, pm, font)
        if plan:
            _draw_plan_walls(draw, walls, pm)
        px, keys, colors = _object_triangles(objects, view, pm, base_dir)
        order = np.lexsort((keys[:, 2], keys[:, 1], keys[:, 0])) if len(keys) else np.zeros(0, dtype=np.int64)
        corners = px.reshape(len(px), 6).tolist()  # each triangle's flat (x, y) list, as _poly makes it
        for i in order.tolist():
            draw.polygon(corners[i], fill=colors[i])
        n_tri = len(order)
    log.debug("view_rendered", objects=len(objects), triangles=n_tri, size_px=size_px, gl=gl is not None)
    return image, draw, pm, font

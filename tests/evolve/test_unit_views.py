"""Unit views: MuJoCo's offscreen render lines up with the (u, v) overlays, or the painter stands in."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from scenemosaic import GenerateConfig, generate
from scenemosaic.evolve import unit_view, unit_view_png
from scenemosaic.exceptions import SceneValidationError
from scenemosaic.render import FLOOR_COLOR, WALL_COLOR, render_view
from scenemosaic.render._gl import gl_available
from scenemosaic.scene import Scene, UnitLayout

LIVING = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "LivingDiningRoom-124277_livingroom.json"


@pytest.fixture(scope="module")
def living(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    return generate(LIVING, tmp_path_factory.mktemp("living_views"), GenerateConfig(evolve=False)).scene


def _objects_mask(png: bytes) -> np.ndarray:
    """Pixels that are neither background, floor nor wall: where objects are drawn."""
    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int32)
    mask = np.ones(a.shape[:2], dtype=bool)
    for c in ((255, 255, 255), FLOOR_COLOR, WALL_COLOR):
        mask &= np.abs(a - np.asarray(c)).sum(axis=2) > 40
    return mask


def test_the_gl_render_covers_the_same_pixels_as_the_painter(living: Scene) -> None:
    layout = UnitLayout.from_scene(living, "floor")
    view = unit_view(layout)
    kw = {"object_ids": layout.ids, "size_px": 512, "show_labels": False, "show_grid": False}
    painted = render_view(living, view, backend="pillow", **kw)  # type: ignore[arg-type]
    if not gl_available():  # no offscreen GL here: "auto" is the painter, "mujoco" says what is missing
        assert render_view(living, view, backend="auto", **kw) == painted  # type: ignore[arg-type]
        with pytest.raises(SceneValidationError, match="MUJOCO_GL"):
            render_view(living, view, backend="mujoco", **kw)  # type: ignore[arg-type]
        return
    rendered = render_view(living, view, backend="mujoco", **kw)  # type: ignore[arg-type]
    a, b = _objects_mask(painted), _objects_mask(rendered)
    iou = (a & b).sum() / (a | b).sum()
    assert a.sum() > 1000 and iou > 0.85, iou  # 0.91 here: edges and outlines differ by a pixel
    print(f"objects mask IoU, MuJoCo vs painter: {iou:.3f}")


def test_unit_views_are_1024_pngs_of_every_kind_of_unit(living: Scene) -> None:
    assert living.structure is not None
    for unit in living.structure.units:
        png = unit_view_png(living, UnitLayout.from_scene(living, unit))
        with Image.open(io.BytesIO(png)) as image:
            assert image.size == (1024, 1024) and image.mode == "RGB"

"""Top-down floor plans and general orthographic views drawn with Pillow."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from PIL import Image

from scenemosaic.exceptions import SceneValidationError
from scenemosaic.render import (
    OrthoView,
    PixelMap,
    category_color,
    render_topdown,
    render_view,
    shade,
    topdown_view,
)
from scenemosaic.render._palette import BACKGROUND, DOOR_COLOR, FLOOR_COLOR
from scenemosaic.scene import Pose, Scene

SIZE = 512


def _decode(png: bytes) -> Image.Image:
    image = Image.open(io.BytesIO(png))
    image.load()
    return image


def _pixel(image: Image.Image, pm: PixelMap, xyz: tuple[float, float, float]) -> tuple[int, int, int]:
    x, y = pm.world_to_px(np.array([xyz]))[0]
    value = image.getpixel((math.floor(x), math.floor(y)))
    assert isinstance(value, tuple)
    return (int(value[0]), int(value[1]), int(value[2]))


def _on_table(scene: Scene, u: float, v: float) -> tuple[float, float, float]:
    """World point at local (u, v) fractions of the table's footprint, on its top."""
    table = scene.get("table")
    local = np.array([u * table.size[0], v * table.size[1], table.size[2], 1.0])
    return tuple(float(c) for c in (table.pose.matrix(with_scale=False) @ local)[:3])  # type: ignore[return-value]


def test_png_decodes_with_requested_size(plan_scene: Scene) -> None:
    image = _decode(render_topdown(plan_scene, size_px=SIZE))
    assert image.format == "PNG" and image.size == (SIZE, SIZE) and image.mode == "RGB"


def test_object_footprint_has_its_colour_and_outside_is_background(plan_scene: Scene) -> None:
    image = _decode(render_topdown(plan_scene, size_px=SIZE))
    view = topdown_view(plan_scene)
    pm = PixelMap.for_size(view, SIZE)
    top = plan_scene.get("table").size[2]
    expected = shade(category_color("dining_table"), top / view.depth_range[1])
    # off the label, the arrow and the outline: back-left part of the table top
    assert _pixel(image, pm, _on_table(plan_scene, -0.3, 0.25)) == expected
    cabinet = shade(category_color("cabinet"), 1.8 / view.depth_range[1])
    assert _pixel(image, pm, (3.65, 2.5, 1.8)) == cabinet
    assert cabinet != expected
    assert _pixel(image, pm, (-0.3, 0.25, 0.0)) == BACKGROUND  # outside the walls, between grid lines
    assert _pixel(image, pm, (3.2, 0.4, 0.0)) == FLOOR_COLOR  # empty floor
    assert _pixel(image, pm, (1.0, -0.05, 0.0)) == DOOR_COLOR  # the door in wall_0


def test_render_is_deterministic_and_reflects_the_scene(plan_scene: Scene) -> None:
    a = render_topdown(plan_scene, size_px=SIZE)
    assert a == render_topdown(plan_scene, size_px=SIZE)
    assert a != render_topdown(plan_scene, size_px=SIZE, show_labels=False)
    moved = plan_scene.model_copy(deep=True)
    moved.objects[0].pose = Pose.from_yaw((2.1, 1.5, 0.0), math.radians(30))
    assert a != render_topdown(moved, size_px=SIZE)


def test_view_of_a_subset_of_objects(plan_scene: Scene) -> None:
    view = topdown_view(plan_scene)
    pm = PixelMap.for_size(view, SIZE)
    image = _decode(render_view(plan_scene, view, object_ids=["cabinet"], size_px=SIZE))
    assert _pixel(image, pm, _on_table(plan_scene, -0.3, 0.25)) == FLOOR_COLOR
    assert _pixel(image, pm, (3.65, 2.5, 1.8)) != FLOOR_COLOR
    with pytest.raises(SceneValidationError, match="unknown object ids"):
        render_view(plan_scene, view, object_ids=["nope"], size_px=SIZE)


def test_side_view_seam(plan_scene: Scene) -> None:
    """A front elevation (u = +X, v = +Z, looking along +Y): the cabinet stands 1.8 m tall."""
    view = OrthoView(origin=(0.0, 0.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 0.0, 1.0), extent=(0.0, 4.0, -0.2, 2.8),
                     depth_range=(-3.0, 0.0))  # fmt: skip
    pm = PixelMap.for_size(view, SIZE)
    image = _decode(render_view(plan_scene, view, object_ids=["cabinet"], size_px=SIZE, show_labels=False))
    assert _pixel(image, pm, (3.7, 0.0, 1.2)) != BACKGROUND
    assert _pixel(image, pm, (3.7, 0.0, 2.2)) == BACKGROUND
    assert _pixel(image, pm, (2.9, 0.0, 1.2)) == BACKGROUND  # off the grid lines


def test_bad_view_is_rejected() -> None:
    with pytest.raises(SceneValidationError, match="orthonormal"):
        OrthoView(origin=(0, 0, 0), u=(1, 0, 0), v=(1, 0, 0), extent=(0, 1, 0, 1))
    with pytest.raises(SceneValidationError, match="extent"):
        OrthoView.top_down(1.0, 0.0, 0.0, 1.0)


def test_real_dining_room(dining_scene: Scene) -> None:
    png = render_topdown(dining_scene, size_px=SIZE)
    image = _decode(png)
    assert image.size == (SIZE, SIZE)
    assert png == render_topdown(dining_scene, size_px=SIZE)
    pm = PixelMap.for_size(topdown_view(dining_scene), SIZE)
    colours = {category_color(o.category) for o in dining_scene.objects}
    pixels = np.asarray(image).reshape(-1, 3)
    for obj in dining_scene.objects:  # every object's colour shows somewhere (under some shade)
        base = np.asarray(category_color(obj.category), dtype=np.float64)
        ratio = pixels / base
        shaded = (np.ptp(ratio, axis=1) < 0.02) & (ratio[:, 0] >= 0.5) & (ratio[:, 0] <= 1.01)
        assert shaded.any(), obj.id
    assert len(colours) >= 2
    assert _pixel(image, pm, (*dining_scene.room.floor[0], 0.0)) != BACKGROUND  # floor corner is drawn

"""Issue 26, item 8: plan labels never overlap (a label that cannot sit on its object moves to a
free spot with a leader line), objects whose id says nothing are labelled by category, and a
contact sheet keeps the plans' labels at their size."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageDraw

from scenemosaic.render import ContactSheet, PixelMap, contact_sheet, render_topdown, topdown_view
from scenemosaic.render._view import _draw_labels, _font, object_label
from scenemosaic.scene import AssetRef, Pose, Room, Scene, SceneObject


def _crowded() -> Scene:
    """Twelve small things on one spot of a desk-sized patch: their labels cannot all sit there."""
    objects = [
        SceneObject(
            id=f"thing_{i}",
            category="book",
            asset=AssetRef(kind="box", extents=(0.1, 0.1, 0.05)),
            pose=Pose.from_yaw((1.0 + 0.03 * (i % 4), 1.0 + 0.03 * (i // 4), 0.0), 0.0),
        )
        for i in range(12)
    ]
    return Scene(room=Room.rectangle(0, 0, 3, 2), objects=objects)


def test_labels_never_overlap_and_stay_in_the_picture() -> None:
    scene = _crowded()
    pm = PixelMap.for_size(topdown_view(scene), 512)
    image = Image.new("RGB", (512, 512))
    boxes = _draw_labels(ImageDraw.Draw(image), scene.objects, pm, _font(12))
    assert set(boxes) == {o.id for o in scene.objects}
    for (a, box_a), (b, box_b) in itertools.combinations(boxes.items(), 2):
        apart = box_a[2] <= box_b[0] or box_b[2] <= box_a[0] or box_a[3] <= box_b[1] or box_b[3] <= box_a[1]
        assert apart, (a, b)
    assert all(min(x0, y0) >= 0 and max(x1, y1) <= 512 for x0, y0, x1, y1 in boxes.values())
    assert render_topdown(scene, size_px=512) == render_topdown(scene, size_px=512)  # still deterministic


def test_an_object_whose_id_says_nothing_is_labelled_by_category() -> None:
    def obj(oid: str, category: str) -> SceneObject:
        return SceneObject(id=oid, category=category, asset=AssetRef(kind="box", extents=(0.5, 0.5, 0.5)), pose=Pose.from_yaw((1.0, 1.0, 0.0), 0.0))

    assert object_label(obj("5_2", "garbage_can")) == "garbage can 5_2"
    assert object_label(obj("small_5_9", "toilet_paper")) == "toilet paper small_5_9"
    assert object_label(obj("dining_chair_0", "chair")) == "dining_chair_0"
    assert object_label(obj("bed", "double_bed")) == "bed"


def test_a_contact_sheet_keeps_the_plans_at_their_size(tmp_path: Path) -> None:
    plan = tmp_path / "plan.png"
    plan.write_bytes(render_topdown(_crowded(), size_px=640))
    sheet = contact_sheet([("base", plan), ("variant_1", plan)], tmp_path / "sheet.png")
    with Image.open(sheet) as image, Image.open(plan) as tile:
        assert image.width == 2 * 640
        assert image.crop((0, image.height - 640, 640, image.height)).tobytes() == tile.convert("RGB").tobytes()


def test_a_sheet_built_a_tile_at_a_time_is_the_sheet_made_at_once(tmp_path: Path) -> None:
    plans = []
    for k, size in enumerate((320, 320, 320, 240)):
        plans.append(tmp_path / f"plan_{k}.png")
        plans[-1].write_bytes(render_topdown(_crowded(), size_px=size))
    tiles = [(f"v{k}", p) for k, p in enumerate(plans)]  # the last one smaller: resized to the first's size
    whole = contact_sheet(tiles, tmp_path / "whole.png")
    sheet = ContactSheet(len(tiles))
    for label, path in tiles:
        sheet.add(label, path)
    with pytest.raises(ValueError, match="4 tile"):
        sheet.add("one too many", plans[0])
    assert sheet.save(tmp_path / "pieces.png").read_bytes() == whole.read_bytes()
    short = ContactSheet(2)
    short.add("only", plans[0])
    with pytest.raises(ValueError, match="1 of its 2"):
        short.save(tmp_path / "short.png")


def _first_free_by_loop(
    spots: list[tuple[float, float]],
    label: tuple[float, float, float, float],
    placed: list[tuple[float, float, float, float]],
    size: int,
) -> int | None:
    """The spot search as a plain loop over spots and placed boxes: what the vectorized search must match."""
    cx, cy, hw, hh = label
    for k, (dx, dy) in enumerate(spots):
        box = (cx + dx - hw, cy + dy - hh, cx + dx + hw, cy + dy + hh)
        inside = box[0] >= 0 and box[1] >= 0 and box[2] <= size and box[3] <= size
        free = not any(box[0] < o[2] and o[0] < box[2] and box[1] < o[3] and o[1] < box[3] for o in placed)
        if inside and free:
            return k
    return None


def test_the_label_spot_search_picks_the_spot_a_plain_loop_picks() -> None:
    """Issue 38: the spots are tried all at once; the first free one is the loop's, on boxes that
    touch, overlap and run off the picture."""
    from scenemosaic.render._view import _first_free_spot

    rng = np.random.default_rng(7)
    size = 200
    for _ in range(300):
        placed = [
            (float(x), float(y), float(x + w), float(y + h))
            for x, y, w, h in np.round(rng.uniform([0, 0, 5, 5], [size, size, 60, 30], size=(rng.integers(0, 12), 4)))
        ]
        label = (float(rng.uniform(0, size)), float(rng.uniform(0, size)), float(rng.uniform(4, 40)), float(rng.uniform(4, 15)))
        spots = [(0.0, 0.0), *((float(a), float(b)) for a, b in np.round(rng.uniform(-120, 120, size=(40, 2))))]
        assert _first_free_spot(spots, label, placed, (size, size)) == _first_free_by_loop(spots, label, placed, size)

"""The plan of a whole house: every room, its walls with door gaps, its objects, and its name."""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shapely.geometry import MultiPoint, Point, Polygon
from shapely.ops import unary_union

from scenemosaic.exchange import load_scenes
from scenemosaic.render import PixelMap, category_color, house_view, render_house_plan, room_label
from scenemosaic.render._palette import DOOR_COLOR, INK_COLOR, WALL_COLOR
from scenemosaic.scene import House, Room, Scene

HOUSE_JSON = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_6room.json"
SIZE = 900


@pytest.fixture(scope="module")
def house() -> House:
    return House(id="procthor_6room", rooms=load_scenes(HOUSE_JSON))


def _image(png: bytes) -> np.ndarray:
    image = Image.open(io.BytesIO(png))
    image.load()
    assert image.size == (SIZE, SIZE)
    return np.asarray(image.convert("RGB"))


def _pixel(pixels: np.ndarray, pm: PixelMap, xy: np.ndarray) -> tuple[int, int, int]:
    x, y = pm.world_to_px(np.array([[xy[0], xy[1], 0.0]]))[0]
    r, g, b = pixels[math.floor(y), math.floor(x)]
    return int(r), int(g), int(b)


def test_rooms_are_named_by_their_type_and_id(house: House) -> None:
    names = {s.id: room_label(s) for s in house.rooms}
    assert names["room_8"] == "Kitchen (room_8)"
    assert names["room_9"] == "Living Room (room_9)"
    assert room_label(Scene(id="den", room=Room.rectangle(0, 0, 3, 3))) == "den"


def test_the_plan_shows_doors_walls_and_objects(house: House) -> None:
    png = render_house_plan(house, size_px=SIZE, show_labels=False)  # no object ids over the walls
    assert png == render_house_plan(house, size_px=SIZE, show_labels=False)  # deterministic
    pixels = _image(png)
    pm = PixelMap.for_size(house_view(house), SIZE)
    inner = [d for d in house.doorways() if not d.leads_outside]
    assert len(inner) >= 4
    # where an object (or its outline and arrow) is drawn, the wall under it does not show
    covered = unary_union([MultiPoint(o.corners()[:, :2]).convex_hull.buffer(0.1) for o in house.objects])
    walls_seen = 0
    for door in inner:
        middle = (door.sides[0].centre + door.sides[-1].centre) / 2.0
        assert _pixel(pixels, pm, middle) == DOOR_COLOR, door.id
        # a little past either edge of the door the shared wall stands
        for side in (1.0, -1.0):
            beside = middle + side * door.direction * (door.width / 2.0 + 0.15)
            if covered.contains(Point(beside)) or any(
                d.passage().buffer(0.05).contains(Point(beside)) for d in house.doorways()
            ):
                continue
            assert _pixel(pixels, pm, beside) == WALL_COLOR, door.id
            walls_seen += 1
    assert walls_seen >= 4
    # objects keep their category colours (under some shade): the biggest one shows its hue
    biggest = max(house.objects, key=lambda o: float(o.size[0] * o.size[1]))
    base = np.asarray(category_color(biggest.category), dtype=np.float64)
    w, d, _ = biggest.size
    off_arrow = biggest.pose.matrix(with_scale=False) @ np.array(
        [w / 4.0, d / 4.0, 0.0, 1.0]
    )  # the arrow runs along -y
    seen = np.asarray(_pixel(pixels, pm, off_arrow[:2]), dtype=np.float64)
    assert np.allclose(seen / max(seen.max(), 1.0), base / base.max(), atol=0.06)


def test_each_room_name_is_printed_inside_the_room(house: House) -> None:
    """With no objects, the only ink on a room's floor, well inside its walls, is its name."""
    empty = house.with_rooms([s.model_copy(update={"objects": [], "relations": []}) for s in house.rooms])
    pixels = _image(render_house_plan(empty, size_px=SIZE))
    pm = PixelMap.for_size(house_view(empty), SIZE)
    ink = np.all(np.abs(pixels.astype(np.int64) - np.asarray(INK_COLOR)) <= 40, axis=-1)
    ys, xs = np.nonzero(ink)
    for scene in empty.rooms:
        assert scene.room is not None
        inside = Polygon(scene.room.floor).buffer(-0.15)
        corners = pm.world_to_px(np.array([[x, y, 0.0] for x, y in inside.exterior.coords]))
        outline = Polygon(corners)
        hits = sum(
            outline.contains(Point(float(x) + 0.5, float(y) + 0.5)) for x, y in zip(xs, ys, strict=True)
        )
        assert hits > 40, scene.id

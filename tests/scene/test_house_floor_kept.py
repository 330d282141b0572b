"""A house variant never cuts off floor its base leaves open (issue 54): ``HouseFloor.keeps``, the
test the house composition applies, refuses an arrangement that walls off a strip of a room while
every room stays reachable (which the reachability test alone let through), and the rule of the
floor a variant keeps is one for rooms and houses (``kept_floor_share``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.exchange import load_house
from scenemosaic.scene import AssetRef, HouseFloor, Pose, SceneObject, kept_floor_share

TWO_ROOMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor10k_house3703_2room.json"


@pytest.mark.parametrize(("base", "least"), [(1.0, 0.99), (0.993, 0.99), (0.99, 0.99), (0.96, 0.955)])
def test_the_floor_a_variant_keeps(base: float, least: float) -> None:
    assert kept_floor_share(base) == pytest.approx(least)


def test_a_cabinet_walling_off_a_strip_of_a_room_is_refused_though_every_room_is_reached() -> None:
    house = load_house(TWO_ROOMS)
    floor = HouseFloor(house)
    keeps = floor.keeps(house.rooms)
    assert keeps(house.rooms)
    big = house.rooms[0]  # room_2: its upper part spans x 1.93..5.65, y 1.88..5.65; its doors at y 1.0 and 3.0
    assert big.id == "room_2"
    wall = SceneObject(
        id="long_cabinet",
        category="cabinet",
        asset=AssetRef(kind="procedural", category="cabinet", extents=(3.72, 0.3, 0.9)),
        pose=Pose.from_yaw((3.793, 4.75, 0.0), 0.0),
    )  # across the room from wall to wall, 0.75 m short of its far wall: a strip cut off
    cut = big.model_copy(update={"objects": [*big.objects, wall]})
    arrangement = [cut, *house.rooms[1:]]
    walk = floor.walkable(arrangement)
    assert walk.unreachable_rooms() == []  # what the test before this one looked at: it let this through
    assert floor.walkable(house.rooms).nav == pytest.approx(1.0) and walk.nav < 0.99  # 1.0 -> 0.978
    assert not keeps(arrangement)

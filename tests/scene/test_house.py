"""The house model and its checks: doorways, door zones and blockers, reachability, walls."""

from __future__ import annotations

from pathlib import Path

import pytest
from shapely.geometry import Polygon

from scenemosaic.exchange import load_scenes
from scenemosaic.scene import (
    DOOR_CLEARANCE_DEPTH_M,
    AssetRef,
    House,
    Opening,
    Pose,
    Room,
    Scene,
    SceneObject,
    cut_off_doors,
    door_blockers,
    door_zones,
    house_walkable,
    wall_crossings,
)

HALF = 0.05  # half the shared wall: each floor stops this short of x = 4


def box(oid: str, x: float, y: float, size: tuple[float, float, float], z: float = 0.0, yaw: float = 0.0) -> SceneObject:
    return SceneObject(
        id=oid, category="cabinet", asset=AssetRef(kind="box", extents=size), pose=Pose.from_yaw((x, y, z), yaw)
    )


def two_rooms(a_objects: list[SceneObject] = (), b_objects: list[SceneObject] = ()) -> House:  # type: ignore[assignment]
    """Room a: x in [0, 3.95]; room b: x in [4.05, 8]; y in [0, 3]; a 0.9 m door at y = 1.5 between them."""
    a = Room.rectangle(0.0, 0.0, 4.0 - HALF, 3.0, ceiling_height=2.5).model_copy(update={"id": "a"})
    b = Room.rectangle(4.0 + HALF, 0.0, 8.0, 3.0, ceiling_height=2.5).model_copy(update={"id": "b"})
    a.wall("wall_1").openings = [Opening(kind="door", center=1.5, width=0.9, height=2.0)]  # east, (3.95, 0) -> (3.95, 3)
    b.wall("wall_3").openings = [Opening(kind="door", center=1.5, width=0.9, height=2.0)]  # west, (4.05, 3) -> (4.05, 0)
    return House(rooms=[Scene(id="a", room=a, objects=list(a_objects)), Scene(id="b", room=b, objects=list(b_objects))])


def test_the_two_cuts_of_one_door_are_one_doorway() -> None:
    (door,) = two_rooms().doorways()
    assert set(door.rooms) == {"a", "b"} and not door.leads_outside
    assert door.width == pytest.approx(0.9)
    passage = door.passage()  # the hole through the wall, face to face
    assert passage.bounds == pytest.approx((4.0 - HALF, 1.05, 4.0 + HALF, 1.95))


def test_a_shipped_house_has_its_doors_openings_and_a_door_outside() -> None:
    path = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"
    house = House(rooms=load_scenes(path))
    kinds = sorted((d.kind, d.rooms) for d in house.doorways())
    assert kinds == [
        ("door", ("room_4", "room_5")),
        ("door", ("room_4", "room_7")),
        ("door", ("room_7",)),
        ("opening", ("room_6", "room_7")),
    ]


def test_a_door_zone_is_the_door_wide_and_the_depth_deep_on_each_side() -> None:
    zones = {z.room_id: z.polygon for z in door_zones(two_rooms())}
    assert zones["a"].bounds == pytest.approx((4.0 - HALF - DOOR_CLEARANCE_DEPTH_M, 1.05, 4.0 - HALF, 1.95))
    assert zones["b"].bounds == pytest.approx((4.0 + HALF, 1.05, 4.0 + HALF + DOOR_CLEARANCE_DEPTH_M, 1.95))


def test_a_door_zone_as_deep_as_the_door_is_wide_holds_where_its_leaf_swings() -> None:
    """``depth=None``: the variants' zone (and SceneEval's Opening Clearance box) is the door's width deep."""
    zones = {z.room_id: z.polygon for z in door_zones(two_rooms(), depth=None)}
    assert zones["a"].bounds == pytest.approx((4.0 - HALF - 0.9, 1.05, 4.0 - HALF, 1.95))
    assert zones["b"].bounds == pytest.approx((4.0 + HALF, 1.05, 4.0 + HALF + 0.9, 1.95))


def test_door_blockers_are_what_a_robot_would_walk_into() -> None:
    in_front = box("cabinet", 3.6, 1.5, (0.4, 0.4, 0.8))
    lamp_above = box("lamp", 3.6, 1.2, (0.3, 0.3, 0.2), z=2.2)  # hung above the zone: walked under
    rug = box("rug", 3.5, 1.6, (0.8, 0.6, 0.01))  # thin: walked over
    beside = box("beside", 3.6, 0.4, (0.4, 0.4, 0.8))  # next to the zone, not in it
    blocked = door_blockers(two_rooms([in_front, lamp_above, rug, beside]))
    assert [(b.room_id, b.object_id) for b in blocked] == [("a", "cabinet")]


def test_a_room_behind_a_blocked_door_is_unreachable() -> None:
    open_scene = two_rooms([box("table", 1.5, 1.5, (1.0, 0.8, 0.75))], [box("bed", 6.5, 1.5, (1.4, 2.0, 0.5))])
    walk = house_walkable(open_scene)
    assert walk.unreachable_rooms() == [] and walk.nav == pytest.approx(1.0)
    wardrobe = box("wardrobe", 3.65, 1.5, (0.6, 1.6, 2.0))  # across the doorway on a's side
    closed = house_walkable(two_rooms([wardrobe], [box("bed", 6.5, 1.5, (1.4, 2.0, 0.5))]))
    assert len(closed.unreachable_rooms()) == 1 and closed.nav < 0.7


def test_a_door_whose_zone_is_clear_can_still_be_cut_off() -> None:
    # a long sideboard 0.75 m in front of the door wall closes a pocket around the door
    sideboard = box("sideboard", 4.0 - HALF - 1.1, 1.5, (0.5, 3.0, 0.9))
    house = two_rooms([sideboard])
    assert not door_blockers(house)
    assert cut_off_doors(house.rooms[0]) == [door_zones(house.rooms[0])[0].door_id]
    assert cut_off_doors(house.rooms[1]) == []


def test_wall_crossings_measure_how_far_an_object_reaches_past_its_floor() -> None:
    through = box("through", 3.9, 2.5, (0.4, 0.4, 0.8))  # reaches 0.15 m past x = 3.95
    inside = box("inside", 1.0, 1.0, (0.4, 0.4, 0.8))
    ((room, oid, past),) = wall_crossings(two_rooms([through, inside]))
    assert (room, oid) == ("a", "through") and past == pytest.approx(0.15, abs=1e-6)
    # a footprint clipping an inner corner reaches out between its corners
    l_floor = [(0.0, 0.0), (4.0, 0.0), (4.0, 2.0), (2.0, 2.0), (2.0, 4.0), (0.0, 4.0)]
    corner = Scene(id="l", room=Room.from_polygon(l_floor, room_id="l"), objects=[box("c", 2.0, 2.0, (0.6, 0.6, 0.5), yaw=0.7854)])
    ((_, _, reach),) = wall_crossings(corner)
    assert reach > 0.1
    assert Polygon(l_floor).covers(Polygon([(0.1, 0.1), (1, 0.1), (1, 1)]))

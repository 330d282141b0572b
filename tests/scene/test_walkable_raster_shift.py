"""Reachability does not hang on where the raster's cells fall: a house moved by part of a cell
(the house raster's cells lie on the world's 5 cm grid) gets the same rooms reached, the same door
blockers and the same house NAV, a door still joins its rooms when its floor edges land exactly on
cell centres, and a blocked door or a wall without a door still parts them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenemosaic.exchange import load_house
from scenemosaic.scene import (
    HOUSE_CELL_M,
    AssetRef,
    House,
    Opening,
    Pose,
    Room,
    Scene,
    SceneObject,
    door_blockers,
    house_walkable,
)

DATA = Path(__file__).resolve().parents[2] / "data" / "houses"
SHIPPED = sorted(p for d in ("procthor", "held_out") for p in (DATA / d).glob("*.json") if p.name != "SOURCES.json")
OFFSETS = [(0.0, 0.0), (0.25, 0.75), (0.5, 0.5), (0.75, 0.25)]
"""Shifts in cells: every quarter of a cell along each axis, half a cell on both at once."""


def shifted(house: House, dx: float, dy: float) -> House:
    """The whole house moved by (dx, dy) metres: floors, walls (their openings with them), objects."""
    rooms = []
    for s in house.rooms:
        assert s.room is not None
        walls = [
            w.model_copy(update={"start": (w.start[0] + dx, w.start[1] + dy), "end": (w.end[0] + dx, w.end[1] + dy)})
            for w in s.room.walls
        ]
        room = s.room.model_copy(update={"floor": [(x + dx, y + dy) for x, y in s.room.floor], "walls": walls})
        objects = [
            o.model_copy(update={"pose": o.pose.model_copy(update={"position": (o.pose.position[0] + dx, o.pose.position[1] + dy, o.pose.position[2])})})
            for o in s.objects
        ]
        rooms.append(s.model_copy(update={"room": room, "objects": objects}))
    return house.with_rooms(rooms)


def box(oid: str, x: float, y: float, size: tuple[float, float, float]) -> SceneObject:
    return SceneObject(id=oid, category="cabinet", asset=AssetRef(kind="box", extents=size), pose=Pose.from_yaw((x, y, 0.0), 0.0))


def two_rooms(*, gap: float = 0.1, door: float | None = 1.04, a_objects: tuple[SceneObject, ...] = ()) -> House:
    """Room a: x in [0, 4 - gap/2]; room b: x in [4 + gap/2, 8]; y in [0, 3]; a door of width
    ``door`` (none: a plain wall) at y = 1.5 in the wall between them, ``gap`` thick (0: the floors touch)."""
    a = Room.rectangle(0.0, 0.0, 4.0 - gap / 2, 3.0, ceiling_height=2.5).model_copy(update={"id": "a"})
    b = Room.rectangle(4.0 + gap / 2, 0.0, 8.0, 3.0, ceiling_height=2.5).model_copy(update={"id": "b"})
    if door is not None:
        a.wall("wall_1").openings = [Opening(kind="door", center=1.5, width=door, height=2.0)]
        b.wall("wall_3").openings = [Opening(kind="door", center=1.5, width=door, height=2.0)]
    return House(rooms=[Scene(id="a", room=a, objects=list(a_objects)), Scene(id="b", room=b)])


def figures(house: House) -> tuple[float, list[str], list[str]]:
    walk = house_walkable(house)
    return walk.nav, walk.unreachable_rooms(), sorted(f"{b.object_id} ({b.door})" for b in door_blockers(house))


def pieces_per_room(house: House) -> dict[str, set[int]]:
    walk = house_walkable(house)
    return {rid: set(np.unique(walk.walkable.labels[cells & walk.walkable.free]).tolist()) for rid, cells in walk.room_cells.items()}


def test_a_door_whose_floor_edges_lie_on_cell_centres_joins_its_rooms() -> None:
    # the bug: half a cell over, both floor edges of the wall lie on a column of cell centres, which
    # counted as neither floor nor passage, and room b was "unreachable" behind a 1.04 m door
    house = shifted(two_rooms(), HOUSE_CELL_M / 2, 0.0)
    walk = house_walkable(house)
    assert np.isclose(walk.raster.xs, 4.0 - 0.05 + HOUSE_CELL_M / 2).any()
    assert np.isclose(walk.raster.xs, 4.0 + 0.05 + HOUSE_CELL_M / 2).any()
    assert walk.unreachable_rooms() == [] and walk.nav == pytest.approx(1.0)


@pytest.mark.parametrize("gap", [0.1, 0.0], ids=["wall", "touching-floors"])
def test_a_door_joins_and_a_wall_parts_two_rooms_at_every_offset(gap: float) -> None:
    for fx in (0.0, 0.25, 0.5, 0.75):
        for fy in (0.0, 0.5):
            d = (fx * HOUSE_CELL_M, fy * HOUSE_CELL_M)
            walk = house_walkable(shifted(two_rooms(gap=gap), *d))
            assert walk.unreachable_rooms() == [] and walk.nav == pytest.approx(1.0), d
            apart = pieces_per_room(shifted(two_rooms(gap=gap, door=None), *d))
            assert apart["a"].isdisjoint(apart["b"]), d  # no leak through the wall
            assert len(house_walkable(shifted(two_rooms(gap=gap, door=None), *d)).unreachable_rooms()) == 1, d


def test_the_robot_still_needs_its_width_at_every_offset() -> None:
    # a 0.3 m door is narrower than the robot (0.4 m across): the rooms stay apart, wherever the cells fall
    for fx in (0.0, 0.25, 0.5, 0.75):
        walk = house_walkable(shifted(two_rooms(door=0.3), fx * HOUSE_CELL_M, fx * HOUSE_CELL_M))
        assert len(walk.unreachable_rooms()) == 1, fx


def test_a_blocked_door_stays_blocked_at_every_offset() -> None:
    wardrobe = box("wardrobe", 3.65, 1.5, (0.6, 1.6, 2.0))  # across the doorway on a's side
    for fx in (0.0, 0.25, 0.5, 0.75):
        for fy in (0.0, 0.5):
            nav, unreachable, blockers = figures(shifted(two_rooms(a_objects=(wardrobe,)), fx * HOUSE_CELL_M, fy * HOUSE_CELL_M))
            assert len(unreachable) == 1 and nav < 0.7 and blockers == ["wardrobe (a:wall_1:0)"], (fx, fy)


@settings(max_examples=30, deadline=None)
@given(
    dx=st.floats(0.0, HOUSE_CELL_M), dy=st.floats(0.0, HOUSE_CELL_M),
    door=st.floats(0.6, 1.2), gap=st.sampled_from([0.0, 0.1]),
)  # fmt: skip
def test_any_offset_any_door(dx: float, dy: float, door: float, gap: float) -> None:
    assert house_walkable(shifted(two_rooms(gap=gap, door=door), dx, dy)).unreachable_rooms() == []
    apart = pieces_per_room(shifted(two_rooms(gap=gap, door=None), dx, dy))
    assert apart["a"].isdisjoint(apart["b"])


def _edges_on_centres(house: House) -> tuple[float, float]:
    """The shift that puts a doorway's floor edge on a column of cell centres, and another's
    (running the other way, where there is one) on a row: the offset that hid doors before."""
    shift = [0.0, 0.0]
    for d in house.doorways():
        axis = int(np.argmax(np.abs(d.normal)))
        if d.leads_outside or shift[axis]:
            continue
        edge = float(d.sides[0].centre[axis])
        shift[axis] = (np.floor(edge / HOUSE_CELL_M) + 0.5) * HOUSE_CELL_M - edge
    return shift[0], shift[1]


@pytest.mark.parametrize("path", SHIPPED, ids=[f"{p.parent.name}/{p.stem}" for p in SHIPPED])
def test_a_shipped_house_gives_one_answer_at_every_offset(path: Path) -> None:
    house = load_house(path)
    nav, unreachable, blockers = figures(house)
    cases = [(fx * HOUSE_CELL_M, fy * HOUSE_CELL_M) for fx, fy in OFFSETS[1:]] + [_edges_on_centres(house)]
    for d in cases:
        n, u, b = figures(shifted(house, *d))
        assert (u, b) == (unreachable, blockers) and abs(n - nav) <= 0.01, d
    # every door and open stretch bricked up: no walkable piece spans two rooms
    walled = house.with_rooms(
        [s.model_copy(update={"room": s.room.model_copy(update={"walls": [w.model_copy(update={"openings": []}) for w in s.room.walls]})}) for s in house.rooms if s.room]
    )
    per_room = pieces_per_room(shifted(walled, *cases[-1]))
    for a, b in [(a, b) for a in per_room for b in per_room if a < b]:
        assert per_room[a].isdisjoint(per_room[b]), (a, b)


def test_one_house_floor_judges_many_arrangements_as_house_walkable_does() -> None:
    """``HouseFloor`` (built once, each room arrangement rasterized once) answers as
    ``house_walkable`` of the house with those rooms, for the base and for a room whose
    wardrobe now stands across the door, in either order and asked again."""
    from scenemosaic.scene import HouseFloor

    house = two_rooms()
    wardrobe = box("wardrobe", 3.65, 1.5, (0.6, 1.6, 2.0))
    blocked_a = house.rooms[0].model_copy(update={"objects": [wardrobe]})
    floor = HouseFloor(house)
    for rooms in ([house.rooms[0], house.rooms[1]], [blocked_a, house.rooms[1]], [house.rooms[0], house.rooms[1]], [blocked_a, house.rooms[1]]):
        ours = floor.walkable(rooms)
        theirs = house_walkable(house.with_rooms(rooms))
        assert np.array_equal(ours.walkable.labels, theirs.walkable.labels) and ours.unreachable_rooms() == theirs.unreachable_rooms()
    assert floor.walkable([blocked_a, house.rooms[1]]).unreachable_rooms() and not floor.walkable(house.rooms).unreachable_rooms()

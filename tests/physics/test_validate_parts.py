"""Validation simulates the world as it is delivered, room doors hung and parts where the open state
puts them, and says which parts do not stay there (issue 53: a lid delivered half open fell shut
under its own weight, a leaf hung inside a wall swung, and the run said it rests)."""

from __future__ import annotations

import math

import pytest

from scenemosaic.assets import OPEN_STATE_KEY, object_articulation, opening
from scenemosaic.physics import validate_scene
from scenemosaic.scene import AssetRef, Opening, Pose, Relation, Room, Scene, SceneObject

TOILET = "toilet"


def _bathroom(lid: float | None = None) -> Scene:
    """A 3 x 2.5 m room with a door in its south wall and a toilet against its north wall, its lid
    delivered at ``lid`` radians (shut when None)."""
    room = Room.rectangle(0, 0, 3.0, 2.5)
    south = room.walls[0].model_copy(update={"openings": [Opening(kind="door", center=0.8, width=0.8, height=2.0)]})
    room = room.model_copy(update={"walls": [south, *room.walls[1:]]})
    toilet = SceneObject(
        id=TOILET, category="toilet", asset=AssetRef(kind="procedural", extents=(0.4, 0.7, 0.8)),
        pose=Pose.from_yaw((2.0, 2.5 - 0.36, 0.0), 0.0),
    )  # fmt: skip
    metadata = {OPEN_STATE_KEY: {"parts": {TOILET: {"lid": lid}}}} if lid is not None else {}
    return Scene(id="bath", room=room, objects=[toilet], relations=[Relation(kind="attach", child=TOILET, parent="floor")], metadata=metadata)


def test_a_lid_left_half_open_is_named_as_moved() -> None:
    report = validate_scene(_bathroom(lid=math.radians(45.0)))
    assert f"{TOILET}/lid" in report.parts_moved and not report.ok


def test_a_shut_or_fully_open_lid_and_the_hung_door_stay_where_they_are_delivered() -> None:
    upper = object_articulation(_bathroom().objects[0])[0].limits[1]
    for lid in (None, upper):
        report = validate_scene(_bathroom(lid=lid))
        assert report.parts_moved == {}, report.parts_moved
        assert report.ok


def test_random_opens_a_lid_shut_or_to_its_stop_and_a_door_anywhere() -> None:
    """A lid's weight swings it from anywhere between: ``random`` draws it shut or at its limit."""
    lid = object_articulation(_bathroom().objects[0])[0]
    assert lid.level
    lids = {opening(lid, "random", seed=s, key="t") for s in range(40)}
    assert lids == {0.0, lid.limits[1]}
    door = SceneObject(id="w", category="wardrobe", asset=AssetRef(kind="procedural", extents=(1.0, 0.6, 2.0)), pose=Pose.from_yaw((0.0, 0.0, 0.0), 0.0))
    leaf = object_articulation(door)[0]
    assert not leaf.level
    doors = {round(opening(leaf, "random", seed=s, key="w"), 6) for s in range(40)}
    assert len(doors) > 30 and all(0.0 <= v <= leaf.limits[1] for v in doors)
    assert any(0.0 < v < leaf.limits[1] for v in doors)


@pytest.mark.parametrize("state", ["closed", "open"])
def test_a_room_door_is_in_the_settled_world(state: str) -> None:
    """The door is hung in what validation settles (its leaves among the parts it watches): pushed
    out of its delivered pose by a cabinet standing where it opens, it is named."""
    scene = _bathroom()
    blocker = SceneObject(
        id="cabinet", category="cabinet", asset=AssetRef(kind="procedural", extents=(0.6, 0.4, 1.0)),
        pose=Pose.from_yaw((0.8, 0.45, 0.0), 0.0), sim={"mass_kg": 200.0},
    )  # fmt: skip
    scene = scene.model_copy(update={
        "objects": [*scene.objects, blocker],
        "relations": [*scene.relations, Relation(kind="attach", child="cabinet", parent="floor")],
        "metadata": {OPEN_STATE_KEY: {"state": state, "parts": {"room_door_0": {"leaf": math.radians(80.0)}}}},
    })  # fmt: skip
    report = validate_scene(scene)
    assert "room_door_0/leaf" in report.parts_moved, report.parts_moved

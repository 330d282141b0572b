"""The door clearance repair: what stands in front of a door, or closes the way to it, moves."""

from __future__ import annotations

import pytest

from scenemosaic.physics import check_collisions, clear_doors, object_shape
from scenemosaic.scene import AssetRef, Opening, Pose, Room, Scene, SceneObject, cut_off_doors, door_blockers


def box(oid: str, x: float, y: float, size: tuple[float, float, float], category: str = "cabinet") -> SceneObject:
    return SceneObject(id=oid, category=category, asset=AssetRef(kind="box", extents=size), pose=Pose.from_yaw((x, y, 0.0), 0.0))


def room_with_door(*objects: SceneObject) -> Scene:
    """A 4 x 3 m room with a 0.9 m door in its east wall at y = 1.5."""
    room = Room.rectangle(0.0, 0.0, 4.0, 3.0, ceiling_height=2.5)
    room.wall("wall_1").openings = [Opening(kind="door", center=1.5, width=0.9, height=2.0)]
    return Scene(id="r", room=room, objects=list(objects))


def shapes(scene: Scene) -> dict:
    return {o.id: object_shape(o, None) for o in scene.objects}


def test_a_room_without_doors_comes_back_as_it_was() -> None:
    scene = Scene(id="r", room=Room.rectangle(0, 0, 4, 3), objects=[box("c", 3.7, 1.5, (0.5, 0.5, 0.8))])
    repaired, repair = clear_doors(scene, shapes(scene))
    assert repaired is scene and not repair.moved and not repair.stuck


def test_furniture_in_front_of_a_door_moves_out_of_its_zone_without_a_collision() -> None:
    scene = room_with_door(box("cabinet", 3.6, 1.5, (0.6, 0.5, 0.9)), box("table", 2.4, 1.5, (0.9, 0.9, 0.75)))
    assert [b.object_id for b in door_blockers(scene)] == ["cabinet"]
    repaired, repair = clear_doors(scene, shapes(scene))
    assert set(repair.moved) == {"cabinet"} and not repair.stuck and not repair.cut_off
    assert not door_blockers(repaired)
    assert not check_collisions(repaired).pairs
    assert repaired.get("table").pose == scene.get("table").pose  # what was not in the way stays
    assert any(n.startswith("doors: moved cabinet") for n in repaired.provenance.notes)
    assert scene.get("cabinet").pose.position == pytest.approx((3.6, 1.5, 0.0))  # the input is kept


def test_a_piece_that_closes_the_way_to_a_clear_door_moves_away_from_it() -> None:
    # a bench 0.8 m in front of the door wall and two stools at its ends close a pocket around
    # the door; nothing stands in the 0.6 m zone itself
    scene = room_with_door(
        box("bench", 3.0, 1.5, (0.4, 1.6, 0.45)),
        box("stool_a", 3.55, 0.45, (0.35, 0.35, 0.45), category="stool"),
        box("stool_b", 3.55, 2.55, (0.35, 0.35, 0.45), category="stool"),
    )
    assert not door_blockers(scene) and cut_off_doors(scene)
    repaired, repair = clear_doors(scene, shapes(scene))
    assert not cut_off_doors(repaired) and not repair.cut_off
    assert repair.moved and not check_collisions(repaired).pairs


def test_a_picture_hung_in_a_doors_way_slides_along_its_wall() -> None:
    """A picture hung low on the door's wall, half over the door's span, slides along the wall
    (not onto the floor) until it clears the door's zone and the opening; the cabinet stays."""
    from scenemosaic.scene import Relation

    picture = SceneObject(
        id="picture", category="painting", asset=AssetRef(kind="box", extents=(0.03, 0.6, 0.5)),
        pose=Pose.from_yaw((3.985, 2.0, 1.2), 0.0),
    )  # fmt: skip
    scene = room_with_door(picture, box("cabinet", 1.0, 2.6, (0.6, 0.5, 0.9)))
    scene = scene.model_copy(update={"relations": [Relation(kind="attach", child="picture", parent="wall_1")]})
    assert [b.object_id for b in door_blockers(scene)] == ["picture"]
    repaired, repair = clear_doors(scene, shapes(scene))
    assert set(repair.moved) == {"picture"} and not repair.stuck
    x, y, z = repaired.get("picture").pose.position
    assert (x, z) == pytest.approx((3.985, 1.2)) and y - 0.3 >= 1.5 + 0.45  # on its wall, past the door's span
    assert y + 0.3 <= 3.0 and not door_blockers(repaired)
    assert repaired.get("cabinet").pose == scene.get("cabinet").pose


def test_a_picture_too_wide_to_slide_clear_of_a_door_is_rehung_on_another_wall() -> None:
    """A 2.4 m picture hung low across the door of a 3 m wall fits on neither side of the door:
    it is re-hung on another wall of the room, as high and as far from it, facing into the room,
    its support relation naming that wall, and no door is blocked."""
    import numpy as np

    from scenemosaic.scene import Relation

    picture = SceneObject(
        id="picture", category="painting", asset=AssetRef(kind="box", extents=(0.03, 2.4, 0.5)),
        pose=Pose.from_yaw((3.985, 1.5, 1.2), 0.0),
    )  # fmt: skip
    scene = room_with_door(picture)
    scene = scene.model_copy(update={"relations": [Relation(kind="attach", child="picture", parent="wall_1")]})
    assert [b.object_id for b in door_blockers(scene)] == ["picture"]
    repaired, repair = clear_doors(scene, shapes(scene))
    assert set(repair.moved) == {"picture"} and not repair.stuck and not door_blockers(repaired)
    assert repaired.room is not None
    rel = repaired.support_of("picture")
    assert rel is not None and rel.parent != "wall_1"
    wall = repaired.room.wall(rel.parent)
    hung = repaired.get("picture")
    assert hung.pose.position[2] == pytest.approx(1.2)
    assert abs(wall.gap(hung.corners())) < 0.01  # flush against the new wall, on the room's side
    along = (hung.corners()[:, :2] - np.asarray(wall.start)) @ np.asarray(wall.direction)
    assert along.max() - along.min() == pytest.approx(2.4, abs=1e-6)  # lies along it, turned with it
    assert along.min() >= -1e-6 and along.max() <= wall.length + 1e-6
    assert not check_collisions(repaired).pairs

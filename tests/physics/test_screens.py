"""A TV hung on the wall behind a bed's head moves to the wall the bed faces (``physics.rehang_screens``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenemosaic.physics import object_shape, rehang_screens
from scenemosaic.scene import (
    AssetRef,
    Opening,
    Pose,
    Relation,
    Room,
    Scene,
    SceneObject,
    front_vector,
    on_backing_wall,
)


def _wall(room: Room, normal: tuple[float, float]) -> str:
    return next(w.id for w in room.walls if np.allclose(w.inward_normal, normal, atol=1e-9))


def _bedroom(window_on_east: bool = False) -> Scene:
    """A 4 x 3 m room: a bed with its head on the west wall, facing east; a TV above its head."""
    room = Room.rectangle(0.0, 0.0, 4.0, 3.0, ceiling_height=2.6)
    west, east = _wall(room, (1.0, 0.0)), _wall(room, (-1.0, 0.0))
    if window_on_east:  # a window where the TV would go: it must find another place
        room.wall(east).openings = [Opening(kind="window", center=1.5, width=2.8, bottom=0.5, height=1.8)]
    bed = SceneObject(id="bed", category="bed", asset=AssetRef(kind="box", extents=(1.6, 2.0, 0.5)), pose=Pose.from_yaw((1.02, 1.5, 0.0), math.pi / 2))
    tv = SceneObject(id="tv", category="television", asset=AssetRef(kind="box", extents=(1.0, 0.05, 0.6)), pose=Pose.from_yaw((0.03, 1.5, 1.2), math.pi / 2))
    return Scene(id="r", room=room, objects=[bed, tv], relations=[Relation(kind="attach", child="tv", parent=west), Relation(kind="attach", child="bed", parent="floor")])


def _shapes(scene: Scene) -> dict:
    return {o.id: object_shape(o, None) for o in scene.objects}


def test_the_tv_behind_the_beds_head_moves_to_the_wall_the_bed_faces() -> None:
    scene = _bedroom()
    assert on_backing_wall(scene, "tv") == "bed"
    fixed, moved, stuck = rehang_screens(scene, _shapes(scene))
    assert scene.room is not None
    east = _wall(scene.room, (-1.0, 0.0))
    assert moved == {"tv": east} and not stuck
    tv = fixed.get("tv")
    x, y, z = tv.pose.position
    assert x == pytest.approx(4.0 - 0.03) and y == pytest.approx(1.5) and z == pytest.approx(1.2)  # across from the bed, same height
    assert np.allclose(front_vector(tv.pose.quaternion)[:2], (-1.0, 0.0), atol=1e-9)  # facing the bed
    rel = fixed.support_of("tv")
    assert rel is not None and rel.parent == east and on_backing_wall(fixed, "tv") is None
    assert scene.get("tv").pose.position == pytest.approx((0.03, 1.5, 1.2))  # the input is kept
    assert any(n.startswith("screens: moved tv") for n in fixed.provenance.notes) and not scene.provenance.notes


def test_a_window_sends_the_tv_to_another_wall_never_back_behind_the_bed() -> None:
    scene = _bedroom(window_on_east=True)
    fixed, moved, stuck = rehang_screens(scene, _shapes(scene))
    assert scene.room is not None and not stuck
    assert moved["tv"] not in (_wall(scene.room, (-1.0, 0.0)), _wall(scene.room, (1.0, 0.0)))
    assert on_backing_wall(fixed, "tv") is None

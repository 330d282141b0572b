"""Fixtures for the render tests: a small hand-built scene and one real 3D-FRONT room."""

from __future__ import annotations

import math

import pytest

from scenemosaic.scene import AssetRef, Opening, Pose, Room, Scene, SceneObject


@pytest.fixture()
def plan_scene() -> Scene:
    """A 4 x 3 m room with a door on wall_0, a rotated box table and a box cabinet on the floor."""
    room = Room.rectangle(0.0, 0.0, 4.0, 3.0, ceiling_height=2.7)
    room.walls[0].openings = [Opening(kind="door", center=1.0, width=0.9, height=2.1)]
    objects = [
        SceneObject(id="table", category="dining_table", asset=AssetRef(kind="box", extents=(1.4, 0.8, 0.75)),
                    pose=Pose.from_yaw((2.0, 1.5, 0.0), math.radians(30))),
        SceneObject(id="cabinet", category="cabinet", asset=AssetRef(kind="box", extents=(0.6, 0.4, 1.8)),
                    pose=Pose.from_yaw((3.5, 2.6, 0.0), math.pi)),
    ]  # fmt: skip
    return Scene(id="plan", room=room, objects=objects)

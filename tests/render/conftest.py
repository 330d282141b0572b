"""Fixtures for the render tests: a small hand-built scene and one real 3D-FRONT room."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from scenemosaic.scene import AssetRef, Opening, Pose, Room, Scene, SceneObject

PHYSCENE_DINING = (
    Path(__file__).resolve().parents[2].parent
    / "shared/data/layouts/physcene/DiningRoom-19325_diningroom.json"
)


@pytest.fixture(scope="session")
def dining_scene() -> Scene:
    """The real PhyScene dining room, loaded by a minimal stand-in for ``load_scene``.

    Half extents, Y-up: (x, y, z) -> (x, -z, y); theta about +Y is yaw about +Z; position is
    the bottom centre. Room: the objects' XY bounds plus a 0.5 m margin.
    """
    data = json.loads(PHYSCENE_DINING.read_text())
    objects = []
    for group in data["ThreedFront"].values():
        for item in group:
            sx, sy, sz = item["size"]
            px, py, pz = item["position"]
            objects.append(
                SceneObject(
                    id=f"{item['label']}_{len(objects)}",
                    category=item["label"],
                    asset=AssetRef(
                        kind="procedural", category=item["label"], extents=(2 * sx, 2 * sz, 2 * sy)
                    ),
                    pose=Pose.from_yaw((px, -pz, py), item["theta"]),
                )
            )
    xs = [c for o in objects for c in o.footprint()[:, 0]]
    ys = [c for o in objects for c in o.footprint()[:, 1]]
    room = Room.rectangle(min(xs) - 0.5, min(ys) - 0.5, max(xs) + 0.5, max(ys) + 0.5)
    return Scene(id="dining", room=room, objects=objects)


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

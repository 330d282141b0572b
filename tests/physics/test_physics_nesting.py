"""Furniture standing inside another piece's box is reported (the hull check misses it with legged stand-ins)."""

from __future__ import annotations

from scenemosaic.physics._checks import nested_furniture
from scenemosaic.scene import FLOOR, AssetRef, Pose, Relation, Room, Scene, SceneObject


def _obj(oid: str, category: str, extents: tuple[float, float, float], xy: tuple[float, float]) -> SceneObject:
    return SceneObject(
        id=oid,
        category=category,
        asset=AssetRef(kind="procedural", category=category, extents=extents),
        pose=Pose.from_yaw((xy[0], xy[1], 0.0), 0.0),
    )


def _scene(*objs: SceneObject) -> Scene:
    return Scene(
        id="n",
        room=Room.rectangle(0, 0, 5, 5, ceiling_height=2.6),
        objects=list(objs),
        relations=[Relation(kind="attach", child=o.id, parent=FLOOR) for o in objs],
    )


def test_a_tv_stand_under_a_dressing_table_is_reported() -> None:
    scene = _scene(_obj("table", "dressing_table", (1.0, 0.5, 0.8), (2, 2)), _obj("stand", "tv_stand", (0.8, 0.4, 0.5), (2.1, 2.0)))
    assert nested_furniture(scene) == ["table ~ stand"]


def test_a_chair_under_a_table_and_a_table_in_an_l_sofa_are_normal() -> None:
    tucked = _scene(_obj("table", "dining_table", (1.4, 0.8, 0.75), (2, 2)), _obj("chair", "dining_chair", (0.45, 0.5, 0.9), (2, 2.3)))
    assert nested_furniture(tucked) == []
    corner = _scene(_obj("sofa", "l_shaped_sofa", (2.5, 2.0, 0.8), (2, 2)), _obj("side", "corner_side_table", (0.5, 0.5, 0.5), (2.8, 2.5)))
    assert nested_furniture(corner) == []
    apart = _scene(_obj("a", "dresser", (1.0, 0.5, 0.8), (1, 1)), _obj("b", "tv_stand", (1.0, 0.5, 0.5), (3, 3)))
    assert nested_furniture(apart) == []

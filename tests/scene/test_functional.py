"""Functional relations read from the geometry, checked in variants, and followed across units."""

from __future__ import annotations

import math

from scenemosaic.exchange import load_scene
from scenemosaic.scene import (
    Pose,
    Scene,
    follow_leaders,
    functional_holds,
    functional_relations,
    quat_from_yaw,
    with_world_poses,
)
from tests.conftest import PHYSCENE_DIR


def _moved(scene: Scene, oid: str, dx: float, dy: float, turn_deg: float = 0.0) -> Scene:
    o = scene.get(oid)
    x, y, z = o.pose.position
    yaw = o.pose.yaw + math.radians(turn_deg)
    return with_world_poses(scene, {oid: Pose(position=(x + dx, y + dy, z), quaternion=quat_from_yaw(yaw), scale=o.pose.scale)})


def test_a_pendant_over_the_dining_table_is_found_and_follows_it() -> None:
    scene = load_scene(PHYSCENE_DIR / "LivingDiningRoom-124277_livingroom.json")
    rels = functional_relations(scene)
    over = [r for r in rels if r.kind == "over" and r.leader == "dining_table_0"]
    assert [r.subject for r in over] == ["pendant_lamp_0"]
    moved = _moved(scene, "dining_table_0", 1.2, -0.9, 90.0)
    assert not functional_holds(moved, over[0]), "moving the table away leaves the lamp over empty floor"
    followed = follow_leaders(scene, moved, over)
    assert followed is not None and functional_holds(followed, over[0])
    lamp0, lamp1 = scene.get("pendant_lamp_0"), followed.get("pendant_lamp_0")
    assert lamp1.pose.position[2] == lamp0.pose.position[2], "a hanging lamp keeps its height"
    table = followed.get("dining_table_0")
    before = math.dist(lamp0.pose.position[:2], scene.get("dining_table_0").pose.position[:2])
    after = math.dist(lamp1.pose.position[:2], table.pose.position[:2])
    assert abs(before - after) < 1e-6, "the lamp keeps its offset from the table's centre"


def test_a_follower_that_would_leave_the_room_makes_the_variant_unfollowable() -> None:
    scene = load_scene(PHYSCENE_DIR / "DiningRoom-19325_diningroom.json")
    over = [r for r in functional_relations(scene) if r.kind == "over"]
    assert follow_leaders(scene, _moved(scene, "dining_table_0", 40.0, 0.0), over) is None


def test_seats_face_their_table_and_stop_when_turned_away() -> None:
    scene = load_scene(PHYSCENE_DIR / "LivingDiningRoom-124277_livingroom.json")
    faces = {(r.subject, r.leader): r for r in functional_relations(scene) if r.kind == "faces"}
    rel = faces[("dining_chair_0", "dining_table_0")]
    assert functional_holds(scene, rel)
    assert not functional_holds(_moved(scene, "dining_chair_0", 0.0, 0.0, 180.0), rel)


def test_nightstands_beside_and_flanking_the_bed() -> None:
    scene = load_scene(PHYSCENE_DIR / "Bedroom-11659_bedroom.json")
    rels = functional_relations(scene)
    kinds = {(r.kind, r.subject) for r in rels}
    assert {("beside", "nightstand_0"), ("beside", "nightstand_1"), ("flanks", "double_bed_0")} <= kinds
    flanks = next(r for r in rels if r.kind == "flanks")
    stand = flanks.group[0]
    bed = scene.get("double_bed_0")
    # the nightstand carried to the bed's foot is no longer beside its head: the bed is not flanked
    away = _moved(scene, stand, *(2.0 * c for c in _front(bed)))
    assert not functional_holds(away, flanks)


def _front(obj: object) -> tuple[float, float]:
    from scenemosaic.scene import front_vector

    f = front_vector(obj.pose.quaternion)  # type: ignore[attr-defined]
    return float(f[0]), float(f[1])

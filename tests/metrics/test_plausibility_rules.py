"""The plausibility figures (``metrics.plausibility``) and the furniture moves of a house's variants
(``metrics.moved_furniture``), on rooms of shipped houses and edits of them that break a rule."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.metrics import PLAUSIBILITY_RULES, furniture, moved_furniture, plausibility, scene_metrics
from scenemosaic.scene import Pose, Scene, front_vector, quat_from_yaw, quat_multiply, with_world_poses

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"


async def _room(house: str, room: str, out: Path) -> Scene:
    scene = (await agenerate(HOUSES / house, out, GenerateConfig(evolve=False, room=room))).scene
    assert isinstance(scene, Scene)
    return scene


def _turned(scene: Scene, oid: str, degrees: float) -> Scene:
    o = scene.get(oid)
    q = quat_multiply(quat_from_yaw(math.radians(degrees)), o.pose.quaternion)
    return with_world_poses(scene, {oid: o.pose.model_copy(update={"quaternion": q})})


async def test_a_tv_turned_on_its_stand_and_one_behind_the_sofa_are_caught(tmp_path: Path) -> None:
    scene = await _room("procthor10k_train1_10room.json", "room|3", tmp_path)  # a living room: sofa, TV on a stand
    tv = next(o for o in scene.objects if o.category == "television")
    figures = plausibility(scene)
    assert set(figures) == set(PLAUSIBILITY_RULES)
    assert figures["tv_faces_stand"] == 1.0 and figures["tv_not_behind_sofa"] == 1.0
    assert plausibility(_turned(scene, tv.id, 180.0))["tv_faces_stand"] == 0.0
    sofa = next(o for o in scene.objects if o.category == "sofa")
    front = front_vector(sofa.pose.quaternion)[:2]
    back = np.asarray(sofa.pose.position[:2]) - front / np.linalg.norm(front) * 0.9
    behind = with_world_poses(scene, {tv.id: Pose(position=(float(back[0]), float(back[1]), tv.pose.position[2]), quaternion=tv.pose.quaternion, scale=tv.pose.scale)})
    assert plausibility(behind)["tv_not_behind_sofa"] < 1.0
    assert scene_metrics(behind)["PLAUS"] < 1.0 and scene_metrics(scene)["PLAUS"] == pytest.approx(min(figures.values()))


async def test_a_tv_on_the_headboard_wall_is_caught(tmp_path: Path) -> None:
    """The bedroom's TV hangs on the wall beside the bed's side; re-hung on the wall the bed's head
    backs onto, behind the bed, it breaks the rule."""
    scene = await _room("procthor_4room.json", "room|4", tmp_path)
    assert scene.room is not None and plausibility(scene)["tv_off_headboard"] == 1.0
    tv, bed = scene.get("4_3"), scene.get("4_1_0")
    old = scene.support_of(tv.id)
    assert old is not None
    src = scene.room.wall(old.parent)
    dst = next(w for w in scene.room.walls if w.id != src.id and -0.02 <= w.gap(bed.corners()) <= 0.3 and float(np.dot(w.inward_normal, front_vector(bed.pose.quaternion)[:2])) > 0.8)
    depth = float((np.asarray(tv.pose.position[:2]) - np.asarray(src.start)) @ src.inward_normal)
    along = float((np.asarray(bed.pose.position[:2]) - np.asarray(dst.start)) @ dst.direction)
    xy = np.asarray(dst.start) + dst.direction * along + dst.inward_normal * depth
    spin = math.atan2(dst.inward_normal[1], dst.inward_normal[0]) - math.atan2(src.inward_normal[1], src.inward_normal[0])
    pose = Pose(position=(float(xy[0]), float(xy[1]), tv.pose.position[2]), quaternion=quat_multiply(quat_from_yaw(spin), tv.pose.quaternion), scale=tv.pose.scale)
    moved = with_world_poses(scene, {tv.id: pose})
    moved = moved.model_copy(update={"relations": [r.model_copy(update={"parent": dst.id}) if r.child == tv.id and r.parent == src.id else r for r in moved.relations]})
    assert plausibility(moved)["tv_off_headboard"] == 0.0


async def test_moved_furniture_counts_furniture_not_small_pieces_or_fixtures(tmp_path: Path) -> None:
    scene = await _room("procthor10k_train4_4room.json", "room|6", tmp_path)  # a kitchen
    pieces = furniture(scene)
    assert "ShelvingUnit_6_5" in pieces and "CounterTop_6_0" not in pieces and "Fridge_6_1" not in pieces
    assert moved_furniture(scene, [scene]) == []
    o = scene.get("ShelvingUnit_6_5")
    shifted = with_world_poses(scene, {o.id: o.pose.model_copy(update={"position": (o.pose.position[0] + 0.5, o.pose.position[1], o.pose.position[2])})})
    assert moved_furniture(scene, [scene, shifted]) == ["ShelvingUnit_6_5"]
    assert moved_furniture(scene, [_turned(scene, o.id, 30.0)]) == ["ShelvingUnit_6_5"]

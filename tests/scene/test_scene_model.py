"""The scene model: validation, JSON round trip, frames and the published schema."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from scenemosaic.exceptions import SceneValidationError
from scenemosaic.scene import (
    AssetRef,
    ConstraintClause,
    CrossUnitConstraint,
    Pose,
    Relation,
    Room,
    Scene,
    SceneObject,
    front_vector,
    quat_from_yaw,
    yaw_from_quat,
)

REPO = Path(__file__).resolve().parents[2]


def _obj(oid: str, x: float = 1.0, y: float = 1.0, yaw: float = 0.0) -> SceneObject:
    return SceneObject(
        id=oid,
        category="chair",
        asset=AssetRef(kind="procedural", category="chair", extents=(0.5, 0.4, 0.9)),
        pose=Pose.from_yaw((x, y, 0.0), yaw),
    )


def test_round_trip_is_byte_identical() -> None:
    scene = Scene(
        room=Room.rectangle(0, 0, 4, 3),
        objects=[_obj("a"), _obj("b", 2.0, 2.0, 1.0)],
        relations=[Relation(kind="attach", child="a", parent="floor"), Relation(kind="attach", child="b", parent="a")],
    )
    text = scene.to_json()
    again = Scene.from_json(text)
    assert again == scene
    assert again.to_json() == text


@pytest.mark.parametrize("bad", [(math.nan, 0, 0), (0, math.inf, 0)])
def test_non_finite_position_rejected(bad: tuple[float, float, float]) -> None:
    with pytest.raises(ValidationError, match="position must be finite"):
        Pose(position=bad)


def test_zero_quaternion_rejected_and_denormal_normalized() -> None:
    with pytest.raises(ValidationError, match="zero norm"):
        Pose(position=(0, 0, 0), quaternion=(0, 0, 0, 0))
    pose = Pose(position=(0, 0, 0), quaternion=(0, 0, 0, 2.0))
    assert np.isclose(np.linalg.norm(pose.quaternion), 1.0)
    assert pose.quaternion[3] == pytest.approx(1.0)


def test_negative_scale_rejected() -> None:
    with pytest.raises(ValidationError, match="positive"):
        Pose(position=(0, 0, 0), scale=(1, -1, 1))


def test_duplicate_ids_named() -> None:
    with pytest.raises(SceneValidationError, match="duplicate object id 'a'") as info:
        Scene(objects=[_obj("a"), _obj("a")])
    assert info.value.object_id == "a"


def test_dangling_relation_named() -> None:
    with pytest.raises(SceneValidationError, match="unknown anchor 'ghost'") as info:
        Scene(objects=[_obj("a")], relations=[Relation(kind="attach", child="a", parent="ghost")])
    assert info.value.object_id == "a"


def test_two_supports_rejected() -> None:
    with pytest.raises(SceneValidationError, match="more than one support"):
        Scene(
            objects=[_obj("a"), _obj("b")],
            relations=[Relation(kind="attach", child="a", parent="floor"), Relation(kind="contain", child="a", parent="b")],
        )


def test_object_may_not_take_anchor_id() -> None:
    with pytest.raises(SceneValidationError, match="collides"):
        Scene(room=Room.rectangle(0, 0, 3, 3), objects=[_obj("wall_0")])


def test_constraint_must_name_existing_objects() -> None:
    clause_a = ConstraintClause(anchor_id="floor", related_objects=["a"], layout_note="a faces b")
    clause_b = ConstraintClause(anchor_id="b", related_objects=["zzz"], layout_note="keep")
    with pytest.raises(SceneValidationError, match="unknown object 'zzz'"):
        Scene(
            objects=[_obj("a"), _obj("b")],
            constraints=[CrossUnitConstraint(id="c0", kind="orientation", description="d", anchor_a=clause_a, anchor_b=clause_b)],
        )


def test_front_axis_is_minus_y_and_yaw_turns_counter_clockwise() -> None:
    assert np.allclose(front_vector(quat_from_yaw(0.0)), [0, -1, 0])
    assert np.allclose(front_vector(quat_from_yaw(math.pi / 2)), [1, 0, 0])


@given(st.floats(min_value=-math.pi + 1e-6, max_value=math.pi))
def test_yaw_round_trip(yaw: float) -> None:
    assert math.isclose(yaw_from_quat(quat_from_yaw(yaw)), yaw, abs_tol=1e-9)


def test_footprint_and_corners_follow_pose() -> None:
    obj = _obj("a", 2.0, 3.0, math.pi / 2)
    fp = obj.footprint()
    # rotated by 90 degrees the 0.5 (x) by 0.4 (y) box spans 0.4 in x and 0.5 in y
    assert np.allclose(fp.max(axis=0) - fp.min(axis=0), [0.4, 0.5])
    lo, hi = obj.aabb()
    assert np.allclose(lo, [1.8, 2.75, 0.0]) and np.allclose(hi, [2.2, 3.25, 0.9])


def test_room_is_counter_clockwise_with_inward_normals() -> None:
    room = Room.from_polygon([(0, 0), (0, 3), (4, 3), (4, 0)])  # clockwise input
    centre = np.array([2.0, 1.5])
    for wall in room.walls:
        mid = (np.array(wall.start) + np.array(wall.end)) / 2
        assert np.dot(centre - mid, wall.inward_normal) > 0


def test_published_schema_is_current() -> None:
    published = json.loads((REPO / "docs" / "scene.schema.json").read_text())
    assert published == Scene.model_json_schema(), "run: scenemosaic schema --out docs/scene.schema.json"


def test_a_scene_of_objects_fills_its_defaults_without_parsing_any_text(monkeypatch: pytest.MonkeyPatch) -> None:
    """``Scene.of_objects`` is what ``model_construct(objects=...)`` gives, without pydantic reading
    its default factories' signatures: that parses text with ``ast``, which two threads doing at
    once can break on CPython 3.11 (seen once as a failed evolve node in the test suite)."""
    import ast

    box = SceneObject(id="a", category="box", asset=AssetRef(kind="box", extents=(1.0, 1.0, 1.0)), pose=Pose.from_yaw((0.0, 0.0, 0.0), 0.0))
    parsed: list[object] = []
    real = ast.parse
    monkeypatch.setattr(ast, "parse", lambda *a, **k: parsed.append(a) or real(*a, **k))
    made = Scene.of_objects([box])
    assert not parsed
    assert made == Scene.model_construct(objects=[box]) and parsed  # the pydantic way parses
    assert made.objects == [box] and made.relations == [] and made.metadata == {}
    other = Scene.of_objects([box])
    made.relations.append(Relation(kind="attach", child="a", parent="floor"))
    assert other.relations == []  # each gets its own defaults


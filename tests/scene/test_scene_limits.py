"""The scene limits (sizes, positions, scales, heights, object count) held by the model itself."""

from __future__ import annotations

import json

import pytest
from pydantic import ValidationError

from scenemosaic.scene import (
    MAX_COORDINATE,
    MAX_OBJECT_SIZE,
    MAX_OBJECTS,
    MAX_SCALE,
    MIN_OBJECT_SIZE,
    MIN_SCALE,
    AssetRef,
    Pose,
    Room,
    Scene,
    SceneObject,
    Wall,
    coordinate_problem,
    object_count_problem,
    scale_problem,
    size_problem,
)


def _obj(
    oid: str = "chair_1",
    extents: tuple[float, float, float] = (0.5, 0.5, 0.9),
    position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> SceneObject:
    return SceneObject(
        id=oid,
        category="chair",
        asset=AssetRef(kind="box", extents=extents),
        pose=Pose(position=position, scale=scale),
    )


def test_limits_have_the_documented_values() -> None:
    assert MAX_OBJECTS == 512
    assert MAX_COORDINATE == 1000.0
    assert (MIN_OBJECT_SIZE, MAX_OBJECT_SIZE) == (0.001, 100.0)
    assert (MIN_SCALE, MAX_SCALE) == (0.001, 1000.0)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"extents": (1e-9, 0.5, 0.9)}, "asset.extents * pose.scale: size along x is 1e-09 m, below the 0.001 m minimum"),
        ({"extents": (0.5, 0.5, 250.0)}, "size along z is 250 m, above the 100 m maximum"),
        ({"extents": (0.5, 0.5, 0.9), "scale": (1.0, 1e-4, 1.0)}, "pose.scale: scale along y is 0.0001"),
        ({"extents": (0.5, 0.5, 0.9), "scale": (1.0, 1.0, 5000.0)}, "pose.scale: scale along z is 5000"),
        # in range on its own, the scale makes the object too small
        ({"extents": (0.5, 0.5, 0.9), "scale": (1.0, 0.001, 1.0)}, "size along y is 0.0005 m"),
        ({"position": (0.0, -1500.0, 0.0)}, "pose.position: coordinate 1 is -1500 m, beyond the +/-1000 m"),
    ],
)
def test_object_out_of_limits_names_the_object_and_field(kwargs: dict[str, object], words: str) -> None:
    with pytest.raises(ValidationError) as info:
        _obj(**kwargs)  # type: ignore[arg-type]
    message = str(info.value)
    assert "object 'chair_1'" in message and words in message, message


def test_objects_at_the_limits_are_accepted() -> None:
    _obj(extents=(MIN_OBJECT_SIZE, MAX_OBJECT_SIZE, 1.0), position=(MAX_COORDINATE, -MAX_COORDINATE, 0.0))
    _obj(extents=(1.0, 1.0, 1.0), scale=(MIN_SCALE * 1.0001, 1.0, 1.0))


def test_object_count_is_bounded_before_the_objects_are_read() -> None:
    objects = [_obj(f"o{i}", position=(0.01 * i, 0.0, 0.0)) for i in range(MAX_OBJECTS)]
    assert len(Scene(objects=objects).objects) == MAX_OBJECTS
    with pytest.raises(ValidationError, match=r"513 objects; a scene holds at most 512"):
        Scene(objects=[*objects, _obj("one_too_many")])
    # a scene.json with far too many entries fails on the count, not on the (invalid) entries
    data = {"objects": [{"id": "!"}] * (MAX_OBJECTS + 1)}
    with pytest.raises(ValidationError) as info:
        Scene.model_validate_json(json.dumps(data))
    assert info.value.error_count() == 1 and "at most 512" in str(info.value)


def test_room_coordinates_and_heights_are_bounded() -> None:
    with pytest.raises(ValidationError, match=r"floor point 2: coordinate 0 is 2000 m"):
        Room(floor=[(0.0, 0.0), (1.0, 0.0), (2000.0, 1.0)])
    with pytest.raises(ValidationError, match=r"height 500 m"):
        Room.rectangle(0, 0, 4, 3, ceiling_height=500.0)
    with pytest.raises(ValidationError, match=r"coordinate 1 is 1e\+06 m"):
        Wall(id="wall_0", start=(0.0, 1e6), end=(1.0, 0.0), height=2.5)
    with pytest.raises(ValidationError, match=r"height 101 m"):
        Wall(id="wall_0", start=(0.0, 0.0), end=(1.0, 0.0), height=101.0)


def test_problem_helpers_say_what_is_wrong() -> None:
    assert coordinate_problem((1.0, 2.0, 3.0)) is None
    assert coordinate_problem((float("nan"), 0.0)) == "coordinate 0 must be finite, got nan"
    assert size_problem((0.5, 0.5, 0.5)) is None
    assert size_problem((0.5, float("inf"), 0.5)) == "size along y must be finite, got inf"
    assert scale_problem((1.0, 1.0, 1.0)) is None
    assert object_count_problem(MAX_OBJECTS) is None
    assert object_count_problem(MAX_OBJECTS + 1) is not None


def test_physics_style_transient_poses_are_not_bounded() -> None:
    """A Pose alone is a value (a body that flew away is measured with one); only objects are bounded."""
    assert Pose(position=(1e5, 0.0, -1e5)).position[0] == 1e5

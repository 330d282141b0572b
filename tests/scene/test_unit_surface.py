"""The (u, v) mapping of every kind of unit: 3D -> 2D -> 3D and 2D -> 3D -> 2D round trips.

The structured, stabilized 22-object bedroom has all five kinds of units: the floor (top-down),
a wall (seen along its outward normal, the painting), the ceiling (seen from below), object tops
(the bed, the desk) and a container seen from its front (the bookshelf with its books).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from scenemosaic import GenerateConfig, generate
from scenemosaic.scene import Scene, UnitLayout, normalize_degrees, surface_for

BEDROOM = Path(__file__).resolve().parents[1] / "fixtures" / "bedroom_22.json"


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    out = tmp_path_factory.mktemp("bedroom_units")
    return generate(BEDROOM, out, GenerateConfig(evolve=False)).scene


def _units(scene: Scene) -> dict[str, str]:
    assert scene.structure is not None
    return {u.anchor_id: u.projection for u in scene.structure.units}


def test_the_bedroom_has_every_kind_of_unit(scene: Scene) -> None:
    kinds = set(_units(scene).values())
    assert kinds == {"top_down", "bottom_up", "wall_normal", "anchor_front"}
    assert _units(scene)["bookshelf_0"] == "anchor_front" and _units(scene)["bed"] == "top_down"


def test_3d_to_2d_to_3d_is_exact(scene: Scene) -> None:
    for anchor in _units(scene):
        layout = UnitLayout.from_scene(scene, anchor)
        for oid, pose in layout.poses().items():
            old = scene.get(oid).pose
            assert np.allclose(pose.position, old.position, atol=1e-9), (anchor, oid)
            dot = abs(float(np.dot(pose.quaternion, old.quaternion)))
            assert dot > 1 - 1e-12, (anchor, oid)


def test_grid_points_hold_their_3d_location_and_interpolate(scene: Scene) -> None:
    for anchor in _units(scene):
        s = surface_for(scene, anchor)
        for i, u in enumerate(s.grid_u):
            for j, v in enumerate(s.grid_v):
                assert np.allclose(s.to_3d(u, v), s.grid[i, j], atol=1e-12)
        mid = s.to_3d(s.size[0] / 3, s.size[1] / 3)
        assert s.to_uv(mid) == pytest.approx((s.size[0] / 3, s.size[1] / 3), abs=1e-9)
        assert abs(float(np.linalg.norm(s.normal)) - 1) < 1e-12


def test_the_floor_maps_u_right_v_up_and_rotation_0_faces_down(scene: Scene) -> None:
    s = surface_for(scene, "floor")
    assert np.allclose(s.u_axis, (1, 0, 0)) and np.allclose(s.v_axis, (0, 1, 0))
    layout = UnitLayout.from_scene(scene, "floor")
    for oid in layout.ids:
        yaw = math.degrees(scene.get(oid).pose.yaw)  # 0 = front toward world -Y = down in the view
        assert abs(normalize_degrees(layout.rotation(oid) + yaw)) < 1e-6, oid


def test_the_wall_view_looks_at_the_wall_from_the_room(scene: Scene) -> None:
    [wall] = [a for a, p in _units(scene).items() if p == "wall_normal"]
    s = surface_for(scene, wall)
    assert scene.room is not None
    inward = scene.room.wall(wall).inward_normal
    assert np.allclose(s.normal[:2], inward) and np.allclose(s.v_axis, (0, 0, 1))
    layout = UnitLayout.from_scene(scene, wall)
    assert layout.rotation("painting_0") == pytest.approx(0.0, abs=0.5)  # hung upright


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_2d_to_3d_to_2d_within_a_millimetre_and_a_tenth_of_a_degree(scene: Scene, data: st.DataObject) -> None:
    units = _units(scene)
    anchor = data.draw(st.sampled_from(sorted(units)))
    layout = UnitLayout.from_scene(scene, anchor)
    oid = data.draw(st.sampled_from(layout.ids))
    U, V = layout.surface.size
    u = data.draw(st.floats(0.0, U))
    v = data.draw(st.floats(0.0, V))
    frozen = units[anchor] == "anchor_front"
    rot = layout.rotation(oid) if frozen else data.draw(st.floats(-179.9, 180.0))
    layout.set_rotation(oid, rot)
    layout.set_center(oid, u, v)
    pose = layout.pose(oid)
    moved = scene.model_copy(
        update={"objects": [o.model_copy(update={"pose": pose}) if o.id == oid else o for o in scene.objects]}
    )
    again = UnitLayout.from_scene(moved, anchor)
    assert math.dist(again.center(oid), (u, v)) < 1e-3
    assert abs(normalize_degrees(again.rotation(oid) - rot)) < 0.1
    # the height above the surface is kept: only the in-plane pose changed
    assert again.span(oid) == pytest.approx(layout.span(oid), abs=1e-6)
    # and the 3D pose maps back to the same 3D pose
    assert np.allclose(again.pose(oid).position, pose.position, atol=1e-6)


def test_the_2d_state_is_json_with_centre_size_box_and_rotation(scene: Scene) -> None:
    state = UnitLayout.from_scene(scene, "floor").state()
    data = state.model_dump(mode="json")
    assert data["unit"] == "floor" and data["projection"] == "top_down"
    first = data["objects"][0]
    assert set(first) == {"id", "category", "center", "size", "bbox", "rotation_degrees"}
    for o in state.objects:
        assert o.bbox.max_u - o.bbox.min_u == pytest.approx(o.size.u)
        assert (o.bbox.min_u + o.bbox.max_u) / 2 == pytest.approx(o.center.u)


def _fresh_outline(layout: UnitLayout, oid: str) -> np.ndarray:
    """The outline worked out from nothing kept: a copy whose kept outlines and rotations are dropped."""
    trial = layout.copy(only={oid})
    trial.set_center(oid, *trial.center(oid))
    trial.set_rotation(oid, trial.rotation(oid))
    return trial.polygon(oid)


def test_kept_outlines_follow_every_move_and_copies_stay_apart(scene: Scene) -> None:
    """Issue 38: a layout keeps each piece's outline and rotation until the piece moves; every
    move (in any kind of unit) gives the outline worked out afresh, a copy moves on its own, and
    what a caller does to a returned outline changes nothing kept."""
    for anchor in _units(scene):
        layout = UnitLayout.from_scene(scene, anchor)
        for oid in layout.ids:
            before = layout.polygon(oid)
            trial = layout.copy()
            u, v = trial.center(oid)
            trial.set_center(oid, u + 0.1, v - 0.05)
            assert np.allclose(trial.polygon(oid), before + np.array([0.1, -0.05]), atol=1e-9)
            trial.set_rotation(oid, trial.rotation(oid) + 90.0)
            assert normalize_degrees(trial.rotation(oid) - layout.rotation(oid) - 90.0) == pytest.approx(0.0, abs=1e-9)
            assert np.array_equal(trial.polygon(oid), _fresh_outline(trial, oid))
            assert np.array_equal(layout.polygon(oid), before)  # the original stays where it was
            returned = layout.polygon(oid)
            returned += 5.0
            assert np.array_equal(layout.polygon(oid), before)
    only = UnitLayout.from_scene(scene, "floor").copy(only={"bed"})
    assert only.ids == ["bed"]

"""World-space meshes shared by views and exports: the assets seam and room slabs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

import scenemosaic.render._geometry
from scenemosaic.render import ceiling_mesh, floor_mesh, object_local_mesh, object_world_mesh, wall_mesh
from scenemosaic.scene import AssetRef, Opening, Pose, Room, SceneObject


def _obj() -> SceneObject:
    return SceneObject(id="crate", category="crate", asset=AssetRef(kind="box", extents=(0.4, 0.3, 0.2)),
                       pose=Pose.from_yaw((1.0, 2.0, 0.5), np.pi / 2, scale=(2.0, 1.0, 1.0)))  # fmt: skip


def test_local_mesh_fills_the_object_size() -> None:
    mesh = object_local_mesh(_obj())
    np.testing.assert_allclose(mesh.bounds, [[-0.4, -0.15, 0.0], [0.4, 0.15, 0.2]], atol=1e-9)
    world = object_world_mesh(_obj())  # yaw 90°: local x runs along world y
    np.testing.assert_allclose(world.bounds, [[0.85, 1.6, 0.5], [1.15, 2.4, 0.7]], atol=1e-9)


def test_assets_object_mesh_is_what_gets_drawn(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[str, Path | None]] = []

    def fake(obj: SceneObject, base_dir: Path | None = None) -> trimesh.Trimesh:
        calls.append((obj.id, base_dir))
        cone = trimesh.creation.cone(radius=float(min(obj.size[:2])) / 2, height=float(obj.size[2]))
        return cone

    monkeypatch.setattr(scenemosaic.render._geometry, "object_mesh", fake)
    mesh = object_local_mesh(_obj(), Path("/scenes/x"))
    assert calls == [("crate", Path("/scenes/x"))]
    assert len(mesh.faces) > 12  # the cone, not a box


def test_room_slabs_on_an_l_shaped_floor() -> None:
    room = Room.from_polygon([(0, 0), (4, 0), (4, 3), (2, 3), (2, 1), (0, 1)], ceiling_height=2.5)
    floor = floor_mesh(room)
    assert floor.is_watertight
    assert abs(floor.volume - 8.0 * 0.05) < 1e-9  # area 4*1 + 2*2 = 8 m², 5 cm thick
    ceiling = ceiling_mesh(room)
    assert abs(ceiling.bounds[0][2] - 2.5) < 1e-12 and abs(ceiling.volume - floor.volume) < 1e-9
    wall = room.walls[0].model_copy(
        update={"openings": [Opening(kind="door", center=2.0, width=1.0, height=2.0)]}
    )
    mesh = wall_mesh(wall)
    solid = (4.0 + 0.2) * 2.5 - 1.0 * 2.0
    assert abs(mesh.volume - solid * wall.thickness) < 1e-9
    assert mesh.bounds[1][1] <= 1e-12  # wall_0 runs along +X at y = 0 and stands outside, y < 0

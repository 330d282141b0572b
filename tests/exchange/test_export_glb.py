"""GLB export: node names, Z-up -> Y-up root, object bounds in Z-up, room nodes, determinism."""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np
import trimesh

from scenemosaic.exchange import GLB_ROOT_NODE, Y_UP_TO_Z_UP, Z_UP_TO_Y_UP, export_glb
from scenemosaic.render import FLOOR_THICKNESS, wall_panels
from scenemosaic.scene import Scene

TOL_M = 1e-3


def _zup_vertices(loaded: trimesh.Scene, node: str) -> np.ndarray:
    """World vertices of a node as a Y-up glTF reader sees them, mapped back to our Z-up frame."""
    matrix, geom = loaded.graph[node]
    mesh = loaded.geometry[geom]
    return trimesh.transform_points(mesh.vertices, Y_UP_TO_Z_UP @ matrix)


def _gltf_json(path: Path) -> dict:
    data = path.read_bytes()
    (length,) = struct.unpack("<I", data[12:16])
    return json.loads(data[20 : 20 + length])


def test_node_names_are_object_ids_and_room_parts(small_scene: Scene, tmp_path: Path) -> None:
    path = export_glb(small_scene, tmp_path / "scene.glb")
    loaded = trimesh.load(path)
    expected = {o.id for o in small_scene.objects}
    expected |= {"room/floor", "room/ceiling"} | {f"room/wall_{i}" for i in range(4)}
    assert set(loaded.graph.nodes_geometry) == expected


def test_root_node_turns_z_up_into_y_up(small_scene: Scene, tmp_path: Path) -> None:
    path = export_glb(small_scene, tmp_path / "scene.glb")
    doc = _gltf_json(path)
    roots = doc["scenes"][doc.get("scene", 0)]["nodes"]
    assert len(roots) == 1
    root = doc["nodes"][roots[0]]
    assert root["name"] == GLB_ROOT_NODE
    np.testing.assert_allclose(np.asarray(root["matrix"]).reshape(4, 4).T, Z_UP_TO_Y_UP, atol=1e-12)
    # in glTF's own frame the ceiling is the highest thing along +Y, the floor top at y = 0
    loaded = trimesh.load(path)
    ceiling = trimesh.transform_points(
        loaded.geometry["room/ceiling"].vertices, loaded.graph["room/ceiling"][0]
    )
    floor = trimesh.transform_points(loaded.geometry["room/floor"].vertices, loaded.graph["room/floor"][0])
    assert abs(ceiling[:, 1].min() - small_scene.room.ceiling_height) < 1e-6
    assert abs(floor[:, 1].max()) < 1e-6


def test_object_bounds_match_the_scene_in_z_up(small_scene: Scene, tmp_path: Path) -> None:
    loaded = trimesh.load(export_glb(small_scene, tmp_path / "scene.glb"))
    for obj in small_scene.objects:
        world = _zup_vertices(loaded, obj.id)
        # back in the object's own frame the mesh fills exactly its size, bottom centre at the origin
        local = trimesh.transform_points(world, np.linalg.inv(obj.pose.matrix(with_scale=False)))
        size = obj.size
        np.testing.assert_allclose(
            local.min(axis=0), [-size[0] / 2, -size[1] / 2, 0.0], atol=TOL_M, err_msg=obj.id
        )
        np.testing.assert_allclose(
            local.max(axis=0), [size[0] / 2, size[1] / 2, size[2]], atol=TOL_M, err_msg=obj.id
        )
        if obj.asset.kind == "box":  # a box fills its oriented box: world bounds are the scene's AABB
            lo, hi = obj.aabb()
            np.testing.assert_allclose(world.min(axis=0), lo, atol=TOL_M, err_msg=obj.id)
            np.testing.assert_allclose(world.max(axis=0), hi, atol=TOL_M, err_msg=obj.id)


def test_real_dining_room_footprints(dining_scene: Scene, tmp_path: Path) -> None:
    loaded = trimesh.load(export_glb(dining_scene, tmp_path / "scene.glb"))
    assert len([n for n in loaded.graph.nodes_geometry if not n.startswith("room/")]) == len(
        dining_scene.objects
    )
    for obj in dining_scene.objects:
        world = _zup_vertices(loaded, obj.id)
        yaw = obj.pose.yaw
        # footprint extents in the object's heading frame equal the input's full extents
        c, s = math.cos(yaw), math.sin(yaw)
        along_x = world[:, 0] * c + world[:, 1] * s
        along_y = -world[:, 0] * s + world[:, 1] * c
        assert abs(np.ptp(along_x) - obj.size[0]) < TOL_M, obj.id
        assert abs(np.ptp(along_y) - obj.size[1]) < TOL_M, obj.id
        assert abs(world[:, 2].min() - obj.pose.position[2]) < TOL_M, obj.id


def test_room_geometry(small_scene: Scene, tmp_path: Path) -> None:
    loaded = trimesh.load(export_glb(small_scene, tmp_path / "scene.glb"))
    floor = _zup_vertices(loaded, "room/floor")
    np.testing.assert_allclose(floor.min(axis=0), [0.0, 0.0, -FLOOR_THICKNESS], atol=1e-6)
    np.testing.assert_allclose(floor.max(axis=0), [4.0, 3.0, 0.0], atol=1e-6)
    wall0 = _zup_vertices(loaded, "room/wall_0")  # along +X at y = 0, standing outside (y < 0)
    np.testing.assert_allclose(wall0.min(axis=0), [-0.1, -0.1, 0.0], atol=1e-6)
    np.testing.assert_allclose(wall0.max(axis=0), [4.1, 0.0, 2.7], atol=1e-6)


def test_wall_panels_leave_openings_open(small_scene: Scene) -> None:
    def solid(panels: list[tuple[float, float, float, float]], s: float, z: float) -> bool:
        return any(a <= s <= b and lo <= z <= hi for a, b, lo, hi in panels)

    door_wall = wall_panels(small_scene.room.walls[0])  # door: s in [0.55, 1.45], z in [0, 2.1]
    assert not solid(door_wall, 1.0, 1.0)
    assert solid(door_wall, 1.0, 2.4) and solid(door_wall, 0.3, 1.0) and solid(door_wall, 1.6, 0.1)
    window_wall = wall_panels(small_scene.room.walls[1])  # window: s in [0.9, 2.1], z in [0.9, 2.0]
    assert not solid(window_wall, 1.5, 1.5)
    assert solid(window_wall, 1.5, 0.5) and solid(window_wall, 1.5, 2.3)
    area = sum((b - a) * (hi - lo) for a, b, lo, hi in window_wall)
    assert abs(area - ((3.0 + 0.2) * 2.7 - 1.2 * 1.1)) < 1e-9


def test_export_is_deterministic(dining_scene: Scene, tmp_path: Path) -> None:
    a = export_glb(dining_scene, tmp_path / "a.glb").read_bytes()
    b = export_glb(dining_scene, tmp_path / "b" / "b.glb").read_bytes()
    assert a == b

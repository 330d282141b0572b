"""URDF export: every file loads in yourdfpy and matches the model the MJCF export simulates.

The scene is a real PhyScene living room run through ``generate`` (no evolution), with one object
marked ``static``; the MuJoCo model of the same scene, loaded with plain ``mujoco``, is the
reference for masses, inertias, free vs welded bodies and collision pieces.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yourdfpy  # the [urdf] extra is part of the dev install
from export_reference import STATIC_ID, ReferenceRoom, hull_geoms

from scenemosaic.assets import object_articulation
from scenemosaic.exchange import export_urdf, write_scene
from scenemosaic.scene import Scene


@dataclass
class Exported:
    scene: Scene
    base_dir: Path
    scene_urdf: Path
    model: mujoco.MjModel


@pytest.fixture(scope="module")
def living(reference_room: ReferenceRoom, tmp_path_factory: pytest.TempPathFactory) -> Exported:
    ref = reference_room
    out = tmp_path_factory.mktemp("living_urdf")
    return Exported(ref.scene, ref.base_dir, export_urdf(ref.scene, out / "urdf_export", ref.base_dir), ref.model)


def _load(path: Path) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=True)



def _mesh_files(path: Path) -> list[str]:
    return [m.attrib["filename"] for m in ET.parse(path).getroot().iter("mesh")]


def test_every_file_loads_with_the_mjcf_mass_and_hulls(living: Exported) -> None:
    model = living.model
    for obj in living.scene.objects:
        path = living.scene_urdf.parent / "urdf" / f"{obj.id}.urdf"
        urdf = _load(path)
        assert urdf.validate(), obj.id
        link = urdf.link_map[obj.id]
        body = model.body(obj.id)
        if body.jntnum[0] == 1:  # MuJoCo keeps mass and inertia of free bodies only
            assert link.inertial.mass == pytest.approx(float(body.mass[0]), rel=1e-12), obj.id
            # MuJoCo's XML keeps six significant digits of the centre and the inertia
            np.testing.assert_allclose(np.diag(link.inertial.inertia), body.inertia, rtol=1e-5)
            np.testing.assert_allclose(link.inertial.origin[:3, 3], body.ipos, rtol=1e-5, atol=1e-6)
        assert np.all(np.linalg.eigvalsh(link.inertial.inertia) > 0), obj.id
        assert len(link.collisions) == hull_geoms(model, obj.id) >= 1, obj.id
        # the visual mesh was found and loaded: one per link (a TV stand's drawers have their own)
        assert len(urdf.scene.geometry) == 1 + len(object_articulation(obj)), obj.id


def test_scene_joints_reproduce_the_poses(living: Exported) -> None:
    urdf = _load(living.scene_urdf)
    assert urdf.validate()
    assert urdf.base_link == "world"
    joints = {j.child: j for j in urdf.robot.joints}
    for obj in living.scene.objects:
        expected = "floating" if living.model.body(obj.id).jntnum[0] == 1 else "fixed"
        assert joints[obj.id].type == expected, obj.id
        assert joints[obj.id].parent == "world"
        placed = urdf.get_transform(frame_to=obj.id, frame_from="world")
        np.testing.assert_allclose(placed, obj.pose.matrix(with_scale=False), atol=1e-6, err_msg=obj.id)
        link = urdf.link_map[obj.id]
        assert link.inertial.mass == pytest.approx(
            _load_single(living, obj.id).link_map[obj.id].inertial.mass
        )
        assert len(link.collisions) == hull_geoms(living.model, obj.id)
    assert joints[STATIC_ID].type == "fixed"
    room = urdf.link_map["room"]
    assert living.scene.room is not None
    assert len(room.collisions) == 2 + len(living.scene.room.walls)  # floor, ceiling, walls
    assert all(c.geometry.box is not None for c in room.collisions)


def _load_single(living: Exported, object_id: str) -> yourdfpy.URDF:
    return _load(living.scene_urdf.parent / "urdf" / f"{object_id}.urdf")


def test_the_folder_moves(living: Exported, tmp_path: Path) -> None:
    folder = export_urdf(living.scene, tmp_path / "first", living.base_dir).parent
    moved = tmp_path / "elsewhere" / "zipped"
    moved.parent.mkdir()
    shutil.move(folder, moved)
    assert not folder.exists()
    files = [moved / "scene.urdf", *sorted((moved / "urdf").glob("*.urdf"))]
    assert len(files) == 1 + len(living.scene.objects)
    for path in files:
        assert str(tmp_path) not in path.read_text()
        for name in _mesh_files(path):
            assert not Path(name).is_absolute() and ".." not in Path(name).parts
            assert (path.parent / name).is_file(), name
    urdf = _load(moved / "scene.urdf")
    room = living.scene.room
    assert room is not None
    # one visual per object and per drawer, door or lid, plus the floor and the walls (the ceiling has none)
    parts = sum(len(object_articulation(o)) for o in living.scene.objects)
    assert len(urdf.scene.geometry) == len(living.scene.objects) + parts + 1 + len(room.walls)


def test_writing_twice_gives_identical_bytes(living: Exported, tmp_path: Path) -> None:
    first = export_urdf(living.scene, tmp_path / "a", living.base_dir).parent
    second = export_urdf(living.scene, tmp_path / "b", living.base_dir).parent
    files = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(second) for p in second.rglob("*") if p.is_file())
    for rel in files:
        assert (first / rel).read_bytes() == (second / rel).read_bytes(), rel
    assert (first / "scene.urdf").read_bytes() == living.scene_urdf.read_bytes()


def test_friction_is_written_for_pybullet_and_gazebo(living: Exported) -> None:
    root = ET.parse(living.scene_urdf).getroot()
    for obj in living.scene.objects:
        link = root.find(f"link[@name='{obj.id}']")
        assert link is not None
        lateral = link.find("contact/lateral_friction")
        assert lateral is not None and float(lateral.attrib["value"]) == obj.sim.friction
        gazebo = root.find(f"gazebo[@reference='{obj.id}']")
        assert gazebo is not None and float(gazebo.findtext("mu1", "nan")) == obj.sim.friction


def test_registered_writer(living: Exported, tmp_path: Path) -> None:
    path = write_scene(living.scene, "urdf", tmp_path / "out", living.base_dir)
    assert path == tmp_path / "out" / "scene.urdf"
    assert path.read_bytes() == living.scene_urdf.read_bytes()


def test_held_and_tilted_objects(tmp_path: Path, small_scene: Scene) -> None:
    """Ceiling and wall objects get fixed joints; a scaled chair and a book on its side keep their pose."""
    urdf = _load(export_urdf(small_scene, tmp_path))
    joints = {j.child: j.type for j in urdf.robot.joints}
    assert joints["lamp"] == joints["tv"] == "fixed"
    assert joints["table"] == joints["chair"] == joints["mug"] == joints["book"] == "floating"
    for obj in small_scene.objects:
        placed = urdf.get_transform(frame_to=obj.id, frame_from="world")
        np.testing.assert_allclose(placed, obj.pose.matrix(with_scale=False), atol=1e-6, err_msg=obj.id)
    chair = _load(tmp_path / "urdf" / "chair.urdf")
    (mesh,) = chair.scene.geometry.values()
    np.testing.assert_allclose(mesh.extents, small_scene.get("chair").size, atol=1e-6)


def test_mesh_hull_pieces_become_obj_collisions(tmp_path: Path, small_scene: Scene) -> None:
    """A piece that is not a box is written as its convex hull in an OBJ and loads as one."""
    import trimesh

    cylinder = trimesh.creation.cylinder(radius=0.3, height=0.75)
    cylinder.apply_translation((0.0, 0.0, 0.375))
    export_urdf(small_scene, tmp_path, hulls={"table": [cylinder.vertices]})
    path = tmp_path / "urdf" / "table.urdf"
    assert _mesh_files(path) == ["meshes/table_visual.obj", "meshes/table_hull_0.obj"]
    urdf = yourdfpy.URDF.load(
        str(path),
        build_collision_scene_graph=True,
        load_collision_meshes=True,
        force_collision_mesh=False,  # its concatenation path calls a deprecated trimesh API
        load_meshes=False,
    )
    (hull,) = urdf.collision_scene.geometry.values()
    assert hull.is_convex and hull.is_watertight
    np.testing.assert_allclose(hull.bounds, cylinder.bounds, atol=1e-6)

"""USD export: the stage opens in pxr (usd-core) and says what the MJCF export simulates.

The scene is a real PhyScene living room run through ``generate`` (no evolution), with one object
marked ``static`` so that both kinds of object occur; the MuJoCo model of the same scene, loaded
with plain ``mujoco``, is the reference for masses, free vs welded bodies and collision pieces.
"""

from __future__ import annotations

import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pytest
from export_reference import STATIC_ID, ReferenceRoom, hull_geoms
from pxr import Usd, UsdGeom, UsdPhysics, UsdShade  # the [usd] extra is part of the dev install

from scenemosaic.assets import object_articulation
from scenemosaic.exceptions import MissingExtraError
from scenemosaic.exchange import export_usd, write_scene
from scenemosaic.scene import Scene


@dataclass
class Exported:
    scene: Scene
    base_dir: Path
    stage_path: Path
    model: mujoco.MjModel


@pytest.fixture(scope="module")
def living(reference_room: ReferenceRoom, tmp_path_factory: pytest.TempPathFactory) -> Exported:
    ref = reference_room
    out = tmp_path_factory.mktemp("living_usd")
    return Exported(ref.scene, ref.base_dir, export_usd(ref.scene, out / "usd", ref.base_dir), ref.model)


def _object_prims(stage: Usd.Stage) -> dict[str, Usd.Prim]:
    """The objects' own prims (a drawer's or a door's prim beside its object's has no objectId)."""
    return {
        str(p.GetCustomDataByKey("scenemosaic:objectId")): p
        for p in stage.GetPrimAtPath("/World/Objects").GetChildren()
        if p.GetCustomDataByKey("scenemosaic:objectId") is not None
    }


def _parts(scene: Scene) -> int:
    """How many drawers, doors and lids the scene's objects have: each a prim and a layer of its own."""
    return sum(len(object_articulation(o)) for o in scene.objects)



def _local_points(prim: Usd.Prim) -> np.ndarray:
    return np.asarray(UsdGeom.Mesh(prim).GetPointsAttr().Get(), dtype=np.float64)


def test_stage_metadata_and_physics_scene(living: Exported) -> None:
    stage = Usd.Stage.Open(str(living.stage_path))
    assert living.stage_path.name == "scene.usda"
    assert living.stage_path.read_text().startswith("#usda 1.0")
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == "/World"
    scenes = [p for p in stage.Traverse() if p.IsA(UsdPhysics.Scene)]
    assert len(scenes) == 1
    physics = UsdPhysics.Scene(scenes[0])
    assert tuple(physics.GetGravityDirectionAttr().Get()) == (0.0, 0.0, -1.0)
    assert physics.GetGravityMagnitudeAttr().Get() == pytest.approx(9.81)
    assert -living.model.opt.gravity[2] == pytest.approx(physics.GetGravityMagnitudeAttr().Get())


def test_one_prim_per_object_at_its_pose(living: Exported) -> None:
    stage = Usd.Stage.Open(str(living.stage_path))
    prims = _object_prims(stage)
    assert set(prims) == {o.id for o in living.scene.objects}
    assert len(stage.GetPrimAtPath("/World/Objects").GetChildren()) == len(living.scene.objects) + _parts(living.scene)
    for obj in living.scene.objects:
        matrix = UsdGeom.Xformable(prims[obj.id]).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        world = np.asarray(matrix, dtype=np.float64).T  # USD multiplies row vectors
        np.testing.assert_allclose(world, obj.pose.matrix(with_scale=False), atol=1e-5, err_msg=obj.id)


def test_movable_objects_are_rigid_with_the_mjcf_mass(living: Exported) -> None:
    stage = Usd.Stage.Open(str(living.stage_path))
    prims = _object_prims(stage)
    model = living.model
    movable = [o for o in living.scene.objects if model.body(o.id).jntnum[0] == 1]
    welded = [o for o in living.scene.objects if model.body(o.id).jntnum[0] == 0]
    assert [o.id for o in welded] == [STATIC_ID] and len(movable) == len(living.scene.objects) - 1
    for obj in movable:
        prim = prims[obj.id]
        assert prim.HasAPI(UsdPhysics.RigidBodyAPI) and prim.HasAPI(UsdPhysics.MassAPI), obj.id
        mass_api = UsdPhysics.MassAPI(prim)
        body = model.body(obj.id)
        assert mass_api.GetMassAttr().Get() == pytest.approx(float(body.mass[0]), rel=1e-6), obj.id
        # MuJoCo's XML keeps six significant digits of the centre and the inertia
        np.testing.assert_allclose(mass_api.GetCenterOfMassAttr().Get(), body.ipos, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(mass_api.GetDiagonalInertiaAttr().Get(), body.inertia, rtol=1e-5)
    for obj in welded:
        prim = prims[obj.id]
        assert not prim.HasAPI(UsdPhysics.RigidBodyAPI) and not prim.HasAPI(UsdPhysics.MassAPI)


def test_collision_pieces_are_the_mjcf_hulls(living: Exported) -> None:
    stage = Usd.Stage.Open(str(living.stage_path))
    for obj in living.scene.objects:
        prim = _object_prims(stage)[obj.id]
        pieces = [p for p in Usd.PrimRange(prim) if p.HasAPI(UsdPhysics.CollisionAPI)]
        assert len(pieces) >= 1
        assert len(pieces) == hull_geoms(living.model, obj.id), obj.id
        for piece in pieces:
            assert piece.IsA(UsdGeom.Mesh) and piece.HasAPI(UsdPhysics.MeshCollisionAPI)
            assert UsdPhysics.MeshCollisionAPI(piece).GetApproximationAttr().Get() == "convexHull"
            assert UsdGeom.Imageable(piece).ComputePurpose() == UsdGeom.Tokens.guide
        # the pieces fill the object's box (procedural parts are exact), in the object's frame
        points = np.concatenate([_local_points(p) for p in pieces])
        w, d, h = obj.size
        np.testing.assert_allclose(points.min(axis=0), [-w / 2, -d / 2, 0.0], atol=1e-5)
        np.testing.assert_allclose(points.max(axis=0), [w / 2, d / 2, h], atol=1e-5)
        # the friction rides on a physics material bound to the pieces
        material, _ = UsdShade.MaterialBindingAPI(pieces[0]).ComputeBoundMaterial("physics")
        assert UsdPhysics.MaterialAPI(material.GetPrim()).GetStaticFrictionAttr().Get() == pytest.approx(
            obj.sim.friction
        )


def test_room_is_static_colliders(living: Exported) -> None:
    stage = Usd.Stage.Open(str(living.stage_path))
    room = living.scene.room
    assert room is not None
    parts = {p.GetName(): p for p in stage.GetPrimAtPath("/World/Room").GetChildren()}
    assert set(parts) == {"floor", "ceiling", *(w.id for w in room.walls)}
    for prim in parts.values():
        assert prim.HasAPI(UsdPhysics.CollisionAPI) and not prim.HasAPI(UsdPhysics.RigidBodyAPI)
    # the floor's top face is the plane z = 0
    box = (
        UsdGeom.Imageable(parts["floor"])
        .ComputeWorldBound(Usd.TimeCode.Default(), "default")
        .ComputeAlignedRange()
    )
    assert box.GetMax()[2] == pytest.approx(0.0, abs=1e-9)


def test_paths_are_relative_and_the_folder_moves(living: Exported, tmp_path: Path) -> None:
    folder = export_usd(living.scene, tmp_path / "first", living.base_dir).parent
    moved = tmp_path / "elsewhere" / "zipped"
    moved.parent.mkdir()
    shutil.move(folder, moved)
    assert not folder.exists()
    assert str(tmp_path) not in (moved / "scene.usda").read_text()
    stage = Usd.Stage.Open(str(moved / "scene.usda"))
    for obj in living.scene.objects:
        prim = _object_prims(stage)[obj.id]
        visual = prim.GetChild("visual")
        assert visual.IsValid() and len(_local_points(visual)) > 0, obj.id  # the reference resolved
        # the visual mesh carries the object's size (scale baked in, none on the prim)
        points = _local_points(visual)
        np.testing.assert_allclose(points.max(axis=0) - points.min(axis=0), obj.size, atol=1e-5)


def test_writing_twice_gives_identical_bytes(living: Exported, tmp_path: Path) -> None:
    first = export_usd(living.scene, tmp_path / "a", living.base_dir).parent
    second = export_usd(living.scene, tmp_path / "b", living.base_dir).parent
    export_usd(living.scene, second, living.base_dir)  # over an existing export
    files = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(second) for p in second.rglob("*") if p.is_file())
    assert len(files) == 1 + len(living.scene.objects) + _parts(living.scene)
    for rel in files:
        assert (first / rel).read_bytes() == (second / rel).read_bytes(), rel


def test_registered_writer(living: Exported, tmp_path: Path) -> None:
    path = write_scene(living.scene, "usd", tmp_path / "out", living.base_dir)
    assert path == tmp_path / "out" / "scene.usda"
    assert path.read_bytes() == living.stage_path.read_bytes()


def test_held_and_scaled_objects(tmp_path: Path, small_scene: Scene) -> None:
    """Ceiling and wall objects only collide; a non-uniformly scaled chair and a book on its side keep their pose."""
    scene = small_scene
    stage = Usd.Stage.Open(str(export_usd(scene, tmp_path / "small.usda")))
    prims = _object_prims(stage)
    for oid in ("lamp", "tv"):
        assert not prims[oid].HasAPI(UsdPhysics.RigidBodyAPI)
    for oid in ("table", "chair", "mug", "book"):
        assert prims[oid].HasAPI(UsdPhysics.RigidBodyAPI)
    for obj in scene.objects:
        matrix = UsdGeom.Xformable(prims[obj.id]).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        np.testing.assert_allclose(np.asarray(matrix).T, obj.pose.matrix(with_scale=False), atol=1e-5)
    chair = _local_points(prims["chair"].GetChild("visual"))
    np.testing.assert_allclose(chair.max(axis=0) - chair.min(axis=0), scene.get("chair").size, atol=1e-5)
    assert (tmp_path / "usd" / "chair.usda").is_file()


def test_missing_pxr_names_the_extra(
    living: Exported, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "pxr", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'scenemosaic\[usd\]'"):
        export_usd(living.scene, tmp_path / "out", living.base_dir)
    assert not (tmp_path / "out").exists()


def test_mesh_hull_pieces_are_convex_meshes(tmp_path: Path, small_scene: Scene) -> None:
    """A piece that is not a box keeps its hull: the collision mesh is that convex hull."""
    import trimesh

    cylinder = trimesh.creation.cylinder(radius=0.3, height=0.75)
    cylinder.apply_translation((0.0, 0.0, 0.375))
    stage = Usd.Stage.Open(str(export_usd(small_scene, tmp_path, hulls={"table": [cylinder.vertices]})))
    (piece,) = [p for p in Usd.PrimRange(_object_prims(stage)["table"]) if p.HasAPI(UsdPhysics.CollisionAPI)]
    mesh = UsdGeom.Mesh(piece)
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get())
    faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    assert set(counts.tolist()) == {3}
    hull = trimesh.Trimesh(vertices=_local_points(piece), faces=faces, process=False)
    assert hull.is_convex and hull.is_watertight and hull.volume > 0  # outward faces
    assert hull.volume == pytest.approx(cylinder.convex_hull.volume, rel=1e-5)

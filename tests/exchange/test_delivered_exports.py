"""Issue 13's acceptance: every format ``generate`` delivers, for the base scene and a variant of a
shipped PhyScene room, loads back in its own library; the MuJoCo scene stays at rest."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
import yourdfpy
from pxr import Usd, UsdGeom, UsdPhysics

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import load_scene, read_scene

ROOM = Path(__file__).resolve().parents[2] / "data/layouts/physcene/LivingDiningRoom-8714_livingroom.json"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("delivered") / "room"
    assert generate(ROOM, out, GenerateConfig(variants=1)).report["variants_written"] == 1
    return out


@pytest.fixture(params=["base", "variant_1"])
def folder(request: pytest.FixtureRequest, run_dir: Path) -> Path:
    return run_dir / str(request.param)


def test_mjcf_loads_and_stays_at_rest(folder: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(folder / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.xpos.copy()
    mujoco.mj_step(model, data, nstep=round(2.0 / model.opt.timestep))
    assert float(np.linalg.norm(data.xpos - start, axis=1).max()) < 0.01
    scene = read_scene(folder)
    assert all(model.body(o.id).mass[0] > 0 for o in scene.objects)


def test_usd_opens_with_a_rigid_body_per_movable_object(folder: Path) -> None:
    stage = Usd.Stage.Open(str(folder / "scene.usda"))
    assert UsdGeom.GetStageUpAxis(stage) == "Z" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    scene = read_scene(folder)
    ids = {p.GetCustomDataByKey("scenemosaic:objectId"): p for p in stage.Traverse() if p.GetCustomDataByKey("scenemosaic:objectId")}
    assert set(ids) == {o.id for o in scene.objects}
    for obj in scene.objects:
        world = UsdGeom.Xformable(ids[obj.id]).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        assert np.allclose(np.asarray(world.ExtractTranslation()), obj.pose.position, atol=1e-5), obj.id
    assert any(p.HasAPI(UsdPhysics.RigidBodyAPI) for p in ids.values())


def test_urdf_loads_with_every_object(folder: Path) -> None:
    urdf = yourdfpy.URDF.load(str(folder / "scene.urdf"), build_scene_graph=True, load_meshes=True, force_collision_mesh=False)
    scene = read_scene(folder)
    assert {o.id for o in scene.objects} <= set(urdf.link_map)
    for obj in scene.objects:
        assert urdf.link_map[obj.id].inertial.mass > 0 and urdf.link_map[obj.id].collisions


def test_glb_and_sceneeval_load_back(folder: Path) -> None:
    scene = read_scene(folder)
    glb = trimesh.load(folder / "scene.glb")
    assert {o.id for o in scene.objects} <= set(glb.graph.nodes)
    state = load_scene(folder / "sceneeval" / "scene_base.json")
    assert len(state.objects) == len(scene.objects)

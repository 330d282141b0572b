"""Issue 26, item 1: every simulator the README names loads the demo's delivered scene the way its
users load scenes, and 500 steps later every movable object is a free body still at rest (within
1 cm) and nothing is below the floor."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pybullet
import pytest
from pxr import Usd, UsdGeom, UsdPhysics
from simulator_checks import REST_M, STEPS, bullet_client, link_position, usd_object_prims

from scenemosaic import GenerateConfig, demo_scene, generate
from scenemosaic.exceptions import MissingExtraError
from scenemosaic.exchange import PYBULLET_INSTALL_HINT, load_pybullet, read_scene, save_scene
from scenemosaic.physics import is_fixed
from scenemosaic.render import category_color
from scenemosaic.scene import Scene


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """What ``make demo`` delivers (``scenemosaic demo``: the demo scene, offline rules)."""
    folder = tmp_path_factory.mktemp("simulators")
    save_scene(demo_scene(), folder / "input")
    generate(folder / "input", folder / "demo", GenerateConfig(model="rules", seed=0))
    return folder / "demo" / "base"


@pytest.fixture(scope="module")
def scene(base: Path) -> Scene:
    return read_scene(base)


def test_mujoco_loads_scene_xml_with_free_objects_at_rest(base: Path, scene: Scene) -> None:
    model = mujoco.MjModel.from_xml_path(str(base / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = {o.id: data.body(o.id).xpos.copy() for o in scene.objects}
    mujoco.mj_step(model, data, nstep=STEPS)
    for obj in scene.objects:
        body = model.body(obj.id)
        free = body.jntnum[0] == 1 and model.jnt_type[body.jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE
        assert free == (not is_fixed(scene, obj)), obj.id
        assert np.linalg.norm(data.body(obj.id).xpos - start[obj.id]) < REST_M, obj.id
        assert data.body(obj.id).xpos[2] > -REST_M, obj.id
    assert any(not is_fixed(scene, o) for o in scene.objects)


def test_mjcf_visuals_carry_the_category_colours(base: Path, scene: Scene) -> None:
    """Item 8: MuJoCo's viewer shows the colours of the GLB, USD, URDF and the plans."""
    model = mujoco.MjModel.from_xml_path(str(base / "scene.xml"))
    for obj in scene.objects:
        rgba = model.geom(f"{obj.id}_visual").rgba
        assert np.allclose(rgba[:3] * 255.0, category_color(obj.category), atol=1e-3), obj.id
    assert len({tuple(model.geom(f"{o.id}_visual").rgba) for o in scene.objects}) > 5


@pytest.fixture
def bullet() -> Iterator[int]:
    with bullet_client() as client:
        yield client


def test_pybullet_loads_scene_sdf_in_one_call_with_free_objects_at_rest(
    base: Path, scene: Scene, bullet: int
) -> None:
    bodies = load_pybullet(base, client=bullet)
    assert set(bodies) == {o.id for o in scene.objects} | {"room"}
    start = {}
    for obj in scene.objects:
        body = bodies[obj.id]
        start[obj.id] = link_position(body, bullet)
        assert np.allclose(start[obj.id], obj.pose.position, atol=1e-6), obj.id
        mass, friction = pybullet.getDynamicsInfo(body, -1, physicsClientId=bullet)[:2]
        assert (mass > 0) == (not is_fixed(scene, obj)), obj.id  # mass 0: PyBullet's static body
        assert friction == pytest.approx(obj.sim.friction), obj.id
    for _ in range(STEPS):
        pybullet.stepSimulation(physicsClientId=bullet)
    for obj in scene.objects:
        body = bodies[obj.id]
        assert np.linalg.norm(link_position(body, bullet) - start[obj.id]) < REST_M, obj.id
        assert pybullet.getAABB(body, physicsClientId=bullet)[0][2] > -REST_M, obj.id

    chair = bodies["chair"]  # free: a push moves it
    before = link_position(chair, bullet)
    pybullet.resetBaseVelocity(chair, [1.0, 0.0, 0.0], physicsClientId=bullet)
    for _ in range(20):
        pybullet.stepSimulation(physicsClientId=bullet)
    assert np.linalg.norm(link_position(chair, bullet) - before) > 0.02


def test_plain_pybullet_load_sdf_places_every_object(base: Path, scene: Scene, bullet: int) -> None:
    bodies = pybullet.loadSDF(str(base / "scene.sdf"), physicsClientId=bullet)
    names = {pybullet.getBodyInfo(b, physicsClientId=bullet)[1].decode(): b for b in bodies}
    for obj in scene.objects:
        assert np.allclose(link_position(names[obj.id], bullet), obj.pose.position, atol=1e-6), obj.id


def test_usd_has_a_rigid_body_per_movable_object_at_its_pose(base: Path, scene: Scene) -> None:
    """``pxr`` carries no simulator: the stage is checked for what Isaac Sim / Omniverse simulate."""
    stage = Usd.Stage.Open(str(base / "scene.usda"))
    prims = usd_object_prims(stage)
    for obj in scene.objects:
        prim = prims[obj.id]
        assert prim.HasAPI(UsdPhysics.RigidBodyAPI) == (not is_fixed(scene, obj)), obj.id
        world = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        assert np.allclose(np.asarray(world.ExtractTranslation()), obj.pose.position, atol=1e-5), obj.id
        assert obj.pose.position[2] > -REST_M


def test_load_pybullet_without_the_extra_names_the_pip_install(
    base: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "pybullet", None)
    with pytest.raises(MissingExtraError, match=PYBULLET_INSTALL_HINT.replace("[", r"\[").replace("]", r"\]")):
        load_pybullet(base)

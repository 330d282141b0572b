"""Issue 39: the delivered pose of drawers, doors and lids (``--open-state closed|open|random``).

A small room (a chest of drawers with a mug in its first drawer, a built-in fridge, a microwave)
is opened with :func:`open_scene` and written through the real exporters; each file must start
with the parts where the scene's metadata says, the joints' limits unchanged.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pybullet
import pytest
from simulator_checks import bullet_client

from scenemosaic.assets import (
    OPEN_STATE_KEY,
    PartSpec,
    interior_boards,
    object_articulation,
    open_scene,
    opening,
    part_openings,
)
from scenemosaic.exchange import export_glb, export_mjcf, export_sceneeval, export_urdf, load_pybullet
from scenemosaic.scene import AssetRef, House, Pose, Relation, Room, Scene, SceneObject, SimAttributes

MUG = "mug"


def _scene() -> Scene:
    dresser = SceneObject(
        id="dresser",
        category="dresser",
        asset=AssetRef(kind="procedural", extents=(1.19, 0.59, 1.09)),
        pose=Pose.from_yaw((2.0, 2.0, 0.0), math.radians(30.0)),
    )
    x0, x1, y0, y1, z0, _ = interior_boards("dresser", tuple(dresser.size))[0]
    inside = dresser.pose.matrix(with_scale=False) @ np.array([(x0 + x1) / 2, (y0 + y1) / 2, z0 + 1e-4, 1.0])
    mug = SceneObject(
        id=MUG,
        category="mug",
        asset=AssetRef(kind="box", extents=(0.08, 0.08, 0.1)),
        pose=Pose(position=tuple(float(v) for v in inside[:3]), quaternion=dresser.pose.quaternion),
        sim=SimAttributes(mass_kg=0.3),
    )
    fridge = SceneObject(
        id="fridge",
        category="fridge",
        asset=AssetRef(kind="procedural", extents=(0.97, 0.75, 2.04)),
        pose=Pose.from_yaw((5.5, 2.0, 0.0), math.radians(90.0)),
        sim=SimAttributes(static=True),
    )
    microwave = SceneObject(
        id="microwave",
        category="microwave",
        asset=AssetRef(kind="procedural", extents=(0.61, 0.35, 0.4)),
        pose=Pose.from_yaw((2.0, 5.5, 0.0), 0.0),
    )
    objects = [dresser, mug, fridge, microwave]
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in (dresser, fridge, microwave)]
    relations.append(Relation(kind="contain", child=MUG, parent="dresser"))
    return Scene(id="opened", room=Room.rectangle(0, 0, 8.0, 8.0), objects=objects, relations=relations)


@pytest.fixture(scope="module")
def closed() -> Scene:
    return _scene()


@pytest.fixture(scope="module")
def opened(closed: Scene) -> Scene:
    return open_scene(closed, "open")


def _parts(scene: Scene) -> list[tuple[SceneObject, PartSpec]]:
    return [(o, part) for o in scene.objects for part in object_articulation(o)]


# ---------------------------------------------------------------------------------------------
# the state itself
# ---------------------------------------------------------------------------------------------
def test_closed_leaves_the_scene_as_it_is(closed: Scene) -> None:
    assert open_scene(closed, "closed") is closed
    assert OPEN_STATE_KEY not in closed.metadata and part_openings(closed) == {}


def test_open_records_every_part_at_its_upper_limit_and_moves_the_drawers_contents(
    closed: Scene, opened: Scene
) -> None:
    openings = part_openings(opened)
    for obj, part in _parts(closed):
        assert openings[obj.id][part.name] == pytest.approx(part.limits[1])
    assert opened.metadata[OPEN_STATE_KEY]["state"] == "open"
    dresser = closed.get("dresser")
    drawer = object_articulation(dresser)[0]
    travel = dresser.pose.matrix(with_scale=False)[:3, :3] @ (np.asarray(drawer.axis) * drawer.limits[1])
    moved = np.asarray(opened.get(MUG).pose.position) - np.asarray(closed.get(MUG).pose.position)
    assert np.allclose(moved, travel, atol=1e-9) and np.linalg.norm(moved) > 0.4
    for other in ("dresser", "fridge", "microwave"):  # nothing else moves
        assert opened.get(other).pose == closed.get(other).pose
    # closing again puts the mug back
    again = open_scene(opened, "closed")
    assert OPEN_STATE_KEY not in again.metadata
    assert np.allclose(again.get(MUG).pose.position, closed.get(MUG).pose.position, atol=1e-9)


def test_random_is_reproducible_for_a_seed_and_differs_between_seeds(closed: Scene) -> None:
    first, same, other = (part_openings(open_scene(closed, "random", seed)) for seed in (3, 3, 4))
    assert first == same
    assert first != other
    values = [first[o.id][p.name] for o, p in _parts(closed)]
    for (obj, part), value in zip(_parts(closed), values, strict=True):
        assert part.limits[0] <= value <= part.limits[1]
        assert value == opening(part, "random", seed=3, key=obj.id)
    assert len(set(values)) == len(values)  # each part has its own draw


def test_a_house_records_the_state_in_every_room(closed: Scene) -> None:
    house = House(id="h", rooms=[closed])
    assert open_scene(house, "closed") is house
    opened = open_scene(house, "open", seed=2)
    assert (
        part_openings(opened)
        == part_openings(opened.rooms[0])
        == part_openings(open_scene(closed, "open", 2))
    )


# ---------------------------------------------------------------------------------------------
# MuJoCo
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def mjcf(opened: Scene, tmp_path_factory: pytest.TempPathFactory) -> mujoco.MjModel:
    path = export_mjcf(opened, tmp_path_factory.mktemp("open_mjcf"))
    return mujoco.MjModel.from_xml_path(str(path))


def test_mujoco_an_open_part_starts_displaced_by_its_opening_within_unchanged_limits(
    opened: Scene, mjcf: mujoco.MjModel
) -> None:
    data = mujoco.MjData(mjcf)
    mujoco.mj_forward(mjcf, data)
    for obj, part in _parts(opened):
        name = f"{obj.id}/{part.name}"
        joint = mjcf.joint(name)
        assert np.allclose(joint.range, part.limits)  # 0 is still closed
        assert data.qpos[mjcf.jnt_qposadr[joint.id]] == pytest.approx(
            part.limits[1], abs=1e-5
        )  # as written: 6 digits
        placed = obj.pose.matrix(with_scale=False) @ part.transform(part.limits[1])
        body = data.body(name)
        assert np.allclose(body.xpos, (placed @ np.array([*part.anchor, 1.0]))[:3], atol=1e-5)
        assert np.allclose(body.xmat.reshape(3, 3), placed[:3, :3], atol=1e-5)
    dresser = opened.get("dresser")
    drawer = object_articulation(dresser)[0]
    closed_anchor = (dresser.pose.matrix(with_scale=False) @ np.array([*drawer.anchor, 1.0]))[:3]
    shift = np.linalg.norm(data.body(f"dresser/{drawer.name}").xpos - closed_anchor)
    assert shift == pytest.approx(drawer.limits[1]) and shift >= 0.8 * drawer.depth
    # driven back to 0 the drawer is where the closed scene has it
    data.qpos[mjcf.jnt_qposadr[mjcf.joint(f"dresser/{drawer.name}").id]] = 0.0
    mujoco.mj_forward(mjcf, data)
    assert np.allclose(data.body(f"dresser/{drawer.name}").xpos, closed_anchor, atol=1e-6)


def test_mujoco_the_open_scene_rests_with_the_mug_in_its_drawer(opened: Scene, mjcf: mujoco.MjModel) -> None:
    data = mujoco.MjData(mjcf)
    mujoco.mj_forward(mjcf, data)
    start = data.xpos.copy()
    qpos = data.qpos.copy()
    fastest, previous = 0.0, data.xipos.copy()
    for _ in range(round(1.0 / mjcf.opt.timestep)):
        mujoco.mj_step(mjcf, data)
        fastest = max(fastest, float(np.linalg.norm(data.xipos - previous, axis=1).max()) / mjcf.opt.timestep)
        previous = data.xipos.copy()
    assert fastest < 5.0
    assert float(np.linalg.norm(data.xpos - start, axis=1).max()) < 0.05
    drawer = f"dresser/{object_articulation(opened.get('dresser'))[0].name}"
    address = mjcf.jnt_qposadr[mjcf.joint(drawer).id]
    assert abs(data.qpos[address] - qpos[address]) < 0.01  # it stays open
    local = data.body(drawer).xmat.reshape(3, 3).T @ (data.body(MUG).xpos - data.body(drawer).xpos)
    assert abs(local[0]) < 0.2 and abs(local[1]) < 0.25 and local[2] < 0.0  # still in the drawer


# ---------------------------------------------------------------------------------------------
# PyBullet, URDF and SDF
# ---------------------------------------------------------------------------------------------
@pytest.fixture
def bullet() -> Iterator[int]:
    with bullet_client() as client:
        yield client


def test_pybullet_load_pybullet_starts_every_part_at_its_opening(
    opened: Scene, tmp_path: Path, bullet: int
) -> None:
    export_urdf(opened, tmp_path)
    sdf = (tmp_path / "scene.sdf").read_text()
    assert sdf.count("<initial_position>") == len(_parts(opened))
    assert "delivered at" in (tmp_path / "scene.urdf").read_text()
    bodies = load_pybullet(tmp_path, client=bullet)
    for obj, part in _parts(opened):
        body = bodies[obj.id]
        joint = next(
            j
            for j in range(pybullet.getNumJoints(body, physicsClientId=bullet))
            if pybullet.getJointInfo(body, j, physicsClientId=bullet)[1].decode() == f"{obj.id}/{part.name}"
        )
        info = pybullet.getJointInfo(body, joint, physicsClientId=bullet)
        assert np.allclose(info[8:10], part.limits)
        assert pybullet.getJointState(body, joint, physicsClientId=bullet)[0] == pytest.approx(part.limits[1])
        if part.joint == "slide":  # the drawer's link stands out of the chest by its travel
            link = np.asarray(
                pybullet.getLinkState(body, joint, computeForwardKinematics=True, physicsClientId=bullet)[4]
            )
            closed_anchor = (obj.pose.matrix(with_scale=False) @ np.array([*part.anchor, 1.0]))[:3]
            assert np.linalg.norm(link - closed_anchor) == pytest.approx(part.limits[1], abs=1e-4)
    for _ in range(240):  # and stays there
        pybullet.stepSimulation(physicsClientId=bullet)
    drawer = object_articulation(opened.get("dresser"))[0]
    body = bodies["dresser"]
    state = pybullet.getJointState(
        body, _joint(body, f"dresser/{drawer.name}", bullet), physicsClientId=bullet
    )[0]
    assert state == pytest.approx(drawer.limits[1], abs=0.01)


def _joint(body: int, name: str, client: int) -> int:
    for j in range(pybullet.getNumJoints(body, physicsClientId=client)):
        if pybullet.getJointInfo(body, j, physicsClientId=client)[1].decode() == name:
            return j
    raise AssertionError(f"no joint {name}")


# ---------------------------------------------------------------------------------------------
# USD, GLB, sceneState
# ---------------------------------------------------------------------------------------------
def test_usd_an_open_part_body_stands_at_its_open_pose(opened: Scene, tmp_path: Path) -> None:
    from pxr import Usd, UsdGeom, UsdPhysics

    from scenemosaic.exchange import export_usd

    stage = Usd.Stage.Open(str(export_usd(opened, tmp_path)))
    for obj, part in _parts(opened):
        path = f"/World/Objects/{obj.id}_{part.name}"
        world = np.asarray(
            UsdGeom.Xformable(stage.GetPrimAtPath(path)).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        ).T
        placed = obj.pose.matrix(with_scale=False) @ part.transform(part.limits[1])
        assert np.allclose(world[:3, 3], (placed @ np.array([*part.anchor, 1.0]))[:3], atol=1e-6)
        assert np.allclose(world[:3, :3], placed[:3, :3], atol=1e-6)
        joint_prim = stage.GetPrimAtPath(f"{path}/joint")
        joint = (
            UsdPhysics.PrismaticJoint(joint_prim)
            if part.joint == "slide"
            else UsdPhysics.RevoluteJoint(joint_prim)
        )
        assert np.allclose(joint.GetLocalPos0Attr().Get(), part.anchor, atol=1e-6)  # the closed frames
        assert joint.GetLowerLimitAttr().Get() == 0.0


def test_glb_and_scene_state_carry_the_opening(opened: Scene, tmp_path: Path) -> None:
    import trimesh

    glb = trimesh.load(export_glb(opened, tmp_path / "scene.glb"))
    state = json.loads(export_sceneeval(opened, tmp_path / "sceneeval").read_text())
    listed = {o["id"]: o.get("parts", []) for o in state["scene"]["object"]}
    for obj, part in _parts(opened):
        matrix, _ = glb.graph.get(frame_to=f"{obj.id}/{part.name}", frame_from=obj.id)
        at = np.eye(4)
        at[:3, 3] = part.anchor
        assert np.allclose(matrix, part.transform(part.limits[1]) @ at, atol=1e-6)
        record = next(r for r in listed[obj.id] if r["name"] == part.name)
        assert record["value"] == pytest.approx(part.limits[1]) and record["limits"] == pytest.approx(
            part.limits
        )


# ---------------------------------------------------------------------------------------------
# closed: the files of today
# ---------------------------------------------------------------------------------------------
def test_closed_files_say_nothing_of_an_opening(closed: Scene, tmp_path: Path) -> None:
    export_mjcf(closed, tmp_path / "mjcf")
    export_urdf(closed, tmp_path / "urdf")
    state = json.loads(export_sceneeval(closed, tmp_path / "sceneeval").read_text())
    assert " ref=" not in (tmp_path / "mjcf" / "scene.xml").read_text()
    assert "initial_position" not in (tmp_path / "urdf" / "scene.sdf").read_text()
    assert "delivered at" not in (tmp_path / "urdf" / "scene.urdf").read_text()
    assert all("value" not in r for o in state["scene"]["object"] for r in o.get("parts", []))

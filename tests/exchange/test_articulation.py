"""Issue 39: furniture that opens, pulled the way a robot pulls it, in every simulator export.

One room holds a stand-in of every category of the shipped houses that opens (sizes as they come
there: the median of each category), each turned its own way; the fridge and the kitchen counter
are held in place as built-ins are. Through the real export path: ``scene.xml`` in MuJoCo,
``scene.sdf`` through ``load_pybullet`` and the per-object URDF in PyBullet, ``scene.urdf`` with
yourdfpy. A pull is a force at the handle along the way the handle moves as the part opens.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pybullet
import pytest
import yourdfpy
from simulator_checks import bullet_client

from scenemosaic.assets import PartSpec, interior_boards, object_articulation
from scenemosaic.exchange import export_mjcf, export_urdf, load_pybullet
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject, SimAttributes

OPENING = {
    # category: (size as in the shipped houses, yaw in degrees, held in place)
    "dresser": ((1.19, 0.59, 1.09), 0.0, False),
    "nightstand": ((0.61, 0.5, 0.71), 30.0, False),
    "desk": ((1.63, 0.66, 0.77), 90.0, False),
    "counter_top": ((1.83, 0.61, 0.94), 180.0, True),
    "wardrobe": ((2.32, 0.83, 2.27), -90.0, False),
    "fridge": ((0.97, 0.75, 2.04), 90.0, True),
    "microwave": ((0.61, 0.35, 0.4), 10.0, False),
    "washing_machine": ((0.67, 0.68, 1.14), -30.0, False),
    "toilet": ((0.54, 0.86, 0.95), 135.0, False),
    "box": ((0.38, 0.33, 0.34), 60.0, False),
    "safe": ((0.3, 0.33, 0.3), -120.0, False),
    "tv_stand": ((1.24, 0.52, 0.59), 45.0, False),
    "side_table": ((0.56, 0.5, 0.6), -60.0, False),
    "dressing_table": ((0.86, 0.61, 1.26), 0.0, False),
    "oven": ((0.76, 0.66, 0.92), 180.0, True),
    "dishwasher": ((0.6, 0.6, 0.85), 20.0, False),
}
PULL_N = {"drawer": 10.0, "door": 10.0, "lid": 3.0}
"""How hard the test pulls each kind of part at its handle, newtons, over what holds up the part's
weight (a lid's): the pull a robot's arm makes."""
DRAWER_OUT = 0.8
"""A drawer slides at least this fraction of its depth."""
HINGE_OPEN_DEG = 90.0
"""A door (or lid) turns at least this far."""
MAX_SPEED = 5.0
"""No body moves faster than this, m/s."""
REST_M = 0.01
"""With nothing pulled, no body moves more than this over :data:`REST_S`."""
REST_S = 2.0
ITEM = "mug_in_drawer"


def _object(i: int, category: str) -> SceneObject:
    size, yaw, held = OPENING[category]
    row, col = divmod(i, 4)
    return SceneObject(
        id=category,
        category=category,
        asset=AssetRef(kind="procedural", extents=size),
        pose=Pose.from_yaw((2.0 + 3.5 * col, 2.0 + 3.5 * row, 0.0), math.radians(yaw)),
        sim=SimAttributes(static=held),
    )


def _in_drawer(dresser: SceneObject) -> tuple[SceneObject, int]:
    """A mug standing in the middle of the dresser's bottom-left drawer (its first compartment)."""
    compartment = 0
    x0, x1, y0, y1, z0, _ = interior_boards("dresser", tuple(dresser.size))[compartment]
    local = np.array([(x0 + x1) / 2, (y0 + y1) / 2, z0 + 1e-4, 1.0])
    world = dresser.pose.matrix(with_scale=False) @ local
    mug = SceneObject(
        id=ITEM,
        category="mug",
        asset=AssetRef(kind="box", extents=(0.08, 0.08, 0.1)),
        pose=Pose(position=tuple(float(v) for v in world[:3]), quaternion=dresser.pose.quaternion),
        sim=SimAttributes(mass_kg=0.3),
    )
    return mug, compartment


@pytest.fixture(scope="module")
def scene() -> Scene:
    objects = [_object(i, c) for i, c in enumerate(OPENING)]
    mug, _ = _in_drawer(objects[0])
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    relations.append(Relation(kind="contain", child=mug.id, parent="dresser"))
    return Scene(id="opening", room=Room.rectangle(0, 0, 14.5, 15.0), objects=[*objects, mug], relations=relations)


@pytest.fixture(scope="module")
def folder(scene: Scene, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("articulation")
    export_mjcf(scene, out / "mjcf")
    export_urdf(scene, out / "urdf")
    return out


def _parts(scene: Scene) -> list[tuple[SceneObject, PartSpec]]:
    return [(o, part) for o in scene.objects for part in object_articulation(o)]


def test_every_category_that_opens_has_its_parts(scene: Scene) -> None:
    kinds = {o.id: {p.kind for p in object_articulation(o)} for o in scene.objects}
    for chest in ("dresser", "nightstand", "desk", "tv_stand", "side_table", "dressing_table"):
        assert kinds[chest] == {"drawer"}, chest
    for door in ("wardrobe", "fridge", "microwave", "washing_machine", "safe", "oven", "dishwasher"):
        assert kinds[door] == {"door"}, door
    assert kinds["counter_top"] == {"door", "drawer"}  # drawers under the top, a cupboard below
    assert kinds["toilet"] == kinds["box"] == {"lid"}
    assert kinds[ITEM] == set()
    # an oven's and a dishwasher's door drops down: hinged along its bottom edge, about +X
    for appliance in ("oven", "dishwasher"):
        (door,) = object_articulation(scene.get(appliance))
        assert door.axis == (1.0, 0.0, 0.0) and door.anchor[2] == pytest.approx(door.box[4])
        assert door.anchor[1] == pytest.approx(door.box[2], abs=0.03)  # on the front
        assert math.degrees(door.limits[1]) == pytest.approx(90.0)


# ---------------------------------------------------------------------------------------------
# MuJoCo
# ---------------------------------------------------------------------------------------------
def _handle_motion(part: PartSpec) -> tuple[np.ndarray, np.ndarray]:
    """The handle's centre in the part's frame, and the way it moves as the part opens (same frame)."""
    handle = part.handle_centre - np.asarray(part.anchor)
    axis = np.asarray(part.axis, dtype=np.float64)
    way = axis if part.joint == "slide" else np.cross(axis, handle)
    return handle, way / np.linalg.norm(way)


def _weight_at_handle(model: mujoco.MjModel, data: mujoco.MjData, body: int, part: PartSpec) -> float:
    """The force at the handle that holds the part's weight in its closed pose (0 for a slide or a
    vertical hinge), with a fifth more."""
    if part.joint == "slide":
        return 0.0
    rotation = data.xmat[body].reshape(3, 3)
    axis = rotation @ np.asarray(part.axis)
    weight = np.array([0.0, 0.0, -9.81 * float(model.body_mass[body])])
    torque = abs(float(axis @ np.cross(data.xipos[body] - data.xpos[body], weight)))
    handle = rotation @ (part.handle_centre - np.asarray(part.anchor))
    lever = float(np.linalg.norm(handle - axis * (axis @ handle)))
    return 1.2 * torque / lever


def _mujoco_pull(model: mujoco.MjModel, obj: SceneObject, part: PartSpec, seconds: float = 3.0) -> tuple[float, float, mujoco.MjData]:
    """Pull one part's handle in a fresh copy of the world: the joint value it reaches, and the
    fastest any body moved meanwhile (m/s)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = model.body(f"{obj.id}/{part.name}").id
    qpos = model.jnt_qposadr[model.joint(f"{obj.id}/{part.name}").id]
    handle, way = _handle_motion(part)
    force = PULL_N[part.kind] + _weight_at_handle(model, data, body, part)
    fastest = 0.0
    previous = data.xipos.copy()
    for _ in range(round(seconds / model.opt.timestep)):
        rotation = data.xmat[body].reshape(3, 3)
        data.qfrc_applied[:] = 0.0
        mujoco.mj_applyFT(
            model, data, rotation @ way * force, np.zeros(3), data.xpos[body] + rotation @ handle, body, data.qfrc_applied
        )
        mujoco.mj_step(model, data)
        fastest = max(fastest, float(np.linalg.norm(data.xipos - previous, axis=1).max()) / model.opt.timestep)
        previous = data.xipos.copy()
    return float(data.qpos[qpos]), fastest, data


def _opened_enough(part: PartSpec, value: float) -> bool:
    if part.joint == "slide":
        return value >= DRAWER_OUT * part.depth
    return math.degrees(value) >= HINGE_OPEN_DEG


def test_mujoco_every_part_opens_when_its_handle_is_pulled(folder: Path, scene: Scene) -> None:
    model = mujoco.MjModel.from_xml_path(str(folder / "mjcf" / "scene.xml"))
    failures = []
    for obj, part in _parts(scene):
        value, fastest, _ = _mujoco_pull(model, obj, part)
        lower, upper = part.limits
        ok = _opened_enough(part, value) and lower - 1e-3 <= value <= upper + 0.02 and fastest < MAX_SPEED
        if not ok:
            failures.append((obj.id, part.name, round(value, 3), round(upper, 3), round(fastest, 2)))
    assert not failures
    assert len(_parts(scene)) >= 25


def test_mujoco_joints_carry_the_parts_limits_damping_and_axes(folder: Path, scene: Scene) -> None:
    model = mujoco.MjModel.from_xml_path(str(folder / "mjcf" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for obj, part in _parts(scene):
        joint = model.joint(f"{obj.id}/{part.name}")
        kind = mujoco.mjtJoint.mjJNT_SLIDE if part.joint == "slide" else mujoco.mjtJoint.mjJNT_HINGE
        assert joint.type[0] == kind
        assert model.jnt_limited[joint.id]
        assert np.allclose(joint.range, part.limits)
        assert joint.damping[0] == pytest.approx(part.damping)
        assert joint.frictionloss[0] == pytest.approx(part.friction)
        # the axis, in the world, is the part's axis turned by the object's pose; the body sits at its anchor
        world = obj.pose.matrix(with_scale=False)
        assert np.allclose(data.xaxis[joint.id], world[:3, :3] @ np.asarray(part.axis), atol=1e-9)
        body = data.body(f"{obj.id}/{part.name}")
        assert np.allclose(body.xpos, (world @ np.array([*part.anchor, 1.0]))[:3], atol=1e-6)
        assert model.body(f"{obj.id}/{part.name}").parentid[0] == model.body(obj.id).id
    # a rigid object is one body on a free joint, as before
    mug = model.body(ITEM)
    assert mug.jntnum[0] == 1 and not any(model.body_parentid[b] == mug.id for b in range(model.nbody) if b != mug.id)


def test_mujoco_closed_scene_rests(folder: Path, scene: Scene) -> None:
    model = mujoco.MjModel.from_xml_path(str(folder / "mjcf" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    # a part never touches its own carcass, even on an object welded to the world (the fridge)
    for contact in data.contact[: data.ncon]:
        names = sorted(model.body(model.geom_bodyid[g]).name for g in (contact.geom1, contact.geom2))
        assert not names[1].startswith(names[0] + "/"), names
    start = data.xpos.copy()
    mujoco.mj_step(model, data, nstep=round(REST_S / model.opt.timestep))
    moved = np.linalg.norm(data.xpos - start, axis=1)
    assert float(moved.max()) < REST_M, model.body(int(moved.argmax())).name
    for obj, part in _parts(scene):
        value = data.qpos[model.jnt_qposadr[model.joint(f"{obj.id}/{part.name}").id]]
        assert abs(value) < (REST_M / 2 if part.joint == "slide" else math.radians(0.5)), (obj.id, part.name, value)


def test_mujoco_an_item_in_a_drawer_comes_out_with_it_and_stays_inside(folder: Path, scene: Scene) -> None:
    model = mujoco.MjModel.from_xml_path(str(folder / "mjcf" / "scene.xml"))
    dresser = scene.get("dresser")
    part = object_articulation(dresser)[0]
    compartment = interior_boards("dresser", tuple(dresser.size))[0]
    start = scene.get(ITEM).pose.position
    value, fastest, data = _mujoco_pull(model, dresser, part, seconds=2.0)
    assert value >= DRAWER_OUT * part.depth and fastest < MAX_SPEED
    moved = np.asarray(data.body(ITEM).xpos) - np.asarray(start)
    assert np.linalg.norm(moved) > value - 0.03  # it came out with the drawer (it may slide to its front)
    # in the drawer's frame it is still within the drawer's inside, on its bottom
    drawer = data.body(f"dresser/{part.name}")
    local = drawer.xmat.reshape(3, 3).T @ (data.body(ITEM).xpos - drawer.xpos) + np.asarray(part.anchor)
    x0, x1, y0, y1, z0, _ = compartment
    assert x0 < local[0] < x1 and y0 < local[1] < y1, local
    assert abs(local[2] - z0) < 0.01, local


# ---------------------------------------------------------------------------------------------
# PyBullet and URDF / SDF
# ---------------------------------------------------------------------------------------------
@pytest.fixture
def bullet() -> Iterator[int]:
    with bullet_client() as client:
        yield client


def _link(body: int, name: str, client: int) -> int:
    for j in range(pybullet.getNumJoints(body, physicsClientId=client)):
        if pybullet.getJointInfo(body, j, physicsClientId=client)[1].decode() == name:
            return j
    raise AssertionError(f"no joint {name}")


def _bullet_pull(body: int, joint: int, part: PartSpec, client: int, seconds: float = 3.0) -> tuple[float, float]:
    handle, way = _handle_motion(part)
    fastest = 0.0
    for _ in range(round(seconds * 240)):
        state = pybullet.getLinkState(body, joint, computeForwardKinematics=True, physicsClientId=client)
        rotation = np.asarray(pybullet.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        point = np.asarray(state[4]) + rotation @ handle
        pybullet.applyExternalForce(
            body, joint, (rotation @ way * PULL_N[part.kind]).tolist(), point.tolist(), pybullet.WORLD_FRAME,
            physicsClientId=client,
        )
        pybullet.stepSimulation(physicsClientId=client)
        speed = np.linalg.norm(
            pybullet.getLinkState(body, joint, computeLinkVelocity=True, physicsClientId=client)[6]
        )
        fastest = max(fastest, float(speed))
    return float(pybullet.getJointState(body, joint, physicsClientId=client)[0]), fastest


@pytest.mark.parametrize(
    ("object_id", "part_name"), [("dresser", "drawer_0"), ("fridge", "door_fridge"), ("wardrobe", "door_1"), ("oven", "door"), ("tv_stand", "drawer_1")]
)
def test_pybullet_load_pybullet_keeps_the_joints_and_a_pull_opens_them(
    folder: Path, scene: Scene, bullet: int, object_id: str, part_name: str
) -> None:
    bodies = load_pybullet(folder / "urdf", client=bullet)
    obj = scene.get(object_id)
    part = next(p for p in object_articulation(obj) if p.name == part_name)
    body = bodies[object_id]
    assert pybullet.getNumJoints(body, physicsClientId=bullet) == len(object_articulation(obj))
    joint = _link(body, f"{object_id}/{part_name}", bullet)
    info = pybullet.getJointInfo(body, joint, physicsClientId=bullet)
    kind = pybullet.JOINT_PRISMATIC if part.joint == "slide" else pybullet.JOINT_REVOLUTE
    assert info[2] == kind and np.allclose(info[8:10], part.limits)
    # closed and still after a second with nothing pulled
    for _ in range(240):
        pybullet.stepSimulation(physicsClientId=bullet)
    assert abs(pybullet.getJointState(body, joint, physicsClientId=bullet)[0]) < REST_M / 2
    value, fastest = _bullet_pull(body, joint, part, bullet)
    assert _opened_enough(part, value) and value <= part.limits[1] + 0.02 and fastest < MAX_SPEED, (value, fastest)


@pytest.mark.parametrize(("object_id", "part_name"), [("nightstand", "drawer_1"), ("counter_top", "door_0")])
def test_pybullet_the_per_object_urdf_opens_too(folder: Path, scene: Scene, bullet: int, object_id: str, part_name: str) -> None:
    urdf = folder / "urdf" / "urdf" / f"{object_id}.urdf"
    body = pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=bullet)
    obj = scene.get(object_id)
    part = next(p for p in object_articulation(obj) if p.name == part_name)
    joint = _link(body, f"{object_id}/{part_name}", bullet)
    friction = pybullet.getJointInfo(body, joint, physicsClientId=bullet)[7]
    assert friction == pytest.approx(part.friction)
    pybullet.setJointMotorControl2(body, joint, pybullet.VELOCITY_CONTROL, force=friction, physicsClientId=bullet)
    value, fastest = _bullet_pull(body, joint, part, bullet)
    assert _opened_enough(part, value) and fastest < MAX_SPEED, (value, fastest)


def test_scene_urdf_has_a_revolute_or_prismatic_joint_per_part(folder: Path, scene: Scene) -> None:
    urdf = yourdfpy.URDF.load(str(folder / "urdf" / "scene.urdf"), build_scene_graph=True, load_meshes=False)
    for obj, part in _parts(scene):
        joint = urdf.joint_map[f"{obj.id}/{part.name}"]
        assert joint.type == ("prismatic" if part.joint == "slide" else "revolute")
        assert joint.parent == obj.id and joint.child == f"{obj.id}/{part.name}"
        assert np.allclose(joint.axis, part.axis)
        assert (joint.limit.lower, joint.limit.upper) == pytest.approx(part.limits)
        assert float(joint.dynamics.damping) == pytest.approx(part.damping)  # yourdfpy keeps the text
        assert float(joint.dynamics.friction) == pytest.approx(part.friction)
        # the part's link sits at its anchor in the object's frame
        placed = urdf.get_transform(frame_to=f"{obj.id}/{part.name}", frame_from=obj.id)
        assert np.allclose(placed[:3, 3], part.anchor)
    assert urdf.joint_map[f"{ITEM}_joint"].type == "floating"


# ---------------------------------------------------------------------------------------------
# USD
# ---------------------------------------------------------------------------------------------
def test_usd_joint_prims_axes_and_limits_read_back(scene: Scene, tmp_path: Path) -> None:
    from pxr import Gf, Usd, UsdGeom, UsdPhysics

    from scenemosaic.exchange import export_usd

    stage = Usd.Stage.Open(str(export_usd(scene, tmp_path)))
    for obj, part in _parts(scene):
        path = f"/World/Objects/{obj.id}_{part.name}"
        body = stage.GetPrimAtPath(path)
        assert body.HasAPI(UsdPhysics.RigidBodyAPI) and body.GetCustomDataByKey("scenemosaic:part") == part.name
        world = np.asarray(UsdGeom.Xformable(body).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
        placed = obj.pose.matrix(with_scale=False)
        assert np.allclose(world[:3, 3], (placed @ np.array([*part.anchor, 1.0]))[:3], atol=1e-6)
        joint_prim = stage.GetPrimAtPath(f"{path}/joint")
        slide = part.joint == "slide"
        joint = UsdPhysics.PrismaticJoint(joint_prim) if slide else UsdPhysics.RevoluteJoint(joint_prim)
        assert joint_prim.IsA(UsdPhysics.PrismaticJoint if slide else UsdPhysics.RevoluteJoint)
        assert [str(t) for t in joint.GetBody0Rel().GetTargets()] == [f"/World/Objects/{obj.id}"]
        assert [str(t) for t in joint.GetBody1Rel().GetTargets()] == [path]
        # the joint's axis, turned by its frame, is the part's opening direction
        unit = np.eye(3)["XYZ".index(joint.GetAxisAttr().Get())]
        turn = Gf.Rotation(joint.GetLocalRot0Attr().Get())
        assert np.allclose(np.asarray(turn.TransformDir(Gf.Vec3d(*unit))), part.axis, atol=1e-6)
        assert np.allclose(joint.GetLocalPos0Attr().Get(), part.anchor, atol=1e-6)
        expected = part.limits if slide else tuple(math.degrees(v) for v in part.limits)
        assert (joint.GetLowerLimitAttr().Get(), joint.GetUpperLimitAttr().Get()) == pytest.approx(expected, abs=1e-4)
        # the part's pieces are under its prim, not the object's
        pieces = {p.GetName() for p in stage.GetPrimAtPath(f"{path}/collision").GetChildren()}
        assert pieces == {f"piece_{k}" for k in part.pieces}
        fixed = {p.GetName() for p in stage.GetPrimAtPath(f"/World/Objects/{obj.id}/collision").GetChildren()}
        assert not pieces & fixed


# ---------------------------------------------------------------------------------------------
# GLB and sceneState
# ---------------------------------------------------------------------------------------------
def test_glb_parts_are_child_nodes_at_their_anchors(scene: Scene, tmp_path: Path) -> None:
    import trimesh

    from scenemosaic.exchange import export_glb

    glb = trimesh.load(export_glb(scene, tmp_path / "scene.glb"))
    for obj in scene.objects:
        parts = object_articulation(obj)
        if not parts:
            continue
        lower, upper = np.full(3, np.inf), np.full(3, -np.inf)
        for node in [obj.id, *(f"{obj.id}/{p.name}" for p in parts)]:
            matrix, geometry = glb.graph.get(frame_to=node, frame_from=obj.id)
            points = trimesh.transform_points(glb.geometry[geometry].vertices, matrix)
            lower, upper = np.minimum(lower, points.min(axis=0)), np.maximum(upper, points.max(axis=0))
        for part in parts:
            matrix, _ = glb.graph.get(frame_to=f"{obj.id}/{part.name}", frame_from=obj.id)
            assert np.allclose(matrix[:3, 3], part.anchor) and np.allclose(matrix[:3, :3], np.eye(3))
        # the object's node and its parts' nodes together fill the object's box, closed
        w, d, h = obj.size
        assert np.allclose(lower, [-w / 2, -d / 2, 0.0], atol=1e-6) and np.allclose(upper, [w / 2, d / 2, h], atol=1e-6)


def test_scene_state_lists_the_parts(scene: Scene, tmp_path: Path) -> None:
    import json

    from scenemosaic.exchange import LOCAL_TO_GLTF, export_sceneeval

    state = json.loads(export_sceneeval(scene, tmp_path).read_text())
    listed = {o["id"]: o.get("parts", []) for o in state["scene"]["object"]}
    assert listed[ITEM] == []
    for obj in scene.objects:
        parts = object_articulation(obj)
        assert [p["name"] for p in listed[obj.id]] == [p.name for p in parts]
        for record, part in zip(listed[obj.id], parts, strict=True):
            assert record["joint"] == part.joint and record["limits"] == pytest.approx(part.limits)
            assert np.allclose(LOCAL_TO_GLTF[:3, :3].T @ np.asarray(record["axis"]), part.axis)


# ---------------------------------------------------------------------------------------------
# A laptop: built open, its lid shuts
# ---------------------------------------------------------------------------------------------
def test_mujoco_a_laptop_rests_open_and_its_lid_shuts_when_pushed(tmp_path: Path) -> None:
    laptop = SceneObject(
        id="laptop",
        category="laptop",
        asset=AssetRef(kind="procedural", extents=(0.36, 0.3, 0.31)),
        pose=Pose.from_yaw((1.0, 1.0, 0.0), math.radians(25.0)),
    )
    (part,) = object_articulation(laptop)
    assert part.kind == "lid" and part.limits[1] == 0.0 and math.degrees(-part.limits[0]) > 90.0
    scene = Scene(id="desk", room=Room.rectangle(0, 0, 2.0, 2.0), objects=[laptop], relations=[Relation(kind="attach", child="laptop", parent="floor")])
    model = mujoco.MjModel.from_xml_path(str(export_mjcf(scene, tmp_path)))
    qpos = model.jnt_qposadr[model.joint("laptop/lid").id]
    # with nothing pushed the lid stays as built, against its upper limit
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.xpos.copy()
    mujoco.mj_step(model, data, nstep=round(REST_S / model.opt.timestep))
    assert float(np.linalg.norm(data.xpos - start, axis=1).max()) < REST_M and abs(data.qpos[qpos]) < math.radians(0.5)
    # pushed at the top of the screen toward the keyboard, it shuts (a turn of more than a right angle)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = model.body("laptop/lid").id
    handle, way = _handle_motion(part)
    fastest, previous = 0.0, data.xipos.copy()
    for _ in range(round(3.0 / model.opt.timestep)):
        rotation = data.xmat[body].reshape(3, 3)
        data.qfrc_applied[:] = 0.0
        mujoco.mj_applyFT(model, data, -rotation @ way * PULL_N["lid"], np.zeros(3), data.xpos[body] + rotation @ handle, body, data.qfrc_applied)
        mujoco.mj_step(model, data)
        fastest = max(fastest, float(np.linalg.norm(data.xipos - previous, axis=1).max()) / model.opt.timestep)
        previous = data.xipos.copy()
    value = float(data.qpos[qpos])
    assert -value >= math.radians(HINGE_OPEN_DEG) and value >= part.limits[0] - 0.02 and fastest < MAX_SPEED, (math.degrees(value), fastest)

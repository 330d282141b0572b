"""Issue 39: the rooms' doors as hinged leaves on their doorways, in every simulator export.

A small room with one door (and, beside it, a wardrobe where the leaf would first swing), pushed
the way a robot pushes a door at its handle: in MuJoCo from ``scene.xml`` (shut from its
delivered open pose, and opened from shut), in PyBullet through ``load_pybullet``; the USD joint
read back with usd-core; the GLB node and the sceneState record. The delivered room, and (marked
``house``) a whole delivered ProcTHOR house, check that the scene and its navigation figures do
not hold the doors while the files do.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pybullet
import pytest
from shapely.geometry import MultiPoint, Polygon
from simulator_checks import bullet_client

from scenemosaic.assets import (
    ROOM_DOOR_JAMB_M,
    ROOM_DOOR_LEAF_M,
    ROOM_DOOR_OPEN_DEG,
    PartSpec,
    open_scene,
    procedural_articulation,
    procedural_parts,
    room_door_leaves,
    with_room_doors,
)
from scenemosaic.exchange import load_pybullet, write_scene
from scenemosaic.physics import pull_parts
from scenemosaic.scene import AssetRef, Opening, Pose, Relation, Room, Scene, SceneObject

PUSH_N = 20.0
"""How hard the test pushes a leaf at its handle, newtons (a 20 kg door: a firm push)."""
TURNED_DEG = 90.0
"""A pushed leaf turns at least this far."""
MAX_SPEED = 5.0
"""No body moves faster than this, m/s."""
DOOR = "room_door_0"


def _room(*, leaves: int | None = None, wardrobe: bool = True) -> Scene:
    """A 4 x 3 m room, a 0.9 m door in its south wall (centre at x = 1.2 m); a wardrobe against
    that wall just east of the door, where a leaf hung on its left jamb (seen from the room) would
    swing; a dresser against the north wall."""
    room = Room.rectangle(0, 0, 4.0, 3.0)
    door = Opening(kind="door", center=1.2, width=0.9, height=2.1, leaves=leaves)
    south = room.walls[0].model_copy(update={"openings": [door]})
    room = room.model_copy(update={"walls": [south, *room.walls[1:]]})
    objects = [
        SceneObject(
            id="dresser",
            category="dresser",
            asset=AssetRef(kind="procedural", extents=(1.19, 0.59, 1.09)),
            pose=Pose.from_yaw((3.0, 2.65, 0.0), 0.0),
        )
    ]
    if wardrobe:
        objects.append(
            SceneObject(
                id="wardrobe",
                category="wardrobe",
                asset=AssetRef(kind="procedural", extents=(1.0, 0.6, 2.0)),
                pose=Pose.from_yaw((2.2, 0.32, 0.0), math.pi),
            )
        )
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    return Scene(id="hall", room=room, objects=objects, relations=relations)


def _leaf(obj: SceneObject) -> PartSpec:
    return procedural_articulation(obj.category, obj.asset.extents)[0]


def _outline(obj: SceneObject, part: PartSpec, value: float) -> Polygon:
    pieces = procedural_parts(obj.category, obj.asset.extents)
    local = np.concatenate([pieces[i].vertices for i in part.pieces])
    world = (obj.pose.matrix() @ part.transform(value) @ np.c_[local, np.ones(len(local))].T).T[:, :2]
    hull = MultiPoint([tuple(p) for p in world]).convex_hull
    assert isinstance(hull, Polygon)
    return hull


# ---------------------------------------------------------------------------------------------
# The rules: which holes, which jamb, how far
# ---------------------------------------------------------------------------------------------
def test_a_door_hangs_in_its_hole_open_and_clear_of_the_furniture() -> None:
    free = room_door_leaves(_room(wardrobe=False))
    assert [d.object.category for d in free] == ["room_door"]  # the left jamb, seen from the room
    (door,) = room_door_leaves(_room())
    obj, part = door.object, _leaf(door.object)
    assert obj.id == DOOR and obj.sim.static and door.rooms == ("hall",)
    assert obj.category == "room_door_right"  # the wardrobe stands where the left-hung leaf swings
    assert door.open_values == {"leaf": pytest.approx(math.radians(ROOM_DOOR_OPEN_DEG))}
    assert part.kind == "door" and part.joint == "hinge" and part.limits[0] == 0.0 and part.damping > 0
    # shut, the leaf fills the hole in the wall's face; open, it is clear of the wardrobe and beside the passage
    shut = _outline(obj, part, 0.0)
    assert 0.75 <= shut.bounds[0] < shut.bounds[2] <= 1.65 and shut.bounds[2] - shut.bounds[0] > 0.85
    opened = _outline(obj, part, door.open_values["leaf"])
    wardrobe = Polygon(_room().get("wardrobe").footprint())
    assert opened.intersection(wardrobe).area < 1e-6
    passage = Polygon([(0.75, 0.0), (1.65, 0.0), (1.65, 0.6), (0.75, 0.6)])
    edge = ROOM_DOOR_JAMB_M + ROOM_DOOR_LEAF_M + 0.005  # the jamb and the leaf's thickness, no more
    assert opened.intersection(passage).area < edge * 0.9


def test_frames_windows_and_open_stretches_get_no_leaf_and_a_double_door_two() -> None:
    assert room_door_leaves(_room(leaves=0)) == []
    scene = _room()
    plain = scene.model_copy(update={"room": Room.rectangle(0, 0, 4.0, 3.0)})
    assert with_room_doors(plain) is plain  # no door: the scene (and every file) as before
    (double,) = room_door_leaves(_room(leaves=2, wardrobe=False))
    assert double.object.category == "room_double_door" and sorted(double.open_values) == ["leaf_0", "leaf_1"]


def test_the_delivered_pose_follows_the_open_state() -> None:
    scene = _room()
    full = math.radians(ROOM_DOOR_OPEN_DEG)

    def value(s: Scene) -> float:
        hung = with_room_doors(s)
        assert isinstance(hung, Scene) and hung.get(DOOR)
        return float(hung.metadata["open_state"]["parts"].get(DOOR, {}).get("leaf", 0.0))

    assert value(scene) == pytest.approx(full)  # by default: furniture shut, the room's door open
    assert value(open_scene(scene, None)) == pytest.approx(full)
    assert value(open_scene(scene, "open")) == pytest.approx(full)
    assert value(open_scene(scene, "closed")) == 0.0  # --open-state closed shuts the doors too
    drawn = value(open_scene(scene, "random", seed=3))
    assert 0.0 < drawn < full and drawn == value(open_scene(scene, "random", seed=3))
    assert "open_state" not in scene.metadata and "open_state" in open_scene(scene, "closed").metadata


# ---------------------------------------------------------------------------------------------
# MuJoCo
# ---------------------------------------------------------------------------------------------
def _mujoco_push(
    model: mujoco.MjModel, obj: SceneObject, part: PartSpec, way: float, seconds: float = 4.0
) -> tuple[float, float]:
    """Push the leaf at its handle, ``way`` +1 opening and -1 shutting, in a fresh copy of the
    world: the joint value it reaches and the fastest any body moved (m/s)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    name = f"{obj.id}/{part.name}"
    body, qpos = model.body(name).id, model.jnt_qposadr[model.joint(name).id]
    handle = part.handle_centre - np.asarray(part.anchor)
    push = np.cross(np.asarray(part.axis), handle)
    push *= way * PUSH_N / np.linalg.norm(push)
    fastest, previous = 0.0, data.xipos.copy()
    for _ in range(round(seconds / model.opt.timestep)):
        rotation = data.xmat[body].reshape(3, 3)
        data.qfrc_applied[:] = 0.0
        point = data.xpos[body] + rotation @ handle
        mujoco.mj_applyFT(model, data, rotation @ push, np.zeros(3), point, body, data.qfrc_applied)
        mujoco.mj_step(model, data)
        fastest = max(
            fastest, float(np.linalg.norm(data.xipos - previous, axis=1).max()) / model.opt.timestep
        )
        previous = data.xipos.copy()
    return float(data.qpos[qpos]), fastest


def test_mujoco_the_leaf_is_delivered_open_and_a_push_shuts_it_or_opens_it(tmp_path: Path) -> None:
    scene = _room()
    (door,) = room_door_leaves(scene)
    part = _leaf(door.object)
    model = mujoco.MjModel.from_xml_path(str(write_scene(scene, "mjcf", tmp_path / "open")))
    joint = model.joint(f"{DOOR}/leaf")
    assert model.jnt_type[joint.id] == mujoco.mjtJoint.mjJNT_HINGE
    assert np.allclose(model.jnt_range[joint.id], part.limits, atol=1e-5)
    assert model.dof_damping[model.jnt_dofadr[joint.id]] == pytest.approx(part.damping, rel=1e-4)
    assert model.body_parentid[model.body(DOOR).id] == 0  # the frame: welded to the world at the doorway
    assert model.qpos0[model.jnt_qposadr[joint.id]] == pytest.approx(part.limits[1], abs=1e-5)
    # open, nothing of the leaf presses into the furniture
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    leaf = model.body(f"{DOOR}/leaf").id
    for c in data.contact[: data.ncon]:
        bodies = {int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])}
        assert leaf not in bodies or c.dist > -0.005, [model.body(b).name for b in bodies]
    shut, fastest = _mujoco_push(model, door.object, part, -1.0)
    assert math.degrees(part.limits[1] - shut) >= TURNED_DEG and shut >= part.limits[0] - 1e-3
    assert fastest < MAX_SPEED
    closed = mujoco.MjModel.from_xml_path(
        str(write_scene(open_scene(scene, "closed"), "mjcf", tmp_path / "shut"))
    )
    assert closed.qpos0[closed.jnt_qposadr[closed.joint(f"{DOOR}/leaf").id]] == 0.0
    opened, fastest = _mujoco_push(closed, door.object, part, 1.0)
    assert math.degrees(opened) >= TURNED_DEG and opened <= part.limits[1] + 0.02 and fastest < MAX_SPEED


# ---------------------------------------------------------------------------------------------
# PyBullet, USD, GLB, sceneState
# ---------------------------------------------------------------------------------------------
def test_pybullet_load_pybullet_hangs_the_leaf_and_a_push_opens_it(tmp_path: Path) -> None:
    scene = open_scene(_room(), "closed")
    (door,) = room_door_leaves(scene)
    part = _leaf(door.object)
    write_scene(scene, "urdf", tmp_path)
    with bullet_client() as client:
        bodies = load_pybullet(tmp_path, client=client)
        body = bodies[DOOR]
        (joint,) = range(pybullet.getNumJoints(body, physicsClientId=client))
        info = pybullet.getJointInfo(body, joint, physicsClientId=client)
        assert info[1].decode() == f"{DOOR}/leaf" and info[2] == pybullet.JOINT_REVOLUTE
        assert np.allclose(info[8:10], part.limits)
        handle = part.handle_centre - np.asarray(part.anchor)
        way = np.cross(np.asarray(part.axis), handle)
        way /= np.linalg.norm(way)
        fastest = 0.0
        for _ in range(4 * 240):
            state = pybullet.getLinkState(body, joint, computeForwardKinematics=True, physicsClientId=client)
            rotation = np.asarray(pybullet.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            pybullet.applyExternalForce(
                body, joint, (rotation @ way * PUSH_N).tolist(), (np.asarray(state[4]) + rotation @ handle).tolist(),
                pybullet.WORLD_FRAME, physicsClientId=client,
            )  # fmt: skip
            pybullet.stepSimulation(physicsClientId=client)
            speed = pybullet.getLinkState(body, joint, computeLinkVelocity=True, physicsClientId=client)[6]
            fastest = max(fastest, float(np.linalg.norm(speed)))
        value = pybullet.getJointState(body, joint, physicsClientId=client)[0]
    assert math.degrees(value) >= TURNED_DEG and value <= part.limits[1] + 0.02 and fastest < MAX_SPEED


def test_usd_the_leaf_is_a_revolute_joint_with_its_axis_and_limits(tmp_path: Path) -> None:
    from pxr import Gf, Usd, UsdPhysics

    scene = _room()
    (door,) = room_door_leaves(scene)
    part = _leaf(door.object)
    stage = Usd.Stage.Open(str(write_scene(scene, "usd", tmp_path)))
    prim = stage.GetPrimAtPath(f"/World/Objects/{DOOR}_leaf/joint")
    assert prim.IsA(UsdPhysics.RevoluteJoint)
    joint = UsdPhysics.RevoluteJoint(prim)
    unit = np.eye(3)["XYZ".index(joint.GetAxisAttr().Get())]
    turn = Gf.Rotation(joint.GetLocalRot0Attr().Get())
    assert np.allclose(np.asarray(turn.TransformDir(Gf.Vec3d(*unit))), part.axis, atol=1e-6)
    limits = (joint.GetLowerLimitAttr().Get(), joint.GetUpperLimitAttr().Get())
    assert limits == pytest.approx((0.0, ROOM_DOOR_OPEN_DEG), abs=1e-4)
    assert [str(t) for t in joint.GetBody0Rel().GetTargets()] == [f"/World/Objects/{DOOR}"]


def test_glb_hangs_the_leaf_and_scene_state_keeps_it_on_the_hole_not_among_objects(tmp_path: Path) -> None:
    """SceneEval reads a room's doors from the arch's holes: a leaf listed as an object is counted
    out of bounds and occluding its own doorway (issue 53), so the sceneState keeps it on the hole."""
    import trimesh

    scene = _room()
    glb = trimesh.load(write_scene(scene, "glb", tmp_path / "scene.glb"))
    assert f"{DOOR}/leaf" in glb.graph.nodes and DOOR in glb.graph.nodes
    state = json.loads(write_scene(scene, "sceneeval", tmp_path / "sceneeval").read_text())
    listed = {o["id"]: o.get("parts", []) for o in state["scene"]["object"]}
    assert DOOR not in listed and sorted(listed) == ["dresser", "wardrobe"]
    assert [p["name"] for p in listed["dresser"]] == [
        p.name for p in procedural_articulation("dresser", (1.19, 0.59, 1.09))
    ]
    holes = [h for e in state["scene"]["arch"]["elements"] if e["type"] == "Wall" for h in e["holes"]]
    (hole,) = holes
    (door,) = room_door_leaves(scene)
    hinge = door.object.pose.matrix(with_scale=False) @ np.array([*_leaf(door.object).anchor, 1.0])
    assert hole["type"] == "Door" and hole["leaf"]["leaves"] == 1 and hole["leaf"]["swingsInto"] == "hall"
    np.testing.assert_allclose(hole["leaf"]["hinges"], [hinge[:2]], atol=1e-6)
    assert hole["leaf"]["openDeg"] == [pytest.approx(math.degrees(door.open_values["leaf"]), abs=1e-3)]
    assert hole["leaf"]["limitDeg"] == [pytest.approx(ROOM_DOOR_OPEN_DEG)]
    shut = scene.model_copy(update={"metadata": {"open_state": {"state": "closed", "seed": 0}}})
    state = json.loads(write_scene(shut, "sceneeval", tmp_path / "shut").read_text())
    (hole,) = [h for e in state["scene"]["arch"]["elements"] if e["type"] == "Wall" for h in e["holes"]]
    assert hole["leaf"]["openDeg"] == [0.0]


# ---------------------------------------------------------------------------------------------
# The delivered scene and its navigation figures hold no leaf
# ---------------------------------------------------------------------------------------------
def test_a_delivered_room_keeps_its_doorway_free_and_its_files_hang_the_door(tmp_path: Path) -> None:
    from scenemosaic.exchange import deliver_scene, read_scene
    from scenemosaic.metrics import nav
    from scenemosaic.scene import cut_off_doors, door_blockers

    scene = _room()
    deliver_scene(scene, tmp_path, None)
    saved = read_scene(tmp_path)
    assert [o.id for o in saved.objects] == [o.id for o in scene.objects]
    assert saved.room is not None and saved.room.walls[0].openings[0].kind == "door"
    assert door_blockers(saved) == door_blockers(scene) == [] and cut_off_doors(saved) == []
    assert nav(saved) == nav(scene)
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "scene.xml"))
    assert model.body(f"{DOOR}/leaf").id > 0 and "open_state" not in saved.metadata


# ---------------------------------------------------------------------------------------------
# A whole house: the delivered scene and its navigation figures hold no leaf
# ---------------------------------------------------------------------------------------------
@pytest.mark.house
def test_a_delivered_house_hangs_its_doors_and_its_navigation_is_unchanged(tmp_path: Path) -> None:
    from scenemosaic.exchange import deliver_scene, load_house, read_house
    from scenemosaic.metrics import house_checks

    source = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"
    house = load_house(source)
    doors = room_door_leaves(house)
    assert len(doors) == sum(1 for d in house.doorways() if d.kind == "door")
    deliver_scene(house, tmp_path, source.parent)
    saved = read_house(tmp_path)
    assert not any(o.category.startswith("room_") for o in saved.objects)
    assert house_checks(saved) == house_checks(house)  # nav, door blockers, reach: as without leaves
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for door in doors:
        for name, value in door.open_values.items():
            joint = model.joint(f"{door.object.id}/{name}")
            assert model.qpos0[model.jnt_qposadr[joint.id]] == pytest.approx(value, abs=1e-5)
    leaves = {model.body(f"{d.object.id}/{n}").id for d in doors for n in d.open_values}
    for c in data.contact[: data.ncon]:
        bodies = {int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])}
        assert not (bodies & leaves) or c.dist > -0.005, [model.body(b).name for b in bodies]


def _corner_room() -> Scene:
    """A 4 x 3 m room with two doors near its south-east corner, one in the south wall and one in
    the east wall, whose leaves, hung on the jambs nearest the corner, would swing into each other."""
    room = Room.rectangle(0, 0, 4.0, 3.0)
    walls = list(room.walls)
    for k, wall in enumerate(walls):
        ends = np.array([wall.start, wall.end])
        if np.allclose(ends[:, 1], 0.0):  # the south wall: its door 0.75 m from the corner
            corner = 4.0 - 0.75 - 0.45
            walls[k] = wall.model_copy(update={"openings": [Opening(kind="door", center=abs(corner - wall.start[0]), width=0.9, height=2.1)]})
        if np.allclose(ends[:, 0], 4.0):  # the east wall: its door 0.45 m from the corner
            walls[k] = wall.model_copy(update={"openings": [Opening(kind="door", center=abs(0.9 - wall.start[1]), width=0.9, height=2.1)]})
    return Scene(id="corner", room=room.model_copy(update={"walls": walls}), objects=[])


def test_two_doors_by_one_corner_swing_clear_of_each_other(tmp_path: Path) -> None:
    """The later door is hung where its leaf does not sweep through the earlier one's (the 10-room
    house had two leaves meeting at 77 degrees); in MuJoCo every leaf swings from shut to its stop."""
    scene = _corner_room()
    doors = room_door_leaves(scene)
    assert len(doors) == 2
    sweeps = []
    for door in doors:
        part = _leaf(door.object)
        angles = np.linspace(0.0, door.open_values[part.name], 21)
        sweeps.append(MultiPoint(np.vstack([np.asarray(_outline(door.object, part, a).exterior.coords) for a in angles])).convex_hull)
        assert door.open_values[part.name] == pytest.approx(math.radians(ROOM_DOOR_OPEN_DEG))
    assert sweeps[0].intersection(sweeps[1]).area < 1e-4
    pulled = pull_parts(write_scene(scene, "mjcf", tmp_path))
    assert len(pulled) == 2 and all(p.room_door and p.passed for p in pulled), pulled

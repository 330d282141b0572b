"""Issue 39: a mesh asset declares its drawers, doors and lids in ``<stem>.parts.json`` beside it.

A cabinet made of three closed boxes (a carcass, a door leaf in front of it, a handle on the
leaf) is written as an OBJ with a declaration of its door, and goes through the real export
path: the door is a hinged body in MuJoCo that opens when its handle is pulled, a node of its own
in the GLB, a part in the sceneState; the declaration travels with the mesh when the scene is
saved; a malformed one is refused naming the file.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from scenemosaic.assets import (
    PARTS_FILE_SUFFIX,
    HullCache,
    object_articulation,
    object_part_meshes,
    referenced_files,
)
from scenemosaic.exceptions import AssetError
from scenemosaic.exchange import export_glb, export_mjcf, export_sceneeval, read_scene, save_scene
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject, SimAttributes

IDENTITY = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0]
DOOR = {
    "name": "door",
    "kind": "door",
    "box": [-0.28, 0.28, -0.225, -0.203, 0.03, 0.77],
    "hinge": "-x",
    "handle": [0.2, 0.23, -0.225, -0.215, 0.35, 0.45],
}
PULL_N = 10.0


def _write_cabinet(folder: Path, parts: object) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    boxes = [
        [[-0.3, -0.2, 0.0], [0.3, 0.225, 0.8]],  # carcass
        [[-0.28, -0.215, 0.03], [0.28, -0.203, 0.77]],  # door leaf, 3 mm in front of it
        [[0.2, -0.225, 0.35], [0.23, -0.215, 0.45]],  # handle near the free (+X) edge
    ]
    mesh = trimesh.util.concatenate([trimesh.creation.box(bounds=b) for b in boxes])
    mesh.export(folder / "cabinet.obj")
    (folder / f"cabinet{PARTS_FILE_SUFFIX}").write_text(json.dumps({"parts": parts}))


def _scene(scale: float = 1.0) -> Scene:
    cabinet = SceneObject(
        id="cabinet",
        category="cabinet",
        asset=AssetRef(kind="mesh", uri="cabinet.obj", extents=(0.6, 0.45, 0.8), source_transform=IDENTITY),
        pose=Pose.from_yaw((1.2, 1.2, 0.0), math.radians(30.0), scale=(scale, scale, scale)),
        sim=SimAttributes(static=True),
    )
    return Scene(
        id="declared",
        room=Room.rectangle(0, 0, 2.5, 2.5),
        objects=[cabinet],
        relations=[Relation(kind="attach", child="cabinet", parent="floor")],
    )


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("declared")
    _write_cabinet(out, [DOOR])
    return out


@pytest.fixture(scope="module")
def hulls(tmp_path_factory: pytest.TempPathFactory) -> HullCache:
    return HullCache(tmp_path_factory.mktemp("hulls"))


def test_the_declaration_becomes_a_part_by_the_rules_of_the_procedural_doors(folder: Path) -> None:
    (door,) = object_articulation(_scene().objects[0], folder)
    assert door.kind == "door" and door.joint == "hinge" and door.axis == (0.0, 0.0, -1.0)
    assert door.anchor[0] == pytest.approx(-0.28) and math.degrees(door.limits[1]) == pytest.approx(110.0)
    assert door.pieces == ()  # the exports pick them among the convex pieces
    # scaled with the object
    (bigger,) = object_articulation(_scene(1.5).objects[0], folder)
    assert bigger.box == pytest.approx(tuple(1.5 * v for v in door.box))
    # a mesh without a declaration has no parts
    assert object_articulation(_scene().objects[0], folder / "elsewhere") == []


def test_mujoco_the_declared_door_opens_when_its_handle_is_pulled(
    folder: Path, hulls: HullCache, tmp_path: Path
) -> None:
    scene = _scene()
    model = mujoco.MjModel.from_xml_path(str(export_mjcf(scene, tmp_path, folder, hull_cache=hulls)))
    joint = model.joint("cabinet/door")
    assert joint.type[0] == mujoco.mjtJoint.mjJNT_HINGE and math.degrees(joint.range[1]) == pytest.approx(
        110.0, abs=1e-3
    )
    body = model.body("cabinet/door").id
    door_geoms = [
        model.geom(g).name
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == body and model.geom_contype[g]
    ]
    assert door_geoms  # its own convex pieces, apart from the carcass's
    (door,) = object_articulation(scene.objects[0], folder)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    handle = door.handle_centre - np.asarray(door.anchor)
    way = np.cross(np.asarray(door.axis), handle)
    way /= np.linalg.norm(way)
    fastest, previous = 0.0, data.xipos.copy()
    for _ in range(round(3.0 / model.opt.timestep)):
        rotation = data.xmat[body].reshape(3, 3)
        data.qfrc_applied[:] = 0.0
        mujoco.mj_applyFT(
            model,
            data,
            rotation @ way * PULL_N,
            np.zeros(3),
            data.xpos[body] + rotation @ handle,
            body,
            data.qfrc_applied,
        )
        mujoco.mj_step(model, data)
        fastest = max(
            fastest, float(np.linalg.norm(data.xipos - previous, axis=1).max()) / model.opt.timestep
        )
        previous = data.xipos.copy()
    value = float(data.qpos[model.jnt_qposadr[joint.id]])
    assert math.degrees(value) >= 90.0 and value <= door.limits[1] + 0.02 and fastest < 5.0, (
        math.degrees(value),
        fastest,
    )


def test_glb_and_scene_state_carry_the_declared_part(folder: Path, tmp_path: Path) -> None:
    scene = _scene()
    meshes = object_part_meshes(scene.objects[0], folder)
    assert set(meshes) == {None, "door"}
    lower, upper = meshes["door"].bounds
    assert lower[1] == pytest.approx(-0.225) and upper[1] == pytest.approx(-0.203)  # the leaf and its handle
    glb = trimesh.load(export_glb(scene, tmp_path / "scene.glb", folder))
    assert "cabinet/door" in glb.graph.nodes
    state = json.loads(export_sceneeval(scene, tmp_path / "sceneeval", folder).read_text())
    (record,) = next(o for o in state["scene"]["object"] if o["id"] == "cabinet")["parts"]
    assert record["name"] == "door" and record["joint"] == "hinge"


def test_the_declaration_travels_with_the_mesh(folder: Path, tmp_path: Path) -> None:
    assert ("cabinet.parts.json", folder / "cabinet.parts.json") in referenced_files(folder / "cabinet.obj")
    save_scene(_scene(), tmp_path / "saved", base_dir=folder)
    saved = read_scene(tmp_path / "saved")
    assert [p.name for p in object_articulation(saved.objects[0], tmp_path / "saved")] == ["door"]


@pytest.mark.parametrize(
    ("parts", "problem"),
    [
        ([{**DOOR, "kind": "hatch"}], "kind must be drawer, door or lid"),
        ([{**DOOR, "box": [0, 1, 0, 1, 0]}], "six numbers"),
        ([{**DOOR, "box": [1, 0, 0, 1, 0, 1]}], "lower bound below its upper"),
        ([{**DOOR, "hinge": "top"}], "hinge must be -x, +x or bottom"),
        ([DOOR, DOOR], "two parts share a name"),
        ({"door": DOOR}, "'parts' is a list"),
    ],
)
def test_a_malformed_declaration_is_refused_naming_its_file(
    tmp_path: Path, parts: object, problem: str
) -> None:
    _write_cabinet(tmp_path, parts)
    with pytest.raises(AssetError, match=re.escape(problem)) as caught:
        object_articulation(_scene().objects[0], tmp_path)
    assert "cabinet.parts.json" in str(caught.value)

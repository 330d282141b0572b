"""Reading a written scene or house back the way its users do, for the tests: MuJoCo
(``scene.xml``), PyBullet (``load_pybullet`` on ``scene.sdf``), a USD stage (``pxr``), the GLB's
nodes, the sceneState's objects, the native reader and the AI2-THOR house file."""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pybullet
import trimesh

from scenemosaic.exchange import delivered_formats, load_pybullet, load_scene
from scenemosaic.scene import House

STEPS = 500
"""Simulation steps of a rest check, at the simulator's default time step."""
REST_M = 0.01
"""Largest drift of an object over :data:`STEPS` steps, and how far below the floor anything may reach."""


def destination(folder: Path, fmt: str) -> Path:
    """Where ``generate`` (and ``scenemosaic export``) puts format ``fmt`` in a delivered folder."""
    sub = dict(delivered_formats()).get(fmt, "")
    return folder / sub if sub else folder


@contextmanager
def bullet_client() -> Iterator[int]:
    """A PyBullet DIRECT client with gravity."""
    client = pybullet.connect(pybullet.DIRECT)
    pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
    try:
        yield client
    finally:
        pybullet.disconnect(client)


def link_position(body: int, client: int) -> np.ndarray:
    """The body's link frame (PyBullet reports the centre of mass): our object's position."""
    position, orientation = pybullet.getBasePositionAndOrientation(body, physicsClientId=client)
    local = pybullet.getDynamicsInfo(body, -1, physicsClientId=client)[3:5]
    inverse = pybullet.invertTransform(*local)
    return np.asarray(pybullet.multiplyTransforms(position, orientation, *inverse)[0])


def mujoco_drift(xml: Path, ids: Iterable[str], steps: int = STEPS) -> tuple[dict[str, float], float]:
    """Load ``xml`` in plain MuJoCo and step it: each body's drift (metres) and the lowest body origin."""
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ids = list(ids)
    start = {i: data.body(i).xpos.copy() for i in ids}
    mujoco.mj_step(model, data, nstep=steps)
    assert np.all(np.isfinite(data.qpos))
    drift = {i: float(np.linalg.norm(data.body(i).xpos - start[i])) for i in ids}
    return drift, min(float(data.body(i).xpos[2]) for i in ids)


def pybullet_drift(folder: Path, ids: Iterable[str], steps: int = STEPS) -> tuple[dict[str, float], float]:
    """``load_pybullet(folder)`` and step it: each object's drift (metres) and the lowest point of any."""
    ids = list(ids)
    with bullet_client() as client:
        bodies = load_pybullet(folder, client=client)
        start = {i: link_position(bodies[i], client) for i in ids}
        for _ in range(steps):
            pybullet.stepSimulation(physicsClientId=client)
        drift = {i: float(np.linalg.norm(link_position(bodies[i], client) - start[i])) for i in ids}
        lowest = min(pybullet.getAABB(bodies[i], physicsClientId=client)[0][2] for i in ids)
    return drift, float(lowest)


def usd_object_prims(stage: Any) -> dict[str, Any]:
    """``{object id: prim}`` of a USD stage opened with ``pxr``'s ``Usd.Stage.Open`` (object prims
    carry ``scenemosaic:objectId``; the prims are valid while the caller holds the stage)."""
    return {
        p.GetCustomDataByKey("scenemosaic:objectId"): p
        for p in stage.Traverse()
        if p.GetCustomDataByKey("scenemosaic:objectId")
    }


def read_back(fmt: str, folder: Path) -> set[str]:
    """The names format ``fmt`` written into ``folder`` (a delivered folder's layout) holds, read
    by its consumer: MuJoCo's bodies (after stepping the model), PyBullet's bodies, the USD
    stage's objects, the GLB's nodes, the sceneState's objects, the native reader's objects;
    for ``procthor``, the house file's rooms' ids."""
    if fmt == "mjcf":
        model = mujoco.MjModel.from_xml_path(str(folder / "scene.xml"))
        data = mujoco.MjData(model)
        mujoco.mj_step(model, data, nstep=50)
        assert np.all(np.isfinite(data.qpos))
        return {model.body(b).name for b in range(1, model.nbody)}
    if fmt == "urdf":
        with bullet_client() as client:
            bodies = load_pybullet(folder, client=client)
            pybullet.stepSimulation(physicsClientId=client)
        return set(bodies)
    if fmt == "usd":
        from pxr import Usd

        return set(usd_object_prims(Usd.Stage.Open(str(folder / "scene.usda"))))
    if fmt == "glb":
        return set(trimesh.load(folder / "scene.glb").graph.nodes)
    if fmt == "sceneeval":
        return {o["id"] for o in json.loads((folder / "sceneeval" / "scene_base.json").read_text())["scene"]["object"]}
    if fmt == "native":
        loaded = load_scene(folder)
        return {o.id for o in loaded.objects} | (set(loaded.room_ids) if isinstance(loaded, House) else set())
    if fmt == "procthor":
        return {str(r["id"]) for r in json.loads((folder / "house.json").read_text())["rooms"]}
    raise AssertionError(f"no reader for {fmt}")

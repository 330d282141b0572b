"""PyBullet: load a delivered scene in one call, every movable object a free body.

PyBullet turns URDF's ``floating`` joints into fixed ones, so ``scene.urdf`` loads frozen there.
``scene.sdf`` (written beside it by :func:`~scenemosaic.exchange.export_urdf`) is the world PyBullet
reads instead: ``pybullet.loadSDF("scene.sdf")`` gives one body per model, each placed at its pose,
the room and the held objects static. PyBullet ignores SDFormat's friction element, so
:func:`load_pybullet` also sets each body's lateral friction to the coefficient the file names.
Drawers, doors and lids are links on revolute and prismatic joints; PyBullet drives every such
joint with a velocity motor toward speed 0 that holds it shut, so :func:`load_pybullet` gives
that motor the joint's own dry friction as its force (PyBullet's way of modelling joint
friction): the part stays closed under small knocks and opens to a pull. A part delivered open
(``--open-state``) is set to its joint's ``<initial_position>``, which ``loadSDF`` ignores.
``pybullet`` is imported only here (``pip install 'scenemosaic[pybullet]'``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from scenemosaic.exceptions import MissingExtraError, UsageError
from scenemosaic.exchange._urdf import SDF_SCENE_FILE

__all__ = ["PYBULLET_INSTALL_HINT", "load_pybullet"]

PYBULLET_INSTALL_HINT = "pip install 'scenemosaic[pybullet]'"
"""The command that installs the PyBullet extra."""


def _import_pybullet() -> Any:
    try:
        import pybullet
    except ImportError as exc:
        raise MissingExtraError(
            f"loading a scene in PyBullet needs pybullet, which is not installed: {PYBULLET_INSTALL_HINT}"
        ) from exc
    return pybullet


def _frictions(root: ET.Element) -> dict[str, float]:
    """Model name -> the friction coefficient of its first collision (``<surface><friction><ode><mu>``)."""
    frictions: dict[str, float] = {}
    for model in root.iterfind("world/model"):
        mu = model.find("link/collision/surface/friction/ode/mu")
        if mu is not None and mu.text:
            frictions[model.attrib["name"]] = float(mu.text)
    return frictions


def _initial_positions(root: ET.Element) -> dict[str, float]:
    """Joint name -> ``<axis><initial_position>``, for the joints the file delivers away from 0."""
    out: dict[str, float] = {}
    for joint in root.iterfind("world/model/joint"):
        value = joint.find("axis/initial_position")
        if value is not None and value.text:
            out[joint.attrib["name"]] = float(value.text)
    return out


def load_pybullet(folder: str | Path, *, client: int = 0) -> dict[str, int]:
    """Load a delivered scene (``folder/scene.sdf``, or that file's path) into a PyBullet client.

    Returns ``{name: body id}``: one body per object, named by its id (a free body, or static
    when the scene holds it in place: ``sim.static``, hung from a wall or the ceiling) and the
    room (``room``; ``room_2`` should an object be called ``room``). Each body's lateral
    friction is the object's ``sim.friction``. An object's drawers, doors and lids are the links
    of its body, on joints named ``<id>/<part>``, their motors set to the joint's friction (see
    the module docstring), each at the joint value the scene delivers it at. Gravity and the time
    step stay the client's::

        import pybullet as p
        from scenemosaic.exchange import load_pybullet

        p.connect(p.DIRECT)
        p.setGravity(0, 0, -9.81)
        bodies = load_pybullet("out/demo/base")
        p.stepSimulation()

    Raises:
        MissingExtraError: pybullet is not installed (``pip install 'scenemosaic[pybullet]'``).
        UsageError: there is no ``scene.sdf`` (write one with ``scenemosaic export RUN --format urdf``).
    """
    path = Path(folder)
    if path.is_dir():
        path = path / SDF_SCENE_FILE
    if not path.is_file():
        raise UsageError(
            f"no {SDF_SCENE_FILE} at {path}: write it with `scenemosaic export RUN --format urdf --out DIR`"
        )
    pybullet = _import_pybullet()
    sdf = ET.parse(path).getroot()  # read once: frictions and delivered joint values
    frictions = _frictions(sdf)
    initial = _initial_positions(sdf)
    bodies: dict[str, int] = {}
    for body in pybullet.loadSDF(str(path), physicsClientId=client):
        name = pybullet.getBodyInfo(body, physicsClientId=client)[1].decode("utf-8")
        bodies[name] = body
        if name in frictions:
            pybullet.changeDynamics(body, -1, lateralFriction=frictions[name], physicsClientId=client)
        for joint in range(pybullet.getNumJoints(body, physicsClientId=client)):
            info = pybullet.getJointInfo(body, joint, physicsClientId=client)
            if info[2] not in (pybullet.JOINT_REVOLUTE, pybullet.JOINT_PRISMATIC):
                continue
            if name in frictions:
                pybullet.changeDynamics(body, joint, lateralFriction=frictions[name], physicsClientId=client)
            pybullet.setJointMotorControl2(
                body, joint, pybullet.VELOCITY_CONTROL, targetVelocity=0.0, force=info[7], physicsClientId=client
            )
            value = initial.get(info[1].decode("utf-8"))
            if value is not None:
                pybullet.resetJointState(body, joint, value, physicsClientId=client)
    return bodies

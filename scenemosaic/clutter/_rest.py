"""The rest check: does a small object stay where it is delivered?

The scene's MJCF is written as the export writes it (``physics.write_scene_mjcf``: the room
static, hung and static pieces welded, every other object on a free joint, numbers as the file
rounds them) into a scratch folder, loaded back with plain MuJoCo and stepped for
:data:`REST_SECONDS` from the delivered poses, with nothing held. Simulating the file, not the
model in memory, matters: the file's rounding alone moves a loaded wardrobe by millimetres. An
object whose origin moves :data:`REST_TOLERANCE_M` or more does not rest, nor does one resting on a
receptacle that moves that much (the load is why it moves), nor one that interpenetrates another
object deeper than physics' collision tolerance (5 mm) before anything moves.
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import mujoco
import numpy as np

from scenemosaic.assets import HullCache
from scenemosaic.physics import ObjectShape, collision_report_for, write_scene_mjcf
from scenemosaic.scene import Scene

__all__ = ["REST_SECONDS", "REST_TOLERANCE_M", "motions_over", "rest_check"]

REST_SECONDS = 2.0
"""How long the delivered scene is simulated to see whether an object rests, seconds (the issue's
acceptance: within 1 cm after 2 s)."""
REST_TOLERANCE_M = 0.008
"""Displacement at or above which an object has not rested, metres: 8 mm, a margin under the 1 cm
acceptance so a pose rounded on its way into a file still passes."""


def motions_over(
    scene: Scene,
    shapes: Mapping[str, ObjectShape],
    seconds: float = REST_SECONDS,
    *,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
) -> dict[str, float]:
    """How far (metres) each free object of ``scene`` moves in ``seconds`` of plain MuJoCo from its
    pose in the scene's MJCF file (``inf`` for one whose state blows up). ``shapes`` is not read:
    the file is written from the assets, as the export writes it."""
    del shapes
    with tempfile.TemporaryDirectory(prefix="scenemosaic-rest-") as scratch:
        xml = write_scene_mjcf(scene, scratch, base_dir, hull_cache=hull_cache)
        model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    free = [
        int(model.jnt_bodyid[j]) for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]
    start = {b: np.array(data.xpos[b]) for b in free}
    mujoco.mj_step(model, data, nstep=max(1, round(seconds / model.opt.timestep)))
    out: dict[str, float] = {}
    for b in free:
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        end = np.array(data.xpos[b])
        out[name] = float(np.linalg.norm(end - start[b])) if np.all(np.isfinite(end)) else float("inf")
    return out


def rest_check(
    scene: Scene,
    candidates: Sequence[str],
    shapes: Mapping[str, ObjectShape],
    *,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
) -> set[str]:
    """The ``candidates`` that do not rest in ``scene`` (see the module docstring)."""
    wanted = set(candidates)
    failed: set[str] = set()
    for pair in collision_report_for(scene, shapes).pairs:
        if pair.a in wanted:
            failed.add(pair.a)
        elif pair.b in wanted:
            failed.add(pair.b)
    moved = motions_over(scene, shapes, base_dir=base_dir, hull_cache=hull_cache)
    restless = {oid for oid, d in moved.items() if d >= REST_TOLERANCE_M}
    for oid in wanted:
        rel = scene.support_of(oid)
        if oid in restless or (rel is not None and rel.parent in restless):
            failed.add(oid)
    return failed

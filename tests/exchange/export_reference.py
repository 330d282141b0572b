"""The reference scene of the USD and URDF export tests: a real PhyScene living room run through
``generate`` (no evolution) with one object marked ``static``, and its MJCF model, which says what
the other exports must agree with (masses, inertias, free vs welded bodies, collision pieces)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import export_mjcf
from scenemosaic.scene import Scene

ROOM = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "LivingDiningRoom-8714_livingroom.json"
STATIC_ID = "tv_stand_0"
HULL_GROUP = 3  # the MJCF export's collision geoms


@dataclass(frozen=True)
class ReferenceRoom:
    scene: Scene
    base_dir: Path
    model: mujoco.MjModel


def build_reference_room(out: Path) -> ReferenceRoom:
    """Generate the room under ``out``, mark ``STATIC_ID`` static, export its MJCF and load it."""
    result = generate(ROOM, out / "run", GenerateConfig(evolve=False))
    scene = result.scene.model_copy(deep=True)
    scene.get(STATIC_ID).sim.static = True
    xml = export_mjcf(scene, out / "mjcf", result.base_dir)
    return ReferenceRoom(scene, result.base_dir, mujoco.MjModel.from_xml_path(str(xml)))


def hull_geoms(model: mujoco.MjModel, object_id: str) -> int:
    """Collision pieces of one body in the MJCF model."""
    body = model.body(object_id).id
    return sum(1 for g in range(model.ngeom) if model.geom_bodyid[g] == body and model.geom_group[g] == HULL_GROUP)

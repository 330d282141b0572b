"""Physics benchmark: build + settle a 30-object floor unit and a whole 16-object room.

Run: ``.venv/bin/python benchmarks/physics.py``. Hulls are warmed once (procedural parts and
the in-process compiled-hull cache), so the timed runs measure world building, containment,
separation and settling. The last line is JSON with ``unit30_settle_s`` and ``room16_settle_s``.
"""

from __future__ import annotations

import asyncio
import json
import math
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np
import structlog

from scenemosaic.exchange import load_scene
from scenemosaic.physics import (
    StabilizationReport,
    check_collisions,
    stabilize_scene_sync,
    validate_scene,
)
from scenemosaic.physics._hulls import object_shape
from scenemosaic.physics._settings import SimSettings
from scenemosaic.physics._world import WorldBuilder
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject
from scenemosaic.structure import structure_scene

ROOT = Path(__file__).resolve().parents[1]

ROOM16 = ROOT / "data" / "layouts" / "physcene" / "LivingDiningRoom-124277_livingroom.json"
CATEGORIES = [
    ("armchair", (0.8, 0.8, 0.9)),
    ("coffee_table", (1.0, 0.6, 0.45)),
    ("nightstand", (0.5, 0.4, 0.55)),
    ("stool", (0.4, 0.4, 0.45)),
    ("side_table", (0.5, 0.5, 0.6)),
    ("cabinet", (0.9, 0.45, 1.0)),
]


def unit30(seed: int = 0) -> Scene:
    """30 floor objects on a tight 6 x 5 grid in an 8 x 7 m room, jittered into each other and floating."""
    rng = np.random.default_rng(seed)
    objects: list[SceneObject] = []
    for k in range(30):
        cat, size = CATEGORIES[k % len(CATEGORIES)]
        gx, gy = k % 6, k // 6
        pos = (
            1.0 + gx * 0.95 + rng.uniform(-0.2, 0.2),
            1.0 + gy * 0.95 + rng.uniform(-0.2, 0.2),
            rng.uniform(0.0, 0.08),
        )
        objects.append(
            SceneObject(
                id=f"{cat}_{k}",
                category=cat,
                asset=AssetRef(kind="procedural", category=cat, extents=size),
                pose=Pose.from_yaw(pos, float(rng.choice([0.0, math.pi / 2, math.pi]))),
            )
        )
    rels = [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    return Scene(id="unit30", room=Room.rectangle(0.0, 0.0, 8.0, 7.0), objects=objects, relations=rels)


def timed(scene: Scene, repeats: int = 3) -> tuple[float, StabilizationReport]:
    stabilize_scene_sync(scene, seed=0)  # warm: hulls and compiled-hull cache
    times: list[float] = []
    report: StabilizationReport | None = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        _, report = stabilize_scene_sync(scene, seed=0)
        times.append(time.perf_counter() - t0)
    assert report is not None
    return statistics.median(times), report


def steps_per_s(scene: Scene, steps: int = 1000) -> float:
    """Raw stepping rate of the whole room on free joints."""
    builder = WorldBuilder(SimSettings())
    builder.add_room(scene.room)
    for o in scene.objects:
        builder.add_dynamic(o, object_shape(o), mode="free")
    world = builder.compile()
    t0 = time.perf_counter()
    mujoco.mj_step(world.model, world.data, nstep=steps)
    return steps / (time.perf_counter() - t0)


def main() -> None:
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(30))
    s30 = unit30()
    t30, r30 = timed(s30)
    room = asyncio.run(structure_scene(load_scene(ROOM16)))  # rules model: supports, units
    t16, r16 = timed(room)
    sps = steps_per_s(room)
    sps30 = steps_per_s(s30)
    before = (check_collisions(s30).count, check_collisions(room).count)
    after = (
        validate_scene(stabilize_scene_sync(s30, seed=0)[0]),
        validate_scene(stabilize_scene_sync(room, seed=0)[0]),
    )
    steps30 = sum(u.steps for u in r30.units)
    steps16 = sum(u.steps for u in r16.units)
    print(f"unit30: {len(s30.objects)} objects, build+settle {t30:.3f} s, {steps30} steps (target <= 1.0 s)")
    print(
        f"room16: {len(room.objects)} objects, {len(r16.units)} units, stabilize {t16:.3f} s, {steps16} steps (target <= 3 s)"
    )
    for label, b, v in zip(("unit30", "room16"), before, after, strict=True):
        print(
            f"{label}: collisions {b} -> {v.collisions.count}, out of bounds {v.out_of_bounds.count}, tipped {len(v.tipped)}, fell {len(v.fell)}"
        )
    print(
        f"stepping: room16 {sps:.0f} steps/s, unit30 {sps30:.0f} steps/s (free joints, all objects dynamic)"
    )
    print(
        json.dumps(
            {
                "unit30_settle_s": round(t30, 4),
                "room16_settle_s": round(t16, 4),
                "unit30_steps": steps30,
                "room16_steps": steps16,
                "room16_steps_per_s": round(sps, 1),
                "unit30_steps_per_s": round(sps30, 1),
            }
        )
    )


if __name__ == "__main__":
    main()

"""A deliberately over-full room: every item ends on or in a plausible receptacle, in bounds, at rest.

An over-full TV stand, a fridge with food, a bookshelf with more books than one board takes, a
baseball bat standing on a bed. The checks read the delivered files (``report.json``, ``scene.json``)
and simulate the delivered MJCF in plain MuJoCo for 2 s, independently of the code that placed them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from scenemosaic.exchange import read_scene, save_scene
from scenemosaic.pipeline import GenerateConfig, generate
from scenemosaic.scene import AssetRef, Pose, Room, Scene, SceneObject, load_priors
from scenemosaic.structure import PLAUSIBLE_P

SETTLE_S = 2.0
AT_REST_M = 0.01


def _obj(oid: str, category: str, size: tuple[float, float, float], at: tuple[float, float, float], yaw: float = 0.0) -> SceneObject:
    return SceneObject(
        id=oid,
        category=category,
        asset=AssetRef(kind="procedural", category=category, extents=size),
        pose=Pose.from_yaw(at, math.radians(yaw)),
    )


def cluttered_room() -> Scene:
    objects = [
        _obj("tv_stand", "tv_stand", (1.2, 0.45, 0.5), (2.5, 0.3, 0.0)),
        _obj("television", "television", (1.0, 0.25, 0.6), (2.5, 0.35, 0.5)),
        _obj("fridge", "fridge", (0.8, 0.7, 1.8), (0.5, 4.5, 0.0), 180.0),
        _obj("bookshelf", "bookshelf", (0.9, 0.35, 1.8), (4.7, 2.5, 0.0), 90.0),
        _obj("bed", "bed", (1.6, 2.0, 0.6), (1.0, 1.5, 0.0)),
        _obj("dining_table", "dining_table", (1.4, 0.9, 0.75), (3.0, 3.8, 0.0)),
        _obj("bat", "baseball_bat", (0.08, 0.08, 0.9), (1.0, 1.5, 0.45)),
    ]
    # more on the TV stand than its top takes
    for i, (cat, size) in enumerate(
        [("plate", (0.26, 0.26, 0.03)), ("candle", (0.08, 0.08, 0.15)), ("pencil", (0.01, 0.18, 0.01)),
         ("vase", (0.18, 0.18, 0.3)), ("remote_control", (0.05, 0.18, 0.02)), ("bowl", (0.22, 0.22, 0.08)),
         ("cell_phone", (0.08, 0.16, 0.01)), ("book", (0.17, 0.24, 0.04))]
    ):  # fmt: skip
        objects.append(_obj(f"on_stand_{i}_{cat}", cat, size, (2.2 + 0.08 * i, 0.2, 0.5)))
    # food in the fridge, all at one height
    for i, cat in enumerate(["apple", "tomato", "egg", "lettuce", "apple"]):
        objects.append(_obj(f"food_{i}_{cat}", cat, (0.08, 0.08, 0.08) if cat != "lettuce" else (0.2, 0.2, 0.15), (0.3 + 0.1 * i, 4.5, 0.9)))
    # fourteen books on the bookshelf's lowest board: more than one board takes
    for i in range(14):
        objects.append(_obj(f"book_{i}", "book", (0.17, 0.24, 0.04), (4.7, 2.2 + 0.04 * i, 0.05 + 0.04 * (i % 2))))
    return Scene(id="cluttered", room=Room.rectangle(0, 0, 5, 5, ceiling_height=2.7), objects=objects)


@pytest.fixture(scope="module")
def delivered(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("clutter") / "room"
    save_scene(cluttered_room(), src)
    out = src.parent / "out"
    generate(src, out, GenerateConfig(model="rules", evolve=False))
    return out


def test_every_item_rests_on_a_plausible_receptacle_in_bounds(delivered: Path) -> None:
    report = json.loads((delivered / "report.json").read_text())
    validation = report["validation"]
    assert validation["collisions"]["pairs"] == []
    assert validation["out_of_bounds"]["objects"] == []
    assert validation["fell"] == [] and validation["tipped"] == []
    scene = read_scene(delivered / "base")
    priors = load_priors()
    for o in scene.objects:
        rel = scene.support_of(o.id)
        assert rel is not None, o.id
        if not priors.is_pickupable(o.category) or rel.parent in ("floor", "ceiling") or rel.parent.startswith("wall"):
            if rel.parent == "floor" and priors.is_pickupable(o.category):
                assert priors.on_floor(o.category), (o.id, "on the floor but not a floor thing")
            continue
        p = priors.probability(o.category, scene.get(rel.parent).category)
        assert p is not None and p >= PLAUSIBLE_P, (o.id, rel.parent, p)
    # the crowded stand gave up what it could not take, and the report says where each went
    moved = next(s for s in report["stages"] if s["name"] == "structure")["detail"]["reparented"]
    assert any(m.startswith("on_stand_") for m in moved) and all("(" in m for m in moved)
    # the fridge's food is inside it, the books all on shelves of the bookshelf
    for o in scene.objects:
        if o.id.startswith("food_"):
            assert scene.support_of(o.id).parent == "fridge" and scene.support_of(o.id).kind == "contain", o.id
        if o.id.startswith("book_"):
            assert scene.support_of(o.id).parent == "bookshelf", o.id
    boards = {round(scene.get(f"book_{i}").pose.position[2], 2) for i in range(14)}
    assert len(boards) >= 2  # one board could not take them all


def test_the_delivered_mjcf_stays_at_rest_for_two_seconds(delivered: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(delivered / "base" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    assert len(free) >= 20
    bodies = [model.jnt_bodyid[j] for j in free]
    before = np.array([data.xpos[b].copy() for b in bodies])
    while data.time < SETTLE_S:
        mujoco.mj_step(model, data)
    after = np.array([data.xpos[b] for b in bodies])
    moved = np.linalg.norm(after - before, axis=1)
    worst = int(np.argmax(moved))
    assert moved.max() < AT_REST_M, (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, bodies[worst]), moved.max())

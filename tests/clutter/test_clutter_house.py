"""Clutter on a whole house (``generate house.json --clutter fill|vary``), judged on the delivered files.

Slow (two whole-house runs of the shipped four-room ProcTHOR house): marked ``house``, run by
``make test-houses``. The checks read ``report.json``, each room's ``scene.json`` and the house's
``scene.xml``, and the priors straight from ``receptacles.json``.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.clutter import load_clutter_priors, small_objects
from scenemosaic.exchange import load_scene
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, House, load_priors

pytestmark = pytest.mark.house

HOUSE = "procthor_4room.json"
VARIANTS = 5
"""Whole-house variants of the ``vary`` run (the issue's acceptance: 5)."""
REST_M = 0.01
"""How far (metres) an object may move in 2 s of plain MuJoCo and still count as resting."""


@pytest.fixture(scope="module")
def filled(tmp_path_factory: pytest.TempPathFactory, repo_data: Path) -> Path:
    out = tmp_path_factory.mktemp("house_fill")
    generate(repo_data / "houses" / "procthor" / HOUSE, out, GenerateConfig(clutter="fill"))
    return out


@pytest.fixture(scope="module")
def varied(tmp_path_factory: pytest.TempPathFactory, repo_data: Path) -> Path:
    out = tmp_path_factory.mktemp("house_vary")
    generate(repo_data / "houses" / "procthor" / HOUSE, out, GenerateConfig(clutter="vary", variants=VARIANTS))
    return out


def _rooms(folder: Path) -> dict[str, dict[str, Any]]:
    order = json.loads((folder / "house_scene.json").read_text())
    rooms = order["rooms"] if isinstance(order, dict) else order
    names = [r if isinstance(r, str) else r["id"] for r in rooms]
    return {name: json.loads((folder / "rooms" / name / "scene.json").read_text()) for name in names}


def _supports(data: dict[str, Any]) -> dict[str, str]:
    return {r["child"]: r["parent"] for r in data["relations"] if r["kind"] in ("attach", "contain")}


def _typical() -> dict[str, float]:
    """Objects per receptacle of each receptacle type in ``receptacles.json``: the objects seen on
    the type over the receptacles of it observed (``count / p`` of any row)."""
    table = json.loads((PROCTHOR_PRIORS_DIR / "receptacles.json").read_text())
    out = {}
    for rtype, row in table.items():
        seen = [v for v in row.values() if v.get("p", 0) > 0]
        if seen:
            out[rtype] = sum(v["count"] for v in seen) / (seen[0]["count"] / seen[0]["p"])
    return out


def test_fill_adds_objects_on_receptacles_the_priors_allow(filled: Path) -> None:
    receptacles = json.loads((PROCTHOR_PRIORS_DIR / "receptacles.json").read_text())
    types = load_priors()
    typical = _typical()
    added = 0
    for room, data in _rooms(filled / "base").items():
        category = {o["id"]: o["category"] for o in data["objects"]}
        supports = _supports(data)
        record = data["metadata"].get("clutter", {}).get("objects", {})
        added += len(record)
        for oid, entry in record.items():
            assert oid in category and oid.startswith(f"{room}_"), oid  # house-wide unique ids
            parent = supports[oid]
            assert parent == entry["receptacle"]
            child_type, parent_type = str(types.type_of(category[oid])), str(types.type_of(category[parent]))
            assert receptacles[parent_type].get(child_type, {}).get("count", 0) > 0, (room, oid, parent)
        for parent in {e["receptacle"] for e in record.values()}:  # filled up to the priors' density
            held = sum(1 for p in supports.values() if p == parent)
            assert held >= typical[str(types.type_of(category[parent]))], (room, parent, held)
    assert added >= 10


def test_the_filled_house_rests_in_plain_mujoco_and_stays_valid(filled: Path) -> None:
    report = json.loads((filled / "report.json").read_text())
    assert report["status"] == "ok", report.get("warnings")
    for rid, room in report["rooms"].items():
        assert [s["name"] for s in room["stages"]][-2:] == ["compose", "clutter"], rid
    for rid, rows in report["metrics"]["rooms"].items():
        assert rows["base"]["COL"] == 0.0 and rows["base"]["OOB"] == 0.0, rid
        assert rows["base"]["NAV"] >= 0.99, rid
    assert report["metrics"]["house"]["base"]["door_blockers"] == []
    added = {
        oid for data in _rooms(filled / "base").values() for oid in data["metadata"]["clutter"]["objects"]
    }
    model = mujoco.MjModel.from_xml_path(str(filled / "base" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    free = [
        int(model.jnt_bodyid[j]) for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in free}
    assert added <= names  # every added object is a free body of the delivered world
    start = {b: data.xpos[b].copy() for b in free}
    mujoco.mj_step(model, data, nstep=round(2.0 / model.opt.timestep))
    moved = [b for b in free if float(np.linalg.norm(data.xpos[b] - start[b])) >= REST_M]
    assert len(moved) <= 0.01 * len(free)
    assert not {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in moved} & added


def test_vary_moves_small_objects_between_receptacles_in_every_variant(varied: Path) -> None:
    """Every pair of the five whole-house variants puts at least 30 % of a room's small objects
    (rooms with at least 5) on another receptacle, the furniture valid in every variant."""
    report = json.loads((varied / "report.json").read_text())
    assert report["status"] == "ok", report.get("warnings")
    for rid, rows in report["metrics"]["rooms"].items():
        for row in rows["variants"]:
            assert row["COL"] == 0.0 and row["OOB"] == 0.0, rid
    priors = load_clutter_priors()
    houses = [load_scene(varied, variant=i) for i in range(1, VARIANTS + 1)]
    assert all(isinstance(h, House) for h in houses)
    judged = 0
    for k, room in enumerate(houses[0].rooms):  # type: ignore[union-attr]
        scenes = [h.rooms[k] for h in houses]  # type: ignore[union-attr]
        small = [set(small_objects(s, priors)) for s in scenes]
        assert all(x == small[0] for x in small), room.id  # the same objects, elsewhere
        if len(small[0]) < 5:
            continue
        judged += 1
        for a, b in itertools.combinations(scenes, 2):
            parents = [
                (a.support_of(o).parent, b.support_of(o).parent)  # type: ignore[union-attr]
                for o in small[0]
            ]
            assert sum(x != y for x, y in parents) >= 0.3 * len(parents), room.id
    assert judged >= 1
    for rid, data in _rooms(varied / "base").items():  # vary adds nothing: the base keeps its input's
        assert "clutter" not in data["metadata"], rid

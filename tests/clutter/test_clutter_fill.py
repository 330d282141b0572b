"""``--clutter fill`` end to end on a shipped PhyScene room, and ``keep`` byte for byte.

Every placement is read back from the delivered files and checked against the priors' own JSON
(not through the package's reader), and the delivered MJCF is simulated with plain MuJoCo.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.clutter import CLUTTER_METADATA, clutter_ids, fill_scene, load_clutter_priors
from scenemosaic.exchange import load_scene, read_scene
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, load_priors

DINING = "DiningRoom-19325_diningroom.json"


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory, repo_data: Path) -> dict[str, Path]:
    """The dining room generated three times: with no clutter setting, with ``keep`` said, with ``fill``."""
    source = repo_data / "layouts" / "physcene" / DINING
    out: dict[str, Path] = {}
    for name, extra in (("default", {}), ("keep", {"clutter": "keep"}), ("fill", {"clutter": "fill"})):
        folder = tmp_path_factory.mktemp(name)
        generate(source, folder, GenerateConfig(**extra))  # type: ignore[arg-type]
        out[name] = folder
    return out


def _scene_json(folder: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((folder / "base" / "scene.json").read_text())
    return data


def test_keep_is_byte_identical_to_no_setting(runs: dict[str, Path]) -> None:
    default, keep = runs["default"] / "base", runs["keep"] / "base"
    for name in ("scene.json", "scene.xml", "sceneeval/scene_base.json"):
        assert (default / name).read_bytes() == (keep / name).read_bytes(), name
    stages = [s["name"] for s in json.loads((runs["keep"] / "report.json").read_text())["stages"]]
    assert "clutter" not in stages
    assert CLUTTER_METADATA not in _scene_json(runs["keep"])["metadata"]


def test_fill_gives_three_times_the_furniture_in_small_objects(runs: dict[str, Path]) -> None:
    data = _scene_json(runs["fill"])
    added = set(data["metadata"][CLUTTER_METADATA]["objects"])
    furniture = [o for o in data["objects"] if o["id"] not in added]
    assert len(furniture) == len(_scene_json(runs["keep"])["objects"])
    assert len(added) >= 3 * len(furniture)
    stage = next(
        s for s in json.loads((runs["fill"] / "report.json").read_text())["stages"] if s["name"] == "clutter"
    )
    assert stage["status"] == "done" and stage["detail"]["added"] == len(added)


def test_every_object_is_a_database_asset_on_a_receptacle_the_priors_allow(runs: dict[str, Path]) -> None:
    data = _scene_json(runs["fill"])
    receptacles = json.loads((PROCTHOR_PRIORS_DIR / "receptacles.json").read_text())
    database = json.loads((PROCTHOR_PRIORS_DIR / "asset-database.json").read_text())
    entries = {e["assetId"]: (t, e["boundingBox"]) for t, es in database.items() for e in es}
    priors = load_priors()
    objects = {o["id"]: o for o in data["objects"]}
    support = {r["child"]: r for r in data["relations"] if r["kind"] in ("attach", "contain")}
    for oid, record in data["metadata"][CLUTTER_METADATA]["objects"].items():
        obj, rel = objects[oid], support[oid]
        assert rel["parent"] == record["receptacle"]
        object_type, box = entries[record["asset_id"]]
        assert priors.type_of(obj["category"]) == object_type
        parent_type = priors.type_of(objects[rel["parent"]]["category"])
        assert parent_type in receptacles, (oid, rel["parent"])
        assert receptacles[parent_type].get(object_type, {}).get("count", 0) > 0, (
            oid,
            object_type,
            parent_type,
        )
        # the database's box (Unity y up) is the object's size; mass and friction are set
        assert obj["asset"]["extents"] == pytest.approx([box["x"], box["z"], box["y"]])
        assert obj["sim"]["mass_kg"] > 0 and obj["sim"]["friction"] > 0 and not obj["sim"]["static"]


def test_every_object_lies_on_or_in_its_receptacle(runs: dict[str, Path]) -> None:
    scene = read_scene(runs["fill"] / "base")
    for oid in clutter_ids(scene):
        obj = scene.get(oid)
        rel = scene.support_of(oid)
        assert rel is not None
        lo, hi = scene.get(rel.parent).aabb()
        x, y, z = obj.pose.position
        assert lo[0] - 0.01 <= x <= hi[0] + 0.01 and lo[1] - 0.01 <= y <= hi[1] + 0.01, oid
        assert lo[2] <= z <= hi[2] + 0.01, oid


def test_the_delivered_mjcf_rests_for_two_seconds(runs: dict[str, Path]) -> None:
    model = mujoco.MjModel.from_xml_path(str(runs["fill"] / "base" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    free = [
        int(model.jnt_bodyid[j]) for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]
    start = {b: data.xpos[b].copy() for b in free}
    mujoco.mj_step(model, data, nstep=round(2.0 / model.opt.timestep))
    moved = {b: float(np.linalg.norm(data.xpos[b] - start[b])) for b in free}
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in free}
    assert set(clutter_ids(read_scene(runs["fill"] / "base"))) <= names  # every small object is a free body
    resting = sum(1 for v in moved.values() if math.isfinite(v) and v < 0.01)
    assert resting >= 0.99 * len(moved), {
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b): v for b, v in moved.items() if v >= 0.01
    }


def test_fill_keeps_the_room_valid(runs: dict[str, Path]) -> None:
    filled = json.loads((runs["fill"] / "report.json").read_text())
    kept = json.loads((runs["keep"] / "report.json").read_text())
    assert filled["metrics"]["base"]["COL"] == 0.0
    assert filled["metrics"]["base"]["OOB"] == 0.0
    assert filled["metrics"]["base"]["NAV"] == kept["metrics"]["base"]["NAV"]
    assert filled["status"] == "ok", filled.get("warnings")


def test_fill_is_deterministic_and_follows_the_seed(runs: dict[str, Path]) -> None:
    base = read_scene(runs["keep"] / "base")
    before = base.model_dump_json()
    priors = load_clutter_priors()
    first, report = fill_scene(base, priors=priors, seed=3)
    again, _ = fill_scene(base, priors=priors, seed=3)
    other, _ = fill_scene(base, priors=priors, seed=4)
    assert report.added_count >= 3 * len(base.objects)
    assert first.model_dump_json() == again.model_dump_json()
    assert first.model_dump_json() != other.model_dump_json()
    assert base.model_dump_json() == before  # the input is not modified


def test_fill_on_a_scene_that_is_not_stabilized_drops_what_cannot_rest(repo_data: Path) -> None:
    """The raw import's furniture floats (nothing stabilized it): whatever is put on it moves with
    it, so the rest check drops every object and says why."""
    raw = load_scene(repo_data / "layouts" / "physcene" / DINING)
    filled, report = fill_scene(raw, priors=load_clutter_priors(), seed=0)
    assert report.added_count == 0 and report.dropped
    assert all("did not rest" in why for why in report.dropped.values())
    assert len(filled.objects) == len(raw.objects)

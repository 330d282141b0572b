"""``--open-state`` on ``generate`` and ``export`` (issue 39): the delivered pose of drawers and doors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import pytest
from typer.testing import CliRunner

from scenemosaic.assets import OPEN_STATE_KEY, object_articulation, opening
from scenemosaic.cli import app
from scenemosaic.exchange import read_scene, save_scene
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject

runner = CliRunner()


def _scene() -> Scene:
    chest = SceneObject(
        id="dresser",
        category="dresser",
        asset=AssetRef(kind="procedural", extents=(1.19, 0.59, 1.09)),
        pose=Pose.from_yaw((2.0, 3.5, 0.0), 0.0),  # backed to a wall, its drawers free to pull out
    )
    cabinet = SceneObject(
        id="cabinet",
        category="cabinet",
        asset=AssetRef(kind="procedural", extents=(0.9, 0.5, 0.9)),
        pose=Pose.from_yaw((2.0, 0.6, 0.0), math.radians(180.0)),  # its doors free to open into the room
    )
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in (chest, cabinet)]
    return Scene(
        id="chest", room=Room.rectangle(0, 0, 4.0, 4.0), objects=[chest, cabinet], relations=relations
    )


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("open_state") / "scene"
    save_scene(_scene(), folder)
    return folder


def _qpos0(xml: Path) -> dict[str, float]:
    model = mujoco.MjModel.from_xml_path(str(xml))
    return {
        model.joint(j).name: float(model.qpos0[model.jnt_qposadr[j]])
        for j in range(model.njnt)
        if "/" in model.joint(j).name
    }


def test_export_open_state_sets_the_delivered_pose(saved: Path, tmp_path: Path) -> None:
    scene = read_scene(saved)
    parts = {f"{o.id}/{p.name}": (o, p) for o in scene.objects for p in object_articulation(o)}
    done = runner.invoke(
        app, ["export", str(saved), "-f", "mjcf", "-o", str(tmp_path / "open"), "--open-state", "open"]
    )
    assert done.exit_code == 0, done.output
    opened = _qpos0(tmp_path / "open" / "scene.xml")
    assert opened.keys() == parts.keys()
    for name, (_, part) in parts.items():
        assert opened[name] == pytest.approx(part.limits[1], abs=1e-5)
    random = []
    for seed in ("3", "3", "4"):
        out = tmp_path / f"random_{len(random)}"
        done = runner.invoke(
            app,
            ["export", str(saved), "-f", "mjcf", "-o", str(out), "--open-state", "random", "--seed", seed],
        )
        assert done.exit_code == 0, done.output
        random.append(_qpos0(out / "scene.xml"))
    assert random[0] == random[1] and random[0] != random[2]
    for name, (obj, part) in parts.items():
        assert random[0][name] == pytest.approx(opening(part, "random", seed=3, key=obj.id), abs=1e-5)
    plain = runner.invoke(app, ["export", str(saved), "-f", "mjcf", "-o", str(tmp_path / "plain")])
    assert plain.exit_code == 0 and set(_qpos0(tmp_path / "plain" / "scene.xml").values()) == {0.0}
    bad = runner.invoke(
        app, ["export", str(saved), "-f", "mjcf", "-o", str(tmp_path / "bad"), "--open-state", "ajar"]
    )
    assert bad.exit_code == 2


def test_generate_delivers_the_open_state_drawn_from_the_run_seed(saved: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    args = [
        "generate",
        str(saved / "scene.json"),
        "--out",
        str(out),
        "--no-evolve",
        "--open-state",
        "random",
        "--seed",
        "5",
    ]
    done = runner.invoke(app, args)
    assert done.exit_code == 0, done.output
    delivered = read_scene(out / "base")
    record = delivered.metadata[OPEN_STATE_KEY]
    assert record["state"] == "random" and record["seed"] == 5
    joints = _qpos0(out / "base" / "scene.xml")
    for obj in delivered.objects:
        for part in object_articulation(obj):
            value = opening(part, "random", seed=5, key=obj.id)
            assert record["parts"][obj.id][part.name] == pytest.approx(value)
            assert joints[f"{obj.id}/{part.name}"] == pytest.approx(value, abs=1e-5)
    report = json.loads((out / "report.json").read_text())
    assert report["config"]["open_state"] == "random"


def test_export_of_a_run_draws_random_from_the_run_seed(saved: Path, tmp_path: Path) -> None:
    """``export RUN --open-state random`` without ``--seed`` draws from the seed the run was made
    with (its report's config), as ``generate --open-state random --seed N`` would."""
    run = tmp_path / "run"
    made = runner.invoke(app, ["generate", str(saved / "scene.json"), "--out", str(run), "--no-evolve", "--seed", "7"])
    assert made.exit_code == 0, made.output
    done = runner.invoke(app, ["export", str(run), "-f", "mjcf", "-o", str(tmp_path / "x"), "--open-state", "random"])
    assert done.exit_code == 0, done.output
    joints = _qpos0(tmp_path / "x" / "base" / "scene.xml")
    delivered = read_scene(run / "base")
    drawn = {
        f"{o.id}/{p.name}": opening(p, "random", seed=7, key=o.id) for o in delivered.objects for p in object_articulation(o)
    }
    assert drawn and joints == pytest.approx(drawn, abs=1e-5)
    assert drawn != {
        f"{o.id}/{p.name}": opening(p, "random", seed=0, key=o.id) for o in delivered.objects for p in object_articulation(o)
    }

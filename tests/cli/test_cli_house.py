"""Every command after ``generate`` on a house run, as a user calls it (issue 35): ``evaluate`` and
``export`` (the whole house, or ``--room``), ``edit --room`` (the whole house written, one room
changed), ``inspect`` and ``render``; and the delivered house in MuJoCo, PyBullet and USD.

One run of the shipped four-room ProcTHOR house with two variants (about 40 s on two cores) serves
the module, so it runs with the house tests (``make test-houses``); ``tests/exchange/
test_write_scene_house.py`` covers ``write_scene`` on a house in ``make test``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from simulator_checks import REST_M, mujoco_drift, pybullet_drift, read_back, usd_object_prims
from typer.testing import CliRunner

from scenemosaic.assets import with_room_doors
from scenemosaic.cli import app
from scenemosaic.exchange import load_scene, read_house, writable_formats
from scenemosaic.physics import is_fixed
from scenemosaic.render import render_house_plan
from scenemosaic.scene import House, RunFolder, Scene, descendants

pytestmark = pytest.mark.house

HOUSE_FILE = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"
ROOM = "room_5"
"""The room the ``--room`` tests use (the bathroom, 9 objects)."""
SCENES = ("base", "variant_1", "variant_2")
runner = CliRunner()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("house_cli") / "house"
    done = runner.invoke(app, ["generate", str(HOUSE_FILE), "--variants", "2", "--model", "rules", "--out", str(out)])
    assert done.exit_code == 0, done.output
    assert [name for name, _ in RunFolder(out).scenes()] == list(SCENES)
    return out


@pytest.fixture(scope="module")
def houses(run_dir: Path) -> dict[str, House]:
    return {name: read_house(run_dir / name) for name in SCENES}


def _ok(args: list[str]) -> str:
    done = runner.invoke(app, args)
    assert done.exit_code == 0, done.output
    return done.stdout


def _refused(args: list[str]) -> str:
    done = runner.invoke(app, args)
    assert done.exit_code == 2, done.output
    assert "Traceback" not in done.output
    return " ".join(done.output.split())


# -- evaluate -------------------------------------------------------------------------------------


def test_evaluate_prints_the_figures_the_run_reported(run_dir: Path, houses: dict[str, House]) -> None:
    figures = json.loads(_ok(["evaluate", str(run_dir)]))
    report = json.loads(RunFolder(run_dir).report.read_text(encoding="utf-8"))
    assert figures == report["metrics"]  # read back from the delivered folders: the run's own figures
    assert list(figures["rooms"]) == houses["base"].room_ids
    assert len(figures["house"]["variants"]) == 2 and figures["house"]["diversity"]["pairs"] == 1


def test_evaluate_one_room_over_the_base_and_the_variants(run_dir: Path) -> None:
    whole = json.loads(_ok(["evaluate", str(run_dir)]))
    room = json.loads(_ok(["evaluate", str(run_dir), "--room", ROOM]))
    assert room == whole["rooms"][ROOM]
    assert json.loads(_ok(["evaluate", str(run_dir), "--room", "room|5"])) == room  # its source id
    assert "no room 'room_99'" in _refused(["evaluate", str(run_dir), "--room", "room_99"])
    one = json.loads(_ok(["evaluate", str(run_dir / "variant_1")]))  # one delivered house: no variants
    assert one["house"]["variants"] == [] and "diversity" not in one["house"]


# -- export ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", writable_formats(house=True))
def test_export_writes_every_scene_as_a_whole_house(run_dir: Path, houses: dict[str, House], fmt: str, tmp_path: Path) -> None:
    _ok(["export", str(run_dir), "--format", fmt, "--out", str(tmp_path)])
    assert sorted(p.name for p in tmp_path.iterdir()) == list(SCENES)
    for name in SCENES:
        names = read_back(fmt, tmp_path / name)
        house = houses[name]
        if fmt == "procthor":
            assert names == {s.provenance.source_room_id for s in house.rooms}
        else:
            assert {o.id for o in house.objects} <= names, name


@pytest.mark.parametrize("fmt", writable_formats())
def test_export_one_room_of_every_scene(run_dir: Path, houses: dict[str, House], fmt: str, tmp_path: Path) -> None:
    _ok(["export", str(run_dir), "--format", fmt, "--room", ROOM, "--out", str(tmp_path)])
    for name in SCENES:
        names = read_back(fmt, tmp_path / name)
        if fmt == "procthor":
            continue  # the house file, this room moved in it: tests/exchange/test_export_procthor.py
        ours = {o.id for o in houses[name].room(ROOM).objects}
        others = {o.id for o in houses[name].objects} - ours
        assert ours <= names and not others & names, name


def test_export_refuses_a_room_the_house_lacks(run_dir: Path, tmp_path: Path) -> None:
    assert "no room 'attic'" in _refused(["export", str(run_dir), "-f", "mjcf", "--room", "attic", "-o", str(tmp_path / "x")])
    assert not (tmp_path / "x").exists()


# -- the delivered house in its simulators --------------------------------------------------------


@pytest.mark.parametrize("name", ["base", "variant_2"])
def test_the_delivered_house_rests_in_mujoco_and_pybullet(houses: dict[str, House], run_dir: Path, name: str) -> None:
    """``scene.xml`` in plain MuJoCo and ``scene.sdf`` through ``load_pybullet``, 500 steps each:
    every object of every room stays within 1 cm, nothing sinks below the floor."""
    folder = run_dir / name
    ids = [o.id for o in houses[name].objects]
    for drift, lowest in (mujoco_drift(folder / "scene.xml", ids), pybullet_drift(folder, ids)):
        worst = max(drift, key=drift.__getitem__)
        assert drift[worst] < REST_M, (worst, drift[worst])
        assert lowest > -REST_M


def test_the_delivered_house_usd_has_a_rigid_body_per_movable_object(houses: dict[str, House], run_dir: Path) -> None:
    from pxr import Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.Open(str(run_dir / "base" / "scene.usda"))
    prims = usd_object_prims(stage)
    house = with_room_doors(houses["base"])  # the doors hung on the doorways: held in place
    assert isinstance(house, House)
    assert set(prims) == {o.id for o in house.objects}
    assert any(o.category.startswith("room_") and o.id.startswith("room_door") for o in house.objects)
    for room in house.rooms:
        for obj in room.objects:
            prim = prims[obj.id]
            assert prim.HasAPI(UsdPhysics.RigidBodyAPI) == (not is_fixed(room, obj)), obj.id
            world = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
            assert np.allclose(np.asarray(world.ExtractTranslation()), obj.pose.position, atol=1e-5), obj.id


# -- edit -----------------------------------------------------------------------------------------

MOVES = [("room_5", "5_2", -0.1), ("room_5", "5_0", -0.1), ("room_6", "6_0", 0.1), ("room_4", "4_2", 0.1)]
"""Candidate edits (room, object, metres along u): the first the edit check accepts is used."""


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_edit_writes_the_whole_house_with_one_room_changed(run_dir: Path, houses: dict[str, House], tmp_path: Path) -> None:
    source = run_dir / "variant_1"
    for room, oid, du in MOVES:
        out = tmp_path / f"{oid}"
        done = runner.invoke(app, ["edit", str(run_dir), "--variant", "1", "--room", room, f"{oid}.center.u = {oid}.center.u + {du}", "--out", str(out)])  # fmt: skip
        assert done.exit_code in (0, 2), done.output
        if done.exit_code == 2:  # refused by the check: nothing written
            assert "nothing written" in " ".join(done.output.split()) and not out.exists()
            continue
        break
    else:
        pytest.fail("every candidate edit was refused")
    edited = load_scene(out)
    assert isinstance(edited, House) and edited.room_ids == houses["variant_1"].room_ids
    for rid in edited.room_ids:  # every other room as it was, to the byte
        if rid != room:
            assert _files(out / "rooms" / rid) == _files(source / "rooms" / rid), rid
    before, after = houses["variant_1"].room(room), edited.room(room)
    moved = np.subtract(after.get(oid).pose.position, before.get(oid).pose.position)
    assert np.allclose(moved, [du, 0.0, 0.0], atol=1e-6)
    riders = set(descendants(before, oid))  # what rests on the piece moves with it, rigidly
    for obj in before.objects:
        shift = np.subtract(after.get(obj.id).pose.position, obj.pose.position)
        if obj.id in riders:
            assert np.allclose(shift, moved, atol=1e-6), obj.id
        elif obj.id != oid:
            assert np.allclose(shift, 0.0, atol=1e-9), obj.id
    # the delivered house layout, every format of the whole house; the simulators see the move
    for name in ("house_scene.json", "scene.xml", "scene.urdf", "scene.sdf", "scene.glb", "topdown.png", "house.json"):
        assert (out / name).is_file(), name
    drift, _ = mujoco_drift(out / "scene.xml", [o.id for o in edited.objects], steps=1)
    assert set(drift) == {o.id for o in edited.objects}
    assert (out / "topdown.png").read_bytes() == render_house_plan(edited, base_dir=out)


def test_edit_refuses_an_invalid_edit_of_a_room_and_writes_nothing(run_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "far"
    said = _refused(["edit", str(run_dir), "--room", ROOM, "5_2.center.u = 5_2.center.u + 6", "--out", str(out)])
    assert "out of bounds 5_2" in said and "nothing written" in said
    assert not out.exists()


def test_edit_of_a_house_names_its_rooms_without_room(run_dir: Path, tmp_path: Path) -> None:
    said = _refused(["edit", str(run_dir), "5_2.center.u = 5_2.center.u - 0.1", "--out", str(tmp_path / "e")])
    assert "pick a room with --room" in said and all(r in said for r in ("room_4", "room_5", "room_6", "room_7"))
    assert "has no room 'room_9'" in _refused(["edit", str(run_dir), "--room", "room_9", "x.center.u = 1", "--out", str(tmp_path / "e")])
    assert not (tmp_path / "e").exists()


# -- inspect, render ------------------------------------------------------------------------------


def test_inspect_lists_the_rooms_or_shows_one_room(run_dir: Path, houses: dict[str, House]) -> None:
    listing = _ok(["inspect", str(run_dir)])
    assert listing.startswith(f"house {houses['base'].id}: 4 rooms, {len(houses['base'].objects)} objects")
    shown = json.loads(_ok(["inspect", str(run_dir), "--variant", "2", "--json"]))
    assert [r["id"] for r in shown["rooms"]] == houses["variant_2"].room_ids
    assert {tuple(d["rooms"]) for d in shown["doorways"]} >= {("room_4", "room_5")}
    tree = _ok(["inspect", str(run_dir), "--room", ROOM, "--variant", "1"])
    assert tree.startswith(ROOM) and all(o.id in tree for o in houses["variant_1"].room(ROOM).objects)
    units = json.loads(_ok(["inspect", str(run_dir), "--room", ROOM, "--json"]))["units"]
    assert "floor" in {u["anchor_id"] for u in units}


def test_render_draws_the_house_plan_or_one_room(run_dir: Path, houses: dict[str, House], tmp_path: Path) -> None:
    plan = tmp_path / "plan.png"
    _ok(["render", str(run_dir), "--variant", "2", "--out", str(plan)])
    assert plan.read_bytes() == render_house_plan(houses["variant_2"], base_dir=run_dir / "variant_2", size_px=1024)
    room = tmp_path / "room.png"
    _ok(["render", str(run_dir), "--room", ROOM, "--size", "256", "--out", str(room)])
    with Image.open(room) as png:
        assert png.size == (256, 256)
    unit = tmp_path / "unit.png"
    _ok(["render", str(run_dir), "--room", ROOM, "--unit", "floor", "--size", "256", "--out", str(unit)])
    assert unit.read_bytes() != room.read_bytes()
    assert "--unit needs one room" in _refused(["render", str(run_dir), "--unit", "floor", "--out", str(tmp_path / "n.png")])
    single = load_scene(run_dir, room=ROOM)
    assert isinstance(single, Scene) and not isinstance(single, House)


def test_edit_refuses_an_edit_that_blocks_a_door_of_the_house(run_dir: Path, houses: dict[str, House], tmp_path: Path) -> None:
    """An object moved into a door's clearance zone is a problem only the house shows: refused,
    named, nothing written."""
    from scenemosaic.scene import door_zones

    base = houses["base"]
    zone, obj = next(
        (z, o) for z in door_zones(base) for o in base.room(z.room_id).objects
        if (r := base.room(z.room_id).support_of(o.id)) is not None and r.parent == "floor" and o.size[2] > 0.3
    )  # fmt: skip
    du = zone.polygon.centroid.x - obj.pose.position[0]  # the floor's u and v run along x and y
    dv = zone.polygon.centroid.y - obj.pose.position[1]
    out = tmp_path / "blocked"
    move = [f"{obj.id}.center.u = {obj.id}.center.u + {du:.4f}", f"{obj.id}.center.v = {obj.id}.center.v + {dv:.4f}"]
    args = ["edit", str(run_dir), "--room", zone.room_id, *move]
    said = _refused([*args, "--out", str(out)])
    assert f"a door blocked by {obj.id}" in said and "nothing written" in said
    assert not out.exists()

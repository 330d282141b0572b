"""Assets the asset database does not hold (ProcTHOR-Objaverse's 32-hex ids, a fork's own; issue
54): the house is read, never refused; each such object stands in as a box of its type's median
size in the database (``ObjaGarbageCan`` read as ``GarbageCan``), a floor piece as tall as twice its
centre's height, and every estimate is listed; a run says it once."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.exchange import load_asset_database, load_house, load_scene
from scenemosaic.exchange._procthor import STAND_IN_BOX_M, _nearest_type
from scenemosaic.scene import Scene
from tests.house_forms import BEDROOM, FOUR_ROOMS, objaverse_form


def test_an_objaverse_asset_stands_in_as_its_types_median_box(tmp_path: Path) -> None:
    changed = objaverse_form(FOUR_ROOMS, tmp_path / "house.json")
    house = load_house(tmp_path / "house.json")
    original = load_house(FOUR_ROOMS)
    category = {raw: room.get(oid).category for room in original.rooms for oid, raw in room.provenance.source_ids.items()}
    db = load_asset_database(None)
    raw = {json.dumps(o["id"]): o for o in json.loads((tmp_path / "house.json").read_text())["objects"]}
    estimates = {oid: how for room in house.rooms for oid, how in room.provenance.size_estimates.items()}
    assert len(estimates) == len(changed)
    for room in house.rooms:
        by_raw = {r: oid for oid, r in room.provenance.source_ids.items()}
        for source_id, kind in changed.items():
            oid = by_raw.get(source_id)
            if oid is None:
                continue
            obj = room.get(oid)
            assert obj.category == category[source_id]  # the type's, as the AI2-THOR asset gave it
            bx, by, bz = db.type_boxes[kind]
            if "ran through the room's walls" in estimates[oid]:  # fitted: a smaller footprint of its type
                assert (obj.size[0], obj.size[1]) in [pytest.approx(f) for f in db.type_footprints[kind][1:]]
            else:
                assert obj.size[0] == pytest.approx(bx) and obj.size[1] == pytest.approx(bz)
            item = raw.get(json.dumps(source_id))
            if item is not None and 0.5 * by <= 2 * item["position"]["y"] <= 2 * by:  # a top-level piece standing on the floor
                assert obj.size[2] == pytest.approx(2 * item["position"]["y"])
                assert obj.pose.position[2] == pytest.approx(0.0, abs=1e-6)  # its base on the floor
            assert f"the median {kind} of the asset database" in estimates[oid]


@pytest.mark.parametrize(
    ("kind", "read_as"),
    [("ObjaGarbageCan", "GarbageCan"), ("ObjaDiningChair", "Chair"), ("ObjaBookshelf", "ShelvingUnit"), ("couch", "Sofa"), ("ObjaHamburger", None)],
)
def test_a_type_the_database_lacks_reads_as_its_nearest(kind: str, read_as: str | None) -> None:
    assert _nearest_type(kind, load_asset_database(None).type_boxes) == read_as


def test_a_type_nothing_matches_stands_in_as_a_plain_box_and_is_said(tmp_path: Path) -> None:
    objaverse_form(BEDROOM, tmp_path / "house.json", every=100, unknown="ObjaHamburger")
    scene = load_scene(tmp_path / "house.json")
    assert isinstance(scene, Scene)
    ((oid, how),) = scene.provenance.size_estimates.items()
    assert "stand-in box" in how and "'ObjaHamburger'" in how
    assert np.allclose(sorted(scene.get(oid).size[:2]), sorted(STAND_IN_BOX_M[::2]))


def test_a_run_of_an_objaverse_house_lists_every_estimate(tmp_path: Path) -> None:
    changed = objaverse_form(BEDROOM, tmp_path / "house.json", every=3)
    result = CliRunner().invoke(app, ["generate", str(tmp_path / "house.json"), "--out", str(tmp_path / "run"), "--no-evolve"])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "run" / "report.json").read_text(encoding="utf-8"))
    imported = next(s for s in report["stages"] if s["name"] == "import")
    assert len(imported["detail"]["size_estimates"]) == len(changed)
    assert sum("stand in as boxes sized from estimates" in n for n in report["notes"]) == 1


def test_a_stand_in_whose_median_runs_through_a_wall_takes_a_smaller_footprint(tmp_path: Path) -> None:
    """A counter of an Objaverse asset 45 cm from the kitchen's wall: its type's median box (a
    2.4 x 1.8 m corner counter) would run through the wall where the file puts it, so it takes the
    first smaller footprint of its type that stays on the floor, height and centre kept; said in its
    estimate. A stand-in whose median fits keeps it."""
    from shapely.geometry import Polygon

    house = json.loads(FOUR_ROOMS.read_text(encoding="utf-8"))
    kitchen = next(r for r in house["rooms"] if r["id"] == "room|6")
    xs = [p["x"] for p in kitchen["floorPolygon"]]
    zs = [p["z"] for p in kitchen["floorPolygon"]]
    counter = next(o for o in house["objects"] if o["assetId"].startswith("Countertop"))
    counter.update(assetId="c0ffee" * 5 + "00", objectType="CounterTop")
    counter["position"].update(x=min(xs) + 0.45, z=(min(zs) + max(zs)) / 2)
    counter["rotation"] = {"x": 0, "y": 0, "z": 0}
    path = tmp_path / "house.json"
    path.write_text(json.dumps(house), encoding="utf-8")
    room = next(r for r in load_house(path).rooms if r.provenance.source_room_id == "room|6")
    oid = next(k for k, raw in room.provenance.source_ids.items() if raw == counter["id"])
    obj = room.get(oid)
    db = load_asset_database(None)
    median = db.type_boxes["CounterTop"]
    assert (obj.size[0], obj.size[1]) != pytest.approx((median[0], median[2]))
    assert (obj.size[0], obj.size[1]) in [pytest.approx(f) for f in db.type_footprints["CounterTop"][1:]]
    assert obj.size[2] == pytest.approx(2 * counter["position"]["y"])  # its height still the file's cue
    assert Polygon(room.room.floor).buffer(0.02).covers(Polygon(obj.footprint()))
    assert "ran through the room's walls" in room.provenance.size_estimates[oid]
    # the same counter in the middle of the kitchen keeps its type's median
    counter["position"].update(x=(min(xs) + max(xs)) / 2)
    path.write_text(json.dumps(house), encoding="utf-8")
    room = next(r for r in load_house(path).rooms if r.provenance.source_room_id == "room|6")
    obj = room.get(next(k for k, raw in room.provenance.source_ids.items() if raw == counter["id"]))
    assert (obj.size[0], obj.size[1]) == pytest.approx((median[0], median[2]))

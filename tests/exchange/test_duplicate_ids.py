"""An AI2-THOR house whose objects share an id (a hand edit, two files merged; issue 54): each
object is read under an id of its own, the fault is said once, and the house written back puts
every object at its own scene object's pose, not at the pose of the first with its id."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dataset_helpers import house_items
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.exchange import export_procthor, load_scene
from scenemosaic.scene import Scene

BEDROOM = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_1room_bedroom.json"


def _with_ids(tmp_path: Path, rename) -> Path:
    house = json.loads(BEDROOM.read_text(encoding="utf-8"))
    for i, item in enumerate(house_items(house["objects"])):
        item["id"] = rename(i, item["id"])
    path = tmp_path / "house.json"
    path.write_text(json.dumps(house), encoding="utf-8")
    return path


def test_two_objects_with_one_id_are_read_apart_and_written_back_each_at_its_own_pose(tmp_path: Path) -> None:
    path = _with_ids(tmp_path, lambda i, raw: "2|7" if raw == "2|8" else raw)  # the second nightstand-ish piece
    scene = load_scene(path)
    assert isinstance(scene, Scene)
    by_source = {raw: oid for oid, raw in scene.provenance.source_ids.items()}
    assert {"2|7", "2|7#2"} <= set(by_source) and by_source["2|7"] != by_source["2|7#2"]
    (fault,) = scene.provenance.source_faults
    assert fault == "objects[12]: its id '2|7' is the id of objects[11] too; read as '2|7#2'"
    second = scene.get(by_source["2|7#2"])
    x, y, z = second.pose.position
    moved = second.model_copy(update={"pose": second.pose.model_copy(update={"position": (x + 0.25, y, z)})})
    scene = scene.model_copy(update={"objects": [moved if o.id == moved.id else o for o in scene.objects]})
    written = json.loads(export_procthor(scene, tmp_path / "back").read_text(encoding="utf-8"))
    source = json.loads(path.read_text(encoding="utf-8"))
    first_out, second_out = written["objects"][11], written["objects"][12]
    assert (first_out["id"], second_out["id"]) == ("2|7", "2|7#2")
    assert first_out["position"]["x"] == pytest.approx(source["objects"][11]["position"]["x"], abs=1e-5)
    assert second_out["position"]["x"] == pytest.approx(source["objects"][12]["position"]["x"] + 0.25, abs=1e-5)


def test_a_house_whose_every_id_is_the_same_keeps_every_object_where_it_was(tmp_path: Path) -> None:
    path = _with_ids(tmp_path, lambda i, raw: "same")
    scene = load_scene(path)
    assert isinstance(scene, Scene)
    items = house_items(json.loads(path.read_text(encoding="utf-8"))["objects"])
    assert len(scene.objects) == len(items) and len(scene.provenance.source_faults) == len(items) - 1
    written = house_items(json.loads(export_procthor(scene, tmp_path / "back").read_text(encoding="utf-8"))["objects"])
    assert len({w["id"] for w in written}) == len(items)  # every id its own now
    for before, after in zip(items, written, strict=True):
        for axis in ("x", "y", "z"):
            assert after["position"][axis] == pytest.approx(before["position"][axis], abs=1e-4), (after["id"], axis)


def test_a_run_says_the_fault_once_and_its_written_back_house_holds_both(tmp_path: Path) -> None:
    path = _with_ids(tmp_path, lambda i, raw: "2|7" if raw == "2|8" else raw)
    result = CliRunner().invoke(app, ["generate", str(path), "--out", str(tmp_path / "run"), "--no-evolve"])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "run" / "report.json").read_text(encoding="utf-8"))
    assert report["status"] == "ok"
    said = [n for n in report["notes"] if "fault(s) of the source file" in n]
    assert len(said) == 1 and "read as '2|7#2'" in said[0]
    imported = next(s for s in report["stages"] if s["name"] == "import")
    assert len(imported["detail"]["source_faults"]) == 1
    back = json.loads((tmp_path / "run" / "base" / "house.json").read_text(encoding="utf-8"))
    ids = [o["id"] for o in back["objects"]]
    assert ids.count("2|7") == 1 and ids.count("2|7#2") == 1

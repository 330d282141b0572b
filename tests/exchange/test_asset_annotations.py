"""A user's annotations file for assets the database does not hold (issue 54: ``--asset-annotations``,
Objaverse/objathor's bounding-box JSON): each annotated asset takes the file's box and the type its
category reads as, and is no longer an estimate; a file that cannot size an asset is refused
before the run, naming the entry."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic import GenerateConfig
from scenemosaic.cli import app
from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import load_asset_annotations, load_asset_database, load_house
from scenemosaic.pipeline import SettingsError
from tests.house_forms import BEDROOM, FOUR_ROOMS, objaverse_form


def _objathor(house: Path, changed: dict[str, str], *, scale: float = 1.0) -> dict[str, dict]:
    """Annotations, as objathor writes them, of the Objaverse assets ``objaverse_form`` put in
    ``house``: each an axis-aligned box ``{min, max}`` (centred, ``scale`` times the AI2-THOR
    asset's it replaced) and a lower-case free-text category."""
    db = load_asset_database(None)
    originals = {}
    for item in _walk(json.loads(house.read_text(encoding="utf-8"))["objects"]):
        if item["id"] in changed:
            originals[item["assetId"]] = changed[item["id"]]
    out: dict[str, dict] = {}
    for uid, kind in originals.items():
        bx, by, bz = (scale * v for v in db.type_boxes[kind])
        words = "".join(f" {c.lower()}" if c.isupper() else c for c in kind).strip()
        box = {"min": {"x": -bx / 2, "y": 0.0, "z": -bz / 2}, "max": {"x": bx / 2, "y": by, "z": bz / 2}}
        out[uid] = {"uid": uid, "category": words, "thor_metadata": {"assetMetadata": {"boundingBox": box}}}
    return out


def _walk(items: list[dict]) -> list[dict]:
    out = []
    for item in items:
        out.append(item)
        out += _walk(item.get("children") or [])
    return out


def test_annotated_objaverse_assets_take_the_files_box_and_are_no_estimates(tmp_path: Path) -> None:
    changed = objaverse_form(FOUR_ROOMS, tmp_path / "house.json")
    notes = _objathor(tmp_path / "house.json", changed, scale=1.3)  # not the type medians: the file's own
    (tmp_path / "annotations.json.gz").write_bytes(gzip.compress(json.dumps(notes).encode()))
    house = load_house(tmp_path / "house.json", asset_database=load_asset_annotations(tmp_path / "annotations.json.gz"))
    db = load_asset_database(None)
    assert not [oid for room in house.rooms for oid in room.provenance.size_estimates]
    checked = 0
    for room in house.rooms:
        for oid, raw in room.provenance.source_ids.items():
            if raw not in changed:
                continue
            bx, by, bz = (1.3 * v for v in db.type_boxes[changed[raw]])
            obj = room.get(oid)
            assert obj.size == pytest.approx((bx, bz, by), abs=1e-6)  # (x, depth, height) from Unity's (x, y, z)
            assert obj.category != "object"  # 'garbage can' reads as GarbageCan, 'arm chair' as ArmChair
            checked += 1
    assert checked == len(changed)
    # without the file the same house is all estimates (the type medians, not the annotated boxes)
    plain = load_house(tmp_path / "house.json")
    assert len([oid for room in plain.rooms for oid in room.provenance.size_estimates]) == len(changed)


def test_a_size_box_and_a_category_the_database_lacks(tmp_path: Path) -> None:
    notes = {
        "f00d" * 8: {"assetMetadata": {"boundingBox": {"x": 0.5, "y": 0.9, "z": 0.4}}, "category": "wooden bookshelf"},
        "beef" * 8: {"boundingBox": {"x": 0.2, "y": 0.3, "z": 0.2}, "category": "hamburger"},
    }
    (tmp_path / "a.json").write_text(json.dumps(notes), encoding="utf-8")
    db = load_asset_annotations(tmp_path / "a.json")
    assert db.boxes["f00d" * 8] == (0.5, 0.9, 0.4) and db.types["f00d" * 8] == "ShelvingUnit"
    assert db.types["beef" * 8] == "Hamburger"  # nothing like it: its own name, sized as annotated
    assert "Bed_1" in db.boxes  # laid over the shipped database, not replacing it


@pytest.mark.parametrize(
    ("entry", "says"),
    [
        ({"category": "chair"}, "no boundingBox"),
        ({"boundingBox": {"x": 0.5, "y": 0.0, "z": 0.4}}, "sizes must be positive"),
        ({"thor_metadata": {"assetMetadata": {"boundingBox": {"min": {"x": 1, "y": 0, "z": 0}, "max": {"x": 0, "y": 1, "z": 1}}}}}, "sizes must be positive"),
    ],
)
def test_an_entry_that_sizes_nothing_is_refused_naming_it(tmp_path: Path, entry: dict, says: str) -> None:
    (tmp_path / "a.json").write_text(json.dumps({"abc123": entry}), encoding="utf-8")
    with pytest.raises(ImportFormatError, match=says) as err:
        load_asset_annotations(tmp_path / "a.json")
    assert "abc123" in str(err.value)


def test_bad_annotations_fail_the_settings_and_the_command_before_the_run(tmp_path: Path) -> None:
    (tmp_path / "a.json.gz").write_bytes(b"not gzip at all")
    with pytest.raises(SettingsError, match="asset_annotations"):
        GenerateConfig(asset_annotations=tmp_path / "a.json.gz")
    result = CliRunner().invoke(
        app, ["generate", str(BEDROOM), "--out", str(tmp_path / "run"), "--asset-annotations", str(tmp_path / "a.json.gz")]
    )
    assert result.exit_code == 2 and "--asset-annotations" in result.output
    assert not (tmp_path / "run").exists()


def test_a_run_with_annotations_lists_no_estimate_and_records_the_file(tmp_path: Path) -> None:
    changed = objaverse_form(BEDROOM, tmp_path / "house.json", every=3)
    (tmp_path / "a.json").write_text(json.dumps(_objathor(tmp_path / "house.json", changed)), encoding="utf-8")
    result = CliRunner().invoke(
        app,
        ["generate", str(tmp_path / "house.json"), "--out", str(tmp_path / "run"), "--no-evolve", "--asset-annotations", str(tmp_path / "a.json")],
    )
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "run" / "report.json").read_text(encoding="utf-8"))
    imported = next(s for s in report["stages"] if s["name"] == "import")
    assert "size_estimates" not in imported["detail"]
    assert not any("sized from estimates" in n for n in report["notes"])
    assert Path(report["config"]["asset_annotations"]).name == "a.json"

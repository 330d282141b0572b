"""A dataset of houses as a batch's input (issue 54): one job a house, named ``<stem>-<index>``, a
range of them by ``--index A:B``, a second batch skipping every finished house; a manifest line
naming one house of a dataset by its ``index``; ``generate FILE --index N`` on the command line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from batch_helpers import write_manifest
from dataset_helpers import ONE_ROOM, TWO_ROOMS, write_dataset
from typer.testing import CliRunner

from scenemosaic.batch import ManifestError, load_manifest
from scenemosaic.cli import app
from scenemosaic.exceptions import UsageError

runner = CliRunner()


def test_a_dataset_is_one_job_a_house_and_a_range_of_them(tmp_path: Path) -> None:
    dataset = write_dataset(tmp_path / "val.jsonl.gz", [ONE_ROOM, TWO_ROOMS, ONE_ROOM], blank_after=1)
    jobs = load_manifest(dataset)
    assert [j.id for j in jobs] == ["val-0", "val-1", "val-2"]
    assert [j.settings["index"] for j in jobs] == [0, 1, 2]
    assert [j.line for j in jobs] == [1, 2, 4]
    assert all(j.input == dataset.resolve() for j in jobs)
    assert [j.id for j in load_manifest(dataset, slice(1, None))] == ["val-1", "val-2"]
    with pytest.raises(ManifestError, match="holds 3 houses; none in the range"):
        load_manifest(dataset, slice(5, 9))
    manifest = write_manifest(tmp_path / "jobs.jsonl", [{"input": dataset, "index": 1, "variants": 2}])
    (line,) = load_manifest(manifest)
    assert line.id == "val-1" and line.settings["index"] == 1 and line.settings["variants"] == 2
    with pytest.raises(UsageError, match="picks houses of a dataset"):
        load_manifest(manifest, slice(0, 1))


def test_a_manifest_line_names_a_house_of_a_dataset_by_index_only(tmp_path: Path) -> None:
    dataset = write_dataset(tmp_path / "val.jsonl.gz", [ONE_ROOM])
    no_index = write_manifest(tmp_path / "a.jsonl", [{"input": dataset}])
    with pytest.raises(ManifestError, match="is a dataset of houses: give the house's 'index'"):
        load_manifest(no_index)
    stray = write_manifest(tmp_path / "b.jsonl", [{"input": TWO_ROOMS, "index": 0}])
    with pytest.raises(ManifestError, match="'index' picks a house of a dataset input"):
        load_manifest(stray)


def test_a_batch_over_a_dataset_runs_each_house_once(tmp_path: Path) -> None:
    dataset = write_dataset(tmp_path / "val.jsonl.gz", [ONE_ROOM, TWO_ROOMS, ONE_ROOM])
    out = tmp_path / "out"
    result = runner.invoke(app, ["batch", str(dataset), "--out", str(out), "--index", "0:2"])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "batch_summary.json").read_text(encoding="utf-8"))
    assert {j["id"]: j["status"] for j in summary["jobs"]} == {"val-0": "ok", "val-1": "ok"}
    assert not (out / "val-2").exists()
    report = json.loads((out / "val-1" / "report.json").read_text(encoding="utf-8"))
    assert report["config"]["index"] == 1
    assert (out / "val-1" / "base" / "house_scene.json").is_file()  # house 1 has two rooms: a house run
    again = runner.invoke(app, ["batch", str(dataset), "--out", str(out), "--index", "0:2"])
    assert again.exit_code == 0, again.output
    summary = json.loads((out / "batch_summary.json").read_text(encoding="utf-8"))
    assert {j["id"]: j["status"] for j in summary["jobs"]} == {"val-0": "skipped", "val-1": "skipped"}
    bad = runner.invoke(app, ["batch", str(dataset), "--out", str(out), "--index", "3:1"])
    assert bad.exit_code == 2 and "give A:B" in bad.output


def test_generate_takes_a_house_of_a_dataset_by_index(tmp_path: Path) -> None:
    dataset = write_dataset(tmp_path / "val.jsonl", [TWO_ROOMS, ONE_ROOM])
    out = tmp_path / "run"
    result = runner.invoke(app, ["generate", str(dataset), "--index", "1", "--out", str(out)])
    assert result.exit_code == 0, result.output
    scene = json.loads((out / "base" / "scene.json").read_text(encoding="utf-8"))
    assert scene["provenance"]["source_index"] == 1
    missing = runner.invoke(app, ["generate", str(dataset), "--out", str(tmp_path / "run2")])
    assert missing.exit_code == 2 and "dataset of 2 houses" in missing.output

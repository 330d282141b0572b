"""The manifest is checked before anything runs; every bad line is named by its number."""

from __future__ import annotations

import json
import os
import sys
from dataclasses import fields
from pathlib import Path

import pytest
from batch_helpers import BEDROOM, DINING, write_manifest
from typer.testing import CliRunner

from scenemosaic.batch import JOB_SETTINGS, ManifestError, load_manifest, run_batch, sanitize_id
from scenemosaic.cli import app
from scenemosaic.exceptions import ImportFormatError, MissingExtraError, UsageError
from scenemosaic.pipeline import GenerateConfig


def _manifest(tmp_path: Path, *lines: str) -> Path:
    path = tmp_path / "jobs.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _raises_on_line(path: Path, line: int) -> ManifestError:
    with pytest.raises(ManifestError) as info:
        load_manifest(path)
    assert info.value.line == line
    assert f"line {line}:" in str(info.value)
    assert str(path) in str(info.value)
    return info.value


def test_bad_json_names_the_line(tmp_path: Path) -> None:
    path = _manifest(tmp_path, json.dumps({"input": str(DINING)}), '{"input": "a.json", "variants": 2', "")
    error = _raises_on_line(path, 2)
    assert "not valid JSON" in str(error)
    assert isinstance(error, ImportFormatError)


def test_unknown_key_names_the_line_and_the_key(tmp_path: Path) -> None:
    path = _manifest(tmp_path, json.dumps({"input": str(DINING)}), "", json.dumps({"input": str(DINING), "varaints": 3}))
    error = _raises_on_line(path, 3)  # the blank line counts
    assert "unknown key 'varaints'" in str(error)
    assert "variants" in str(error)  # the allowed keys are listed


def test_missing_input_key_and_missing_input_file_name_the_line(tmp_path: Path) -> None:
    path = _manifest(tmp_path, json.dumps({"variants": 1}))
    assert "'input' is required" in str(_raises_on_line(path, 1))
    path = _manifest(tmp_path, json.dumps({"input": str(DINING)}), json.dumps({"input": "rooms/nope.json"}))
    error = _raises_on_line(path, 2)
    assert f"input not found: {tmp_path / 'rooms' / 'nope.json'}" in str(error)


def test_every_bad_line_is_reported_at_once(tmp_path: Path) -> None:
    path = _manifest(
        tmp_path,
        "[1, 2]",
        json.dumps({"input": str(DINING), "variants": "5"}),  # strict: a string is not a number
        json.dumps({"input": str(DINING), "variants": 2, "evolve": False}),
        json.dumps({"input": str(DINING)}),
    )
    error = _raises_on_line(path, 1)
    assert [p.split(":")[0] for p in error.problems] == ["line 1", "line 2", "line 3"]
    assert "expected a JSON object" in error.problems[0]
    assert "'variants'" in error.problems[1]
    assert "variants come from the evolve stage" in error.problems[2]


def test_an_empty_manifest_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(ManifestError, match="no job"):
        load_manifest(_manifest(tmp_path, "", "  "))


def test_inputs_and_cassettes_are_relative_to_the_manifest(tmp_path: Path) -> None:
    folder = tmp_path / "lists"
    relative = os.path.relpath(DINING, folder)
    path = write_manifest(
        folder / "jobs.jsonl",
        [{"input": relative, "variants": 3, "seed": 7, "model": "replay:tapes/dining.json", "asset_dir": "assets"}],
    )
    (job,) = load_manifest(path)
    assert job.input == DINING.resolve()
    assert job.line == 1
    assert job.settings["model"] == f"replay:{(folder / 'tapes' / 'dining.json').resolve()}"
    assert job.settings["asset_dir"] == str((folder / "assets").resolve())
    config = job.config(cache_dir=tmp_path / "cache")
    assert (config.variants, config.seed, config.overwrite, config.resume) == (3, 7, True, False)
    assert config.asset_dir == (folder / "assets").resolve() and config.cache_dir == tmp_path / "cache"


def test_ids_default_to_the_stem_numbered_when_shared_and_are_sanitized(tmp_path: Path) -> None:
    path = write_manifest(
        tmp_path / "jobs.jsonl",
        [
            {"input": DINING},
            {"input": DINING, "seed": 1},
            {"input": BEDROOM},
            {"input": BEDROOM, "id": "../My Room #2"},
            {"input": BEDROOM, "id": "..."},
        ],
    )
    ids = [job.id for job in load_manifest(path)]
    stem = DINING.stem
    assert ids == [f"{stem}-1", f"{stem}-2", BEDROOM.stem, "My_Room_2", "job"]
    assert sanitize_id("a/b\\c:d") == "a_b_c_d"
    assert sanitize_id(".hidden") == "hidden"


def test_a_duplicate_id_is_an_error_naming_both_lines(tmp_path: Path) -> None:
    path = write_manifest(tmp_path / "jobs.jsonl", [{"input": DINING, "id": "room a"}, {"input": BEDROOM, "id": "Room_A"}])
    error = _raises_on_line(path, 2)
    assert "already used on line 1" in str(error)


def test_manifest_settings_are_generate_config_fields() -> None:
    assert set(JOB_SETTINGS) <= {f.name for f in fields(GenerateConfig)}
    assert {"variants", "seed", "model", "evolve"} <= set(JOB_SETTINGS)
    assert not {"overwrite", "resume", "cache_dir", "agents"} & set(JOB_SETTINGS)


def test_a_bad_manifest_stops_the_batch_before_anything_is_written(tmp_path: Path) -> None:
    path = _manifest(tmp_path, json.dumps({"input": str(DINING)}), "{oops")
    out = tmp_path / "out"
    with pytest.raises(ManifestError):
        run_batch(path, out)
    assert not out.exists()


def test_bad_batch_arguments_are_usage_errors(tmp_path: Path) -> None:
    path = write_manifest(tmp_path / "jobs.jsonl", [{"input": DINING}])
    with pytest.raises(UsageError, match="workers"):
        run_batch(path, tmp_path / "out", workers=0)
    with pytest.raises(UsageError, match="timeout_s"):
        run_batch(path, tmp_path / "out", timeout_s=0)
    with pytest.raises(UsageError, match="executor"):
        run_batch(path, tmp_path / "out", executor="slurm")  # type: ignore[arg-type]


def test_parallel_jobs_may_not_record_into_one_cassette(tmp_path: Path) -> None:
    model = "record_missing:tape.json=openai:some-model"
    path = write_manifest(tmp_path / "jobs.jsonl", [{"input": DINING, "model": model}, {"input": BEDROOM, "model": model}])
    with pytest.raises(UsageError, match="lines 1, 2 record into the same cassette"):
        run_batch(path, tmp_path / "out", workers=2)
    assert not (tmp_path / "out").exists()


def test_the_ray_executor_without_ray_names_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray now raises ImportError
    path = write_manifest(tmp_path / "jobs.jsonl", [{"input": DINING}])
    with pytest.raises(MissingExtraError, match=r"pip install 'scenemosaic\[ray\]'"):
        run_batch(path, tmp_path / "out", executor="ray")
    assert not (tmp_path / "out").exists()


def test_cli_batch_help_and_bad_manifest(tmp_path: Path) -> None:
    runner = CliRunner()
    helped = runner.invoke(app, ["batch", "--help"])
    assert helped.exit_code == 0 and "--executor" in helped.output and "--timeout" in helped.output
    path = _manifest(tmp_path, json.dumps({"input": str(DINING)}), json.dumps({"input": str(DINING), "colour": "red"}))
    result = runner.invoke(app, ["batch", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert "line 2" in result.output and "colour" in result.output
    assert not (tmp_path / "out").exists()


def test_a_photograph_job_with_its_detections(tmp_path: Path) -> None:
    """A manifest line for a photograph: the detections path is taken relative to the manifest,
    and the perception settings reach the job's GenerateConfig; a field of view out of range is refused."""
    photos = Path(__file__).resolve().parents[2] / "data" / "images" / "demo_bedroom"
    line = {
        "input": str(photos / "photo.png"),
        "detections": os.path.relpath(photos / "boxes.json", tmp_path),
        "segmenter": "grabcut",
        "reconstructor": "box-lifter",
        "hfov_deg": 60,
    }
    jobs = load_manifest(_manifest(tmp_path, json.dumps(line)))
    config = jobs[0].config()
    assert config.detections == (photos / "boxes.json").resolve()
    assert (config.segmenter, config.reconstructor, config.hfov_deg) == ("grabcut", "box-lifter", 60)
    _raises_on_line(_manifest(tmp_path, json.dumps({**line, "hfov_deg": 300})), 1)

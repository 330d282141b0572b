"""The manifest is checked before anything runs; every bad line is named by its number."""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path
from typing import Any

import pytest
from batch_helpers import BEDROOM, DINING, write_manifest
from typer.testing import CliRunner

from scenemosaic.batch import (
    JOB_SETTINGS,
    LINE_KEYS,
    NOT_IN_MANIFEST,
    ManifestError,
    load_manifest,
    run_batch,
    sanitize_id,
)
from scenemosaic.cli import app
from scenemosaic.exceptions import ImportFormatError, MissingExtraError, UsageError
from scenemosaic.pipeline import SETTINGS, GenerateConfig
from scenemosaic.scene import PROCTHOR_PRIORS_DIR


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
    """Every GenerateConfig field is a manifest key, or is listed as not taken with the reason."""
    assert set(JOB_SETTINGS) | set(NOT_IN_MANIFEST) == set(GenerateConfig.model_fields)
    assert not set(JOB_SETTINGS) & set(NOT_IN_MANIFEST) and all(NOT_IN_MANIFEST.values())
    assert not set(LINE_KEYS) & set(GenerateConfig.model_fields)
    assert {"variants", "seed", "model", "evolve", "prompt", "image_model", "image_size", "hfov_deg"} <= set(JOB_SETTINGS)
    assert set(NOT_IN_MANIFEST) == {
        "overwrite", "resume", "restart_stale", "cache_dir", "reply_cache", "rate_limit_dir", "agents", "layout_rules",
    }  # fmt: skip
    # every setting a generate flag sets, a manifest line can set too, but the batch's own
    assert {f for f, s in SETTINGS.items() if s.flag} - set(JOB_SETTINGS) == {"overwrite", "resume", "restart_stale", "cache_dir", "reply_cache"}


def test_a_line_carries_every_generate_setting(tmp_path: Path) -> None:
    """A manifest line may set every setting in JOB_SETTINGS (the prompt too, instead of an
    input); each reaches the job's GenerateConfig, paths taken relative to the manifest."""
    folder = tmp_path / "lists"
    shutil.copytree(PROCTHOR_PRIORS_DIR, tmp_path / "priors")  # a usable priors folder
    (tmp_path / "sizes.json").write_text('{"abc": {"boundingBox": {"x": 1, "y": 1, "z": 1}}}', encoding="utf-8")
    line: dict[str, Any] = {
        "format": "image", "room": "room|3", "asset_dir": "assets", "priors_dir": "../priors", "asset_annotations": "../sizes.json",
        "detections": "boxes.json", "segmenter": "grabcut", "reconstructor": "box-lifter", "hfov_deg": 55.0, "camera_height_m": 1.5,
        "prompt": "a small bedroom", "image_model": "gpt-image-1", "image_size": "512x512",
        "model": "replay:tapes/bedroom.json", "vision": False, "solver_fallback": False, "variants": 2,
        "evolve": True, "evolve_rounds": 3, "save_views": True, "request_timeout_s": 12.5, "deadline_s": 600.0,
        "unusable_replies": 3,
        "max_concurrency": 2, "requests_per_minute": 30.0, "tokens_per_minute": 9000.0, "seed": 7, "open_state": "random",
        "stabilize": True, "strict": True, "room_workers": 2, "fallback": "rules", "max_input_mb": 50.0,
        "allow_orphans": True, "clutter": "vary", "clutter_density": 6.5, "index": None,
    }  # fmt: skip
    assert set(line) == set(JOB_SETTINGS)
    (job,) = load_manifest(write_manifest(folder / "jobs.jsonl", [line]))
    assert job.input is None and job.id == "prompt" and job.label == "prompt: a small bedroom"
    config = job.config()
    paths = {"asset_dir": folder / "assets", "priors_dir": tmp_path / "priors", "asset_annotations": tmp_path / "sizes.json", "detections": folder / "boxes.json"}
    expected = {**line, **{k: v.resolve() for k, v in paths.items()}}
    expected["model"] = f"replay:{(folder / 'tapes' / 'bedroom.json').resolve()}"
    assert {name: getattr(config, name) for name in JOB_SETTINGS} == expected
    assert job.settings == {k: str(v) if isinstance(v, Path) else v for k, v in expected.items()}


def test_settings_the_manifest_does_not_take_name_the_reason(tmp_path: Path) -> None:
    path = _manifest(tmp_path, json.dumps({"input": str(DINING), "overwrite": True, "reply_cache": "r"}))
    error = _raises_on_line(path, 1)
    assert "key 'overwrite' is not taken in a manifest: the batch sets it" in str(error)
    assert "key 'reply_cache' is not taken" in str(error)


def test_input_or_prompt_but_not_both(tmp_path: Path) -> None:
    both = _manifest(tmp_path, json.dumps({"input": str(DINING), "prompt": "a room"}))
    assert "not both" in str(_raises_on_line(both, 1))
    empty = _manifest(tmp_path, json.dumps({"prompt": " "}))
    assert "the text prompt is empty" in str(_raises_on_line(empty, 1))
    jobs = load_manifest(_manifest(tmp_path, json.dumps({"prompt": "a"}), json.dumps({"prompt": "b", "seed": 1})))
    assert [(j.id, j.input) for j in jobs] == [("prompt-1", None), ("prompt-2", None)]


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


def test_ids_in_other_scripts_stay_distinct() -> None:
    """Two jobs named in a script without Latin letters do not both become ``job`` (and collide)."""
    from scenemosaic.batch._manifest import sanitize_id

    ids = [sanitize_id(t) for t in ("卧室", "厨房", "Кухня", "café")]
    assert len(set(ids)) == 4 and ids[3] == "cafe"
    assert all(i and not i.startswith(".") and "/" not in i for i in ids)

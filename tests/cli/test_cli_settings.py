"""`scenemosaic generate`'s options against GenerateConfig's fields: every field has a flag or
says why not, every flag reaches its field, and a bad value is named by its flag."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from scenemosaic import cli
from scenemosaic.cli import app
from scenemosaic.pipeline import SETTINGS, GenerateConfig
from scenemosaic.scene import PROCTHOR_PRIORS_DIR

runner = CliRunner()

NOT_SETTINGS = {"input_path", "out", "log_level", "log_format"}
"""generate's parameters that are not GenerateConfig settings."""


def _generate_options() -> dict[str, Any]:
    """generate's parameters by name (typer's own click objects)."""
    generate = typer.main.get_command(app).commands["generate"]  # type: ignore[attr-defined]
    return {p.name: p for p in generate.params if p.name is not None}


def _flags(param: Any) -> set[str]:
    return {*param.opts, *getattr(param, "secondary_opts", [])}


def test_every_setting_has_a_flag_or_says_why_not() -> None:
    options = _generate_options()
    flags = {flag: name for name, p in options.items() for flag in _flags(p)}
    for field, setting in SETTINGS.items():
        if setting.flag is None:
            assert setting.no_flag, f"{field}: neither a flag nor a reason"
            continue
        assert setting.flag in flags, f"{field}: {setting.flag} is not an option of generate"
    named = {flags[s.flag] for s in SETTINGS.values() if s.flag is not None}
    assert set(options) - NOT_SETTINGS == named, "a generate option that is no GenerateConfig setting"
    assert sorted(f for f, s in SETTINGS.items() if s.flag is None) == ["agents", "layout_rules", "rate_limit_dir"]


def _capture(monkeypatch: pytest.MonkeyPatch) -> list[tuple[Path | None, Path, GenerateConfig]]:
    seen: list[tuple[Path | None, Path, GenerateConfig]] = []
    monkeypatch.setattr(cli, "_run_cli", lambda input_path, out, config: seen.append((input_path, out, config)))
    return seen


def test_every_flag_reaches_its_setting(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """One run with every flag set away from its default (but --resume, which takes a stopped run's folder)."""
    shutil.copytree(PROCTHOR_PRIORS_DIR, tmp_path / "priors")  # --priors must name usable priors
    (tmp_path / "sizes.json").write_text('{"abc": {"boundingBox": {"x": 1, "y": 1, "z": 1}}}', encoding="utf-8")
    values: dict[str, tuple[list[str], Any]] = {
        "format": (["image"], "image"),
        "room": (["room|3"], "room|3"),
        "allow_orphans": ([], True),
        "asset_dir": ([str(tmp_path / "assets")], tmp_path / "assets"),
        "priors_dir": ([str(tmp_path / "priors")], tmp_path / "priors"),
        "asset_annotations": ([str(tmp_path / "sizes.json")], tmp_path / "sizes.json"),
        "detections": ([str(tmp_path / "boxes.json")], tmp_path / "boxes.json"),
        "segmenter": (["grabcut"], "grabcut"),
        "reconstructor": (["box-lifter"], "box-lifter"),
        "hfov_deg": (["55"], 55.0),
        "camera_height_m": (["1.45"], 1.45),
        "prompt": (["a small bedroom"], "a small bedroom"),
        "image_model": (["gpt-image-1"], "gpt-image-1"),
        "image_size": (["512x512"], "512x512"),
        "model": (["openai:qwen@http://localhost:8080/v1"], "openai:qwen@http://localhost:8080/v1"),
        "vision": ([], False),
        "solver_fallback": ([], False),
        "reply_cache": ([str(tmp_path / "replies")], tmp_path / "replies"),
        "variants": (["3"], 3),
        "evolve": ([], True),  # --evolve (the default); --no-evolve below
        "evolve_rounds": (["4"], 4),
        "save_views": ([], True),
        "clutter": (["vary"], "vary"),
        "clutter_density": (["6.5"], 6.5),
        "request_timeout_s": (["12.5"], 12.5),
        "deadline_s": (["600"], 600.0),
        "unusable_replies": (["3"], 3),
        "max_concurrency": (["2"], 2),
        "requests_per_minute": (["30"], 30.0),
        "tokens_per_minute": (["9000"], 9000.0),
        "seed": (["7"], 7),
        "open_state": (["random"], "random"),
        "stabilize": ([], False),
        "strict": ([], True),
        "overwrite": ([], True),
        "cache_dir": ([str(tmp_path / "hulls")], tmp_path / "hulls"),
        "room_workers": (["3"], 3),
        "fallback": (["rules"], "rules"),
        "max_input_mb": (["50"], 50.0),
        "index": (["2"], 2),
        "restart_stale": ([], True),
    }
    switches = {"vision": "--no-vision", "solver_fallback": "--no-solver-fallback", "stabilize": "--no-stabilize"}
    assert set(values) == {f for f, s in SETTINGS.items() if s.flag is not None and f != "resume"}
    args = ["generate", "--out", str(tmp_path / "out")]
    for field, (rest, _) in values.items():
        args += [switches.get(field, SETTINGS[field].flag or ""), *rest]
    seen = _capture(monkeypatch)
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    ((input_path, out, config),) = seen
    assert input_path is None and out == tmp_path / "out"
    for field, (_, expected) in values.items():
        assert getattr(config, field) == expected, field
        if field != "evolve":
            assert expected != GenerateConfig.model_fields[field].default, f"{field}: the test sets its default"
    seen.clear()
    assert runner.invoke(app, ["generate", "--prompt", "a room", "--out", str(tmp_path / "o"), "--no-evolve"]).exit_code == 0
    assert seen[0][2].evolve is False


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--rounds", "0"], "--rounds"),
        (["--hfov", "200"], "--hfov"),
        (["--camera-height", "0"], "--camera-height"),
        (["--variants", "2", "--no-evolve"], "variants come from the evolve stage"),
        (["--deadline", "0"], "--deadline"),
        (["--max-concurrency", "0"], "--max-concurrency"),
    ],
)
def test_a_bad_value_exits_2_named_by_its_flag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, flags: list[str], named: str
) -> None:
    seen = _capture(monkeypatch)
    result = runner.invoke(app, ["generate", "--prompt", "a room", "--out", str(tmp_path / "o"), *flags])
    assert result.exit_code == 2, result.output
    assert named in result.output and "Traceback" not in result.output
    assert not seen


def test_every_option_is_made_from_its_field() -> None:
    """generate's setting options take their default, help and bounds from GenerateConfig's fields
    (none is written in the CLI), and --help lists every flag with its help."""
    from scenemosaic.pipeline._config import setting_options

    options = _generate_options()
    for option in setting_options():
        param = options[option.field]
        assert option.flag in param.opts, option.field
        if option.field != "resume":  # --resume takes the stopped run's folder
            assert param.default == GenerateConfig.model_fields[option.field].default, option.field
        assert param.help == cli.escape(option.help) and param.help, option.field
        assert param.secondary_opts == ([f"--no-{option.flag[2:]}"] if option.switch else []), option.field
    helped = runner.invoke(app, ["generate", "--help"], env={"COLUMNS": "400"})
    assert helped.exit_code == 0, helped.output
    lines = {line.split()[1]: line for line in helped.output.splitlines() if line.startswith("│ --")}
    for option in setting_options():
        assert option.help[:30] in lines[option.flag], option.flag
    assert "[5 to 170]" in lines["--hfov"] and "[transient|rules]" in lines["--fallback"]
    assert "-o" in lines["--out"] and "--resume" in lines and "--log-level" in lines

"""GenerateConfig's settings are declared once: validated in one place, grouped, and marked as
deciding the results (or not) on the fields themselves."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenemosaic.exceptions import UsageError
from scenemosaic.pipeline import (
    SETTINGS,
    GenerateConfig,
    Setting,
    SettingsError,
    config_from_record,
    config_record,
)

DOCS = Path(__file__).resolve().parents[2] / "docs" / "settings.md"

# The record report.json and the checkpoint held before the settings were declared on the fields:
# its keys must not change (a --resume of an older run, a batch's skip test compare them). A new
# setting whose default is None may join: an older record without it reads the same.
RECORD_KEYS = {
    "format", "model", "seed", "room", "stabilize", "solver_fallback", "fallback", "vision", "request_timeout_s", "deadline_s",
    "unusable_replies",
    "variants", "evolve", "evolve_rounds", "save_views", "segmenter", "reconstructor", "hfov_deg", "camera_height_m",
    "prompt", "image_model", "image_size", "clutter", "clutter_density",
    "asset_dir", "cache_dir", "priors_dir", "asset_annotations", "detections", "allow_orphans", "open_state", "index",
}  # fmt: skip


def test_the_python_api_keeps_its_keywords_and_defaults() -> None:
    config = GenerateConfig(model="rules", seed=0)
    assert (config.variants, config.evolve, config.evolve_rounds, config.segmenter) == (0, True, 8, "auto")
    assert GenerateConfig(detections="boxes.json").detections == Path("boxes.json")  # a path may be a string
    assert GenerateConfig() == GenerateConfig()
    with pytest.raises(ValueError, match="frozen"):
        config.seed = 3  # type: ignore[misc]


def test_every_field_declares_its_group_and_whether_it_decides() -> None:
    assert list(SETTINGS) == list(GenerateConfig.model_fields)
    for name, setting in SETTINGS.items():
        assert isinstance(setting, Setting), name
        assert setting.group in ("input", "perception", "model", "evolution", "limits", "run"), name
        assert (setting.flag is None) != (setting.no_flag is None), name
        assert not (setting.decides and setting.recorded), name
        assert not setting.recorded or setting.path, name
    assert set(config_record(GenerateConfig())) == RECORD_KEYS


@pytest.mark.parametrize(
    ("settings", "problem"),
    [
        ({"variants": -1}, r"'variants': .*greater than or equal to 0"),
        ({"evolve_rounds": 0}, r"'evolve_rounds': .*greater than or equal to 1"),
        ({"variants": 2, "evolve": False}, "variants come from the evolve stage"),
        ({"request_timeout_s": 0}, r"'request_timeout_s': .*greater than 0"),
        ({"deadline_s": -5.0}, r"'deadline_s': .*above 0 seconds \(or none\)"),
        ({"deadline_s": "soon"}, r"'deadline_s': .*should be 'none'"),
        ({"hfov_deg": 300}, r"'hfov_deg': .*less than or equal to 170"),
        ({"hfov_deg": 2}, r"'hfov_deg': .*greater than or equal to 5"),
        ({"camera_height_m": 0}, r"'camera_height_m': .*greater than 0.1"),
        ({"camera_height_m": 40}, r"'camera_height_m': .*less than or equal to 10"),
        ({"max_concurrency": 0}, r"'max_concurrency'"),
        ({"requests_per_minute": 0}, r"'requests_per_minute'"),
        ({"seed": "3"}, r"'seed': .*valid integer"),  # strict: a string is not a number
        ({"segmenter": 3}, r"'segmenter': expected a segmenter name or a Segmenter"),
        ({"agents": ["support"]}, r"'agents': expected TaskAgent instances"),
        ({"prompt": "  "}, "the text prompt is empty"),
        ({"varaints": 3}, r"'varaints': not a setting of generate"),
    ],
)
def test_a_bad_setting_is_a_usage_error_naming_it(settings: dict[str, Any], problem: str) -> None:
    with pytest.raises(UsageError, match=problem) as info:
        GenerateConfig(**settings)
    assert isinstance(info.value, SettingsError) and info.value.problems


def test_every_bad_setting_is_named_at_once() -> None:
    with pytest.raises(SettingsError) as info:
        GenerateConfig(variants=-1, evolve_rounds=0, hfov_deg=500)
    assert [field for field, _ in info.value.problems] == ["hfov_deg", "variants", "evolve_rounds"]
    assert info.value.describe(lambda f: f"--{f}")[0].startswith("--hfov_deg: ")


def test_objects_are_taken_where_a_name_is_and_recorded_by_their_name() -> None:
    from scenemosaic.models import RulesModel
    from scenemosaic.perception import BoxLifter, BoxSegmenter

    config = GenerateConfig(model=RulesModel(), segmenter=BoxSegmenter(), reconstructor=BoxLifter(), layout_rules=[len])
    record = config_record(config)
    assert record["model"] == config.model.name  # type: ignore[union-attr]
    assert (record["segmenter"], record["reconstructor"]) == (BoxSegmenter().name, BoxLifter().name)
    with pytest.raises(SettingsError, match="layout rules must be callables"):
        GenerateConfig(layout_rules=[np.float64(1.0)])


def test_the_record_round_trips_and_keeps_the_old_values(tmp_path: Path) -> None:
    config = GenerateConfig(
        model="rules", seed=7, variants=3, hfov_deg=55.5, detections=tmp_path / "boxes.json", cache_dir=tmp_path,
        prompt="a small bedroom", image_size="512x512", request_timeout_s=30.0, max_concurrency=2, strict=True,
    )  # fmt: skip
    record = config_record(config)
    assert record["detections"] == str(tmp_path / "boxes.json") and record["cache_dir"] == str(tmp_path)
    assert record["asset_dir"] is None and "max_concurrency" not in record and "strict" not in record
    again = config_from_record(record, resume=True)
    assert again.resume and config_record(again) == record
    assert again.detections == tmp_path / "boxes.json"
    assert config_from_record({**record, "not_a_setting": 1, "variants_requested": 3}) == config_from_record(record)


def test_a_whole_number_for_a_float_setting_is_recorded_as_written() -> None:
    """From Python, ``hfov_deg=60`` stays 60 in the record (report.json as before); a manifest's
    JSON numbers for float settings are floats, as a manifest line always gave them."""
    assert config_record(GenerateConfig(hfov_deg=60, deadline_s=90))["hfov_deg"] == 60
    assert type(config_record(GenerateConfig(hfov_deg=60, deadline_s=90))["deadline_s"]) is int
    from_json = GenerateConfig.model_validate({"hfov_deg": 60}, context={"json_numbers": True})
    assert type(from_json.hfov_deg) is float


def test_docs_list_every_setting_with_its_group_and_flag() -> None:
    text = DOCS.read_text(encoding="utf-8")
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| `(\w+)` \|.*$", text, re.MULTILINE)}
    assert set(rows) == set(SETTINGS), set(rows) ^ set(SETTINGS)
    for name, setting in SETTINGS.items():
        cells = [c.strip() for c in rows[name].strip("|").split("|")]
        assert cells[1] == setting.group, name
        assert cells[2] == ("yes" if setting.decides else "recorded" if setting.recorded else ""), name
        assert cells[3] == (f"`{setting.flag}`" if setting.flag else "—"), name
        assert cells[4] == ("—" if setting.no_manifest else "yes"), name


def test_an_unusable_priors_folder_fails_before_the_run(tmp_path: Path) -> None:
    """A ``--priors`` folder without the priors (or with broken ones) is a configuration error at
    once, not a silent fall back to the shipped priors with status ``ok``."""
    from scenemosaic.scene import PROCTHOR_PRIORS_DIR

    with pytest.raises(SettingsError, match="not a usable priors folder"):
        GenerateConfig(priors_dir=tmp_path / "missing")
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in ("receptacles.json", "placement-annotations.json"):
        (broken / name).write_text("{not json", encoding="utf-8")
    with pytest.raises(SettingsError, match="priors_dir"):
        GenerateConfig(priors_dir=broken)
    assert GenerateConfig(priors_dir=PROCTHOR_PRIORS_DIR).priors_dir == PROCTHOR_PRIORS_DIR


def test_the_docs_table_is_the_one_the_fields_make() -> None:
    """``docs/settings.md``'s table is rendered from the fields (the prose around it is kept), so
    the doc cannot drift from them."""
    from scenemosaic.pipeline._config import SETTINGS_TABLE_BEGIN, settings_doc, settings_table

    text = DOCS.read_text(encoding="utf-8")
    assert settings_doc(text) == text, (
        "docs/settings.md's table differs from GenerateConfig's fields: rewrite it with the command in its 'The settings'"
    )
    assert settings_table() in text and text.index(SETTINGS_TABLE_BEGIN) > text.index("## The settings")


def test_every_flag_has_a_help_sentence_and_its_bounds() -> None:
    from scenemosaic.pipeline._config import setting_bounds, setting_options

    options = {o.field: o for o in setting_options()}
    assert set(options) == {f for f, s in SETTINGS.items() if s.flag is not None}
    for name, option in options.items():
        assert option.help.endswith((".", "]")) and 5 < len(option.help) < 200, (name, option.help)
        assert "``" not in option.help and ":class:" not in option.help, name
        assert option.default == GenerateConfig.model_fields[name].default, name
    assert (setting_bounds("hfov_deg"), setting_bounds("variants"), setting_bounds("request_timeout_s")) == ("5 to 170", "0 or more", "above 0")
    assert options["evolve_rounds"].help.endswith("[1 or more]") and options["fallback"].choices == ("transient", "rules")
    assert {o.decls for o in options.values() if o.switch} == {
        "--vision/--no-vision", "--solver-fallback/--no-solver-fallback", "--evolve/--no-evolve", "--stabilize/--no-stabilize",
    }  # fmt: skip


def test_the_defaults_a_docstring_names_are_the_code_s() -> None:
    """Where a docstring gives the number a ``None`` default stands for, it is the constant's."""
    from scenemosaic.evolve import MAX_ROUNDS
    from scenemosaic.perception import DEFAULT_HFOV_DEG
    from scenemosaic.pipeline._config import INPUT_SIZE_LIMITS_MB

    doc = {name: " ".join((info.description or "").split()) for name, info in GenerateConfig.model_fields.items()}
    limits = INPUT_SIZE_LIMITS_MB
    assert f"{limits['scene']:g} for a scene file, {limits['image']:g} for a photograph" in doc["max_input_mb"]
    assert f"else {DEFAULT_HFOV_DEG:g})" in doc["hfov_deg"]
    assert GenerateConfig.model_fields["evolve_rounds"].default == MAX_ROUNDS

"""parse_model: every accepted spelling, the vision switches, and the errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.exceptions import ModelConfigError
from scenemosaic.models import LimitedModel, OpenAIChatModel, ReplayModel, RulesModel, parse_model


@pytest.fixture(autouse=True)
def _clean_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SCENEMOSAIC_VISION", raising=False)
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")


def test_rules() -> None:
    model = parse_model("rules", vision=True)
    assert isinstance(model, RulesModel)
    assert model.vision is False


def test_openai_default_base_url() -> None:
    model = parse_model("openai:gpt-4o-mini")
    assert isinstance(model, OpenAIChatModel)
    assert (model.model, model.base_url, model.vision) == ("gpt-4o-mini", "https://api.openai.com/v1", True)
    assert model.name == "openai:gpt-4o-mini"


def test_openai_base_url_with_port_path_and_colon_in_model_name() -> None:
    model = parse_model("openai:qwen2.5:0.5b-instruct@http://127.0.0.1:8089/v1/", structured="json_object")
    assert isinstance(model, OpenAIChatModel)
    assert model.model == "qwen2.5:0.5b-instruct"
    assert model.base_url == "http://127.0.0.1:8089/v1"
    assert model.structured == "json_object"


def test_vision_kwarg_and_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    assert parse_model("openai:m@http://h/v1", vision=False).vision is False
    monkeypatch.setenv("SCENEMOSAIC_VISION", "0")
    assert parse_model("openai:m@http://h/v1").vision is False
    assert parse_model("openai:m@http://h/v1", vision=True).vision is True  # an explicit kwarg wins
    assert parse_model("openai:m@http://h/v1", vision=None).vision is False  # None: not given
    monkeypatch.setenv("SCENEMOSAIC_VISION", "yes")
    assert parse_model("openai:m@http://h/v1").vision is True
    monkeypatch.setenv("SCENEMOSAIC_VISION", "sometimes")
    with pytest.raises(ModelConfigError, match="SCENEMOSAIC_VISION"):
        parse_model("openai:m@http://h/v1")


def test_limits_wrap_the_model() -> None:
    model = parse_model("openai:m@http://h/v1", max_concurrency=4, requests_per_minute=30)
    assert isinstance(model, LimitedModel)
    assert isinstance(model.wrapped, OpenAIChatModel)
    assert model.limiter.max_concurrency == 4
    assert model.limiter.requests is not None and model.limiter.requests.rate_per_s == pytest.approx(0.5)
    assert model.name == "openai:m"


def test_replay_and_record_specs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "c.json"
    replay = parse_model(f"replay:{path}", vision=False)
    assert isinstance(replay, ReplayModel)
    assert (replay.mode, replay.wrapped, replay.vision) == ("replay", None, False)

    monkeypatch.delenv("OPENAI_API_KEY")  # replaying a recorded OpenAI run needs no key
    named = parse_model(f"replay:{path}=openai:gpt-4o")
    assert isinstance(named, ReplayModel) and named.name == "openai:gpt-4o"

    rec = parse_model(f"record:{path}=openai:m@http://127.0.0.1:8089/v1", max_concurrency=2)
    assert isinstance(rec, ReplayModel) and rec.mode == "record"
    assert isinstance(rec.wrapped, LimitedModel)  # limits apply to the asking model, under the cassette
    assert rec.name == "openai:m"
    missing = parse_model(f"record_missing:{path}=rules")
    assert isinstance(missing, ReplayModel) and isinstance(missing.wrapped, RulesModel)
    assert missing.mode == "record_missing"


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("gpt-4o", "unknown model"),
        ("anthropic:claude", "unknown model scheme 'anthropic'"),
        ("openai:", "names no model"),
        ("openai:m@127.0.0.1:8089", "http"),
        ("record:c.json", "needs the model to ask"),
        ("replay:", "no cassette"),
        ("openai:m@http://h/v1", "bad option"),
    ],
)
def test_bad_specs(spec: str, match: str) -> None:
    kw = {"no_such_option": 1} if match == "bad option" else {}
    with pytest.raises(ModelConfigError, match=match):
        parse_model(spec, **kw)

"""``parse_model``: a model from a short string (CLI flags, config files)."""

from __future__ import annotations

import os
from typing import Any

from scenemosaic.exceptions import ModelConfigError
from scenemosaic.models._base import Model
from scenemosaic.models._limit import LimitedModel
from scenemosaic.models._openai import OpenAIChatModel
from scenemosaic.models._replay import ReplayMode, ReplayModel
from scenemosaic.models._rules import RulesModel

__all__ = ["MODEL_SPEC_HELP", "parse_model"]

MODEL_SPEC_HELP = """\
rules                               each agent's deterministic solver (offline, no network)
openai:<model>[@<base_url>]         OpenAI-compatible Chat Completions, e.g.
                                    openai:gpt-4o-mini  or  openai:qwen@http://127.0.0.1:8089/v1
replay:<path>[=<spec>]              answers only from the cassette at <path>; <spec> (optional)
                                    names the recorded model
record:<path>=<spec>                ask <spec> and (re)record every reply into <path>
record_missing:<path>=<spec>        replay what <path> has, ask <spec> for the rest and record it"""
"""What :func:`parse_model` accepts, in words (shown by the CLI)."""

_LIMIT_KEYS = ("max_concurrency", "requests_per_minute", "tokens_per_minute")
_FALSE = {"0", "false", "no", "off"}
_TRUE = {"1", "true", "yes", "on"}


def _vision_from_env() -> bool | None:
    raw = os.environ.get("SCENEMOSAIC_VISION")
    if raw is None or not raw.strip():
        return None
    value = raw.strip().lower()
    if value in _FALSE:
        return False
    if value in _TRUE:
        return True
    raise ModelConfigError(f"SCENEMOSAIC_VISION must be 0 or 1, not {raw!r}")


def parse_model(spec: str, **kw: Any) -> Model:
    """Build a model from ``spec`` (see :data:`MODEL_SPEC_HELP`).

    Keyword arguments go to :class:`OpenAIChatModel` (``vision``, ``structured``,
    ``api_key_env``, ``timeout_s``, ``transport``...). ``max_concurrency``,
    ``requests_per_minute`` and ``tokens_per_minute`` wrap the asking model in a
    :class:`LimitedModel` (inside any replay, so replayed answers are not throttled).
    ``vision`` (``None`` counts as not given) defaults to the environment variable
    ``SCENEMOSAIC_VISION`` (``0``/``1``) when set, else to true. The ``rules`` model ignores these arguments.
    Unknown schemes raise :class:`ModelConfigError`.
    """
    spec = spec.strip()
    scheme, sep, rest = spec.partition(":")
    if spec == "rules":
        return RulesModel()
    if not sep:
        raise ModelConfigError(f"unknown model {spec!r}; expected one of:\n{MODEL_SPEC_HELP}")
    if kw.get("vision", 0) is None:  # "not said": same as leaving it out
        del kw["vision"]
    if "vision" not in kw:
        env_vision = _vision_from_env()
        if env_vision is not None:
            kw["vision"] = env_vision
    if scheme == "openai":
        return _openai(rest, kw, spec)
    if scheme in ("replay", "record", "record_missing"):
        path, eq, inner_spec = rest.partition("=")
        if not path:
            raise ModelConfigError(f"model {spec!r} names no cassette path")
        if scheme == "replay":
            # The inner model only names what was recorded; it never sends, so needs no key.
            inner = parse_model(inner_spec, **{"api_key": "unused-in-replay", **kw}) if eq else None
            vision = kw.get("vision") if inner is None else None
            return ReplayModel(inner, path, "replay", vision=vision)
        if not eq or not inner_spec:
            raise ModelConfigError(f"model {spec!r} needs the model to ask: {scheme}:<path>=<spec>")
        mode: ReplayMode = "record" if scheme == "record" else "record_missing"
        return ReplayModel(parse_model(inner_spec, **kw), path, mode)
    raise ModelConfigError(
        f"unknown model scheme {scheme!r} in {spec!r}; expected one of:\n{MODEL_SPEC_HELP}"
    )


def _openai(rest: str, kw: dict[str, Any], spec: str) -> Model:
    # The model name comes first and cannot hold '@'; the base URL after it may hold ':' and '/'.
    name, at, base_url = rest.partition("@")
    if not name:
        raise ModelConfigError(f"model {spec!r} names no model: openai:<model>[@<base_url>]")
    limits = {k: kw.pop(k) for k in _LIMIT_KEYS if k in kw}
    if at:
        if not base_url.startswith(("http://", "https://")):
            raise ModelConfigError(f"base URL in {spec!r} must start with http:// or https://")
        kw["base_url"] = base_url
    try:
        model: Model = OpenAIChatModel(name, **kw)
    except TypeError as exc:
        raise ModelConfigError(f"bad option for {spec!r}: {exc}") from exc
    if any(v is not None for v in limits.values()):
        model = LimitedModel(model, **limits)
    return model

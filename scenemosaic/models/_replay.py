"""Record once, replay forever: model replies stored in a plain JSON cassette.

A request is keyed by the SHA-256 of its canonical form: the model name, the messages
(each image replaced by the SHA-256 of its PNG bytes), the output type's JSON schema and
the settings that change an answer (temperature, max_tokens, seed; not the timeout).
The cassette is one human-readable JSON file, keys sorted, meant to be committed next to
the tests or runs that use it::

    {"format": "scenemosaic-cassette", "version": 1,
     "models": {"openai:gpt-4o": {"vision": true}},
     "entries": {"<sha256>": {"agent": "support", "output_type": "SupportOutput",
                              "request": {"model": ..., "messages": [...], "schema": {...}, "settings": {...}},
                              "reply": {...validated output as JSON...},
                              "usage": {"requests": 1, "input_tokens": ..., ...}}}}

Every outcome of a request is recorded, so a replayed run takes the same path as the recorded
one: a valid reply (``reply``), a reply that was not JSON or broke the schema (``invalid_reply``
with its ``errors``: the agent repairs it again), and a failure after the transport's retries
(``error``: a time-out, an HTTP error, a context-length refusal; raised again on replay, so the
agent falls back again). The run's own limits (deadline, open circuit) are not the server's
answer and are not recorded.

On a miss in replay mode, :class:`ReplayMissError` names what differs from the nearest
recorded request of the same agent: ``model``, ``messages[i]``, ``schema`` or ``settings``.
"""

from __future__ import annotations

import base64
import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any, Literal

import structlog
from pydantic import ValidationError

from scenemosaic.exceptions import (
    ModelConfigError,
    ModelContextLengthError,
    ModelDeadlineExceeded,
    ModelError,
    ModelHTTPError,
    ModelUnavailableError,
    OutputValidationError,
    ReplayMissError,
)
from scenemosaic.models._base import ImagePart, Message, Model, ModelSettings, OutputT, RequestContext, Usage

__all__ = ["Cassette", "ReplayMode", "ReplayModel", "canonical_request", "request_key"]

log = structlog.get_logger(__name__)

ReplayMode = Literal["off", "record", "replay", "record_missing"]
"""``off``: pass through. ``record``: always ask and (re)store. ``replay``: only the cassette;
a miss is an error. ``record_missing``: the cassette where it has the answer, else ask and store."""

CASSETTE_FORMAT = "scenemosaic-cassette"
CASSETTE_VERSION = 1


def _canonical_message(message: Message) -> dict[str, Any]:
    parts: list[dict[str, Any]] = []
    for part in message.parts:
        if isinstance(part, ImagePart):
            parts.append({"image_sha256": hashlib.sha256(part.png).hexdigest(), "label": part.label})
        else:
            parts.append({"text": part.text})
    return {"role": message.role, "parts": parts}


def canonical_request(
    model: str, messages: list[Message], output_type: type[Any], settings: ModelSettings | None
) -> dict[str, Any]:
    """The parts of a request that decide its answer, as plain JSON data."""
    s = settings or ModelSettings()
    return {
        "model": model,
        "messages": [_canonical_message(m) for m in messages],
        "schema": output_type.model_json_schema(),
        "settings": {"temperature": s.temperature, "max_tokens": s.max_tokens, "seed": s.seed},
    }


def _usage_of(exc: BaseException) -> dict[str, Any]:
    """What a failed request still cost, as recorded (some failures carry a ``usage``)."""
    usage = getattr(exc, "usage", None)
    return dataclasses.asdict(usage) if isinstance(usage, Usage) else {}


def _error_record(exc: ModelError) -> dict[str, Any]:
    """A model failure as cassette data (:func:`_recorded_error` turns it back)."""
    record: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, ModelHTTPError):
        record.update(status_code=exc.status_code, body=exc.body[:2000])
    if isinstance(exc, ModelContextLengthError):
        record.update(prompt_tokens=exc.prompt_tokens, context_tokens=exc.context_tokens, sent=exc.sent)
    return record


def _recorded_error(record: dict[str, Any]) -> ModelError:
    """The failure a cassette recorded, raised again the way the live model raised it."""
    kind = record.get("type")
    message = str(record.get("message", "recorded model failure"))
    err: ModelError
    if kind == "ModelContextLengthError":
        err = ModelContextLengthError(
            message,
            status_code=int(record.get("status_code", 400)),
            body=str(record.get("body", "")),
            prompt_tokens=record.get("prompt_tokens"),
            context_tokens=record.get("context_tokens"),
            sent=bool(record.get("sent", True)),
        )
    elif kind == "ModelHTTPError":
        err = ModelHTTPError(message, status_code=int(record.get("status_code", 500)), body=str(record.get("body", "")))
    else:
        err = ModelError(message)
    err.args = (message,)  # the message as recorded, without a second "HTTP <status>:" prefix
    return err


def _dumps(value: Any) -> str:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


def request_key(canonical: dict[str, Any]) -> str:
    """SHA-256 hex digest of a canonical request (see :func:`canonical_request`)."""
    return hashlib.sha256(_dumps(canonical).encode("utf-8")).hexdigest()


def _differences(recorded: dict[str, Any], wanted: dict[str, Any]) -> list[str]:
    diff: list[str] = []
    if recorded.get("model") != wanted["model"]:
        diff.append("model")
    old_msgs, new_msgs = recorded.get("messages", []), wanted.get("messages", [])
    for i in range(max(len(old_msgs), len(new_msgs))):
        if i >= len(old_msgs) or i >= len(new_msgs) or _dumps(old_msgs[i]) != _dumps(new_msgs[i]):
            diff.append(f"messages[{i}]")
    for part in ("schema", "settings", "images"):
        if _dumps(recorded.get(part)) != _dumps(wanted.get(part)):
            diff.append(part)
    return diff


def _first_change(old: str, new: str, width: int = 40) -> str:
    i = next((k for k, (a, b) in enumerate(zip(old, new, strict=False)) if a != b), min(len(old), len(new)))
    lo = max(0, i - 10)
    return f"at char {i}: recorded {old[lo : i + width]!r}, now {new[lo : i + width]!r}"


class Cassette:
    """The recorded requests and replies in one JSON file; loaded lazily, written atomically."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._entries: dict[str, dict[str, Any]] | None = None
        self._models: dict[str, dict[str, Any]] = {}

    def _load(self) -> dict[str, dict[str, Any]]:
        if self._entries is None:
            if self.path.exists():
                try:
                    data = json.loads(self.path.read_text(encoding="utf-8"))
                except (OSError, ValueError) as exc:
                    raise ModelConfigError(f"cassette {self.path} cannot be read: {exc}") from exc
                if not isinstance(data, dict) or data.get("format") != CASSETTE_FORMAT:
                    raise ModelConfigError(f"{self.path} is not a scenemosaic cassette (no format marker)")
                self._entries = dict(data.get("entries", {}))
                self._models = dict(data.get("models", {}))
            else:
                self._entries = {}
        return self._entries

    @property
    def entries(self) -> dict[str, dict[str, Any]]:
        """Recorded entries by request key."""
        return self._load()

    @property
    def models(self) -> dict[str, dict[str, Any]]:
        """Per recorded model name: its properties at recording time (``vision``)."""
        self._load()
        return self._models

    def get(self, key: str) -> dict[str, Any] | None:
        """The entry recorded for ``key``, if any."""
        return self._load().get(key)

    def put(self, key: str, entry: dict[str, Any], *, model: str, vision: bool) -> None:
        """Store ``entry`` under ``key`` and write the file."""
        self._load()[key] = entry
        self._models[model] = {"vision": vision}
        self.save()

    def save(self) -> None:
        """Write the cassette atomically (a temporary file in the same folder, then a rename)."""
        data = {
            "format": CASSETTE_FORMAT,
            "version": CASSETTE_VERSION,
            "models": self._models,
            "entries": self._load(),
        }
        from scenemosaic.scene import write_atomic  # the one atomic write

        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(self.path, json.dumps(data, indent=1, sort_keys=True, ensure_ascii=False) + "\n")

    def miss_error(self, agent: str | None, wanted: dict[str, Any]) -> ReplayMissError:
        """The error for a request with no entry: what differs from the nearest recording."""
        entries = self._load()
        if not entries:
            where = "is empty" if self.path.exists() else "does not exist"
            return ReplayMissError(
                f"no recorded reply for agent {agent!r}: cassette {self.path} {where}", differing=["agent"]
            )
        same_agent = [e for e in entries.values() if e.get("agent") == agent]
        if not same_agent:
            agents = sorted({str(e.get("agent")) for e in entries.values()})
            return ReplayMissError(
                f"no recorded reply for agent {agent!r} in cassette {self.path} (it has: {', '.join(agents)})",
                differing=["agent"],
            )
        best, nearest = min(
            ((_differences(e["request"], wanted), e) for e in same_agent), key=lambda d: len(d[0])
        )
        detail = ""
        for item in best:
            if item.startswith("messages["):
                i = int(item[len("messages[") : -1])
                old = nearest["request"]["messages"]
                if i < len(old) and i < len(wanted["messages"]):
                    detail = f"; {item} {_first_change(_dumps(old[i]), _dumps(wanted['messages'][i]))}"
                else:
                    detail = f"; {item} exists in only one of them"
                break
        return ReplayMissError(
            f"no recorded reply for agent {agent!r} in cassette {self.path}; the nearest recorded request "
            f"differs in {', '.join(best)}{detail}",
            differing=best,
        )


class ReplayModel(Model):
    """Answers from a cassette, records into it, or both, depending on ``mode``.

    ``wrapped`` is the model that really answers (needed in every mode but ``replay``).
    Without it, the name and ``vision`` come from ``name``/``vision`` or, when the
    cassette holds exactly one model, from the cassette. Replayed calls report the usage
    recorded with them, so usage totals of a replayed run match the recorded run.
    """

    def __init__(
        self,
        wrapped: Model | None,
        cassette: str | Path | Cassette,
        mode: ReplayMode = "replay",
        *,
        name: str | None = None,
        vision: bool | None = None,
    ) -> None:
        if mode not in ("off", "record", "replay", "record_missing"):
            raise ModelConfigError(f"replay mode must be off, record, replay or record_missing, not {mode!r}")
        if wrapped is None and mode != "replay":
            raise ModelConfigError(f"replay mode {mode!r} needs a model to ask")
        self.wrapped = wrapped
        self.cassette = cassette if isinstance(cassette, Cassette) else Cassette(cassette)
        self.mode: ReplayMode = mode
        self._name = name
        self._vision = vision

    def __repr__(self) -> str:
        return f"ReplayModel({self.wrapped!r}, {str(self.cassette.path)!r}, mode={self.mode!r})"

    @property
    def name(self) -> str:
        """The wrapped model's name, else the given one, else the cassette's only model."""
        if self.wrapped is not None:
            return self.wrapped.name
        if self._name is not None:
            return self._name
        names = sorted(self.cassette.models)
        if len(names) == 1:
            return names[0]
        raise ModelConfigError(
            f"cassette {self.cassette.path} holds {len(names)} models ({', '.join(names) or 'none'}); "
            "name the one to replay (replay:<path>=<model spec>)"
        )

    @name.setter
    def name(self, value: str) -> None:
        self._name = value

    @property
    def vision(self) -> bool:
        """The wrapped model's ``vision``, else the given one, else as recorded."""
        if self.wrapped is not None:
            return self.wrapped.vision
        if self._vision is not None:
            return self._vision
        try:
            return bool(self.cassette.models.get(self.name, {}).get("vision", False))
        except ModelConfigError:
            return False

    @vision.setter
    def vision(self, value: bool) -> None:
        self._vision = value

    @property
    def uses_rule_solvers(self) -> bool:  # type: ignore[override]
        """The wrapped model's value (a cassette alone never holds rule answers)."""
        return self.wrapped.uses_rule_solvers if self.wrapped is not None else False

    @property
    def default_timeout_s(self) -> float | None:
        """The wrapped model's own time-out (none for a cassette alone)."""
        return self.wrapped.default_timeout_s if self.wrapped is not None else None

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Replay, record or pass through according to ``mode``."""
        if self.mode == "off":
            assert self.wrapped is not None
            return await self.wrapped.request(messages, output_type, settings, context=context)
        agent = context.agent if context else None
        canonical = canonical_request(self.name, messages, output_type, settings)
        key = request_key(canonical)
        if self.mode in ("replay", "record_missing"):
            entry = self.cassette.get(key)
            if entry is not None:
                if "error" in entry:  # a recorded failure (time-out, HTTP error): the agent meets it again
                    raise _recorded_error(entry["error"])
                if "invalid_reply" in entry:  # a recorded bad reply: the agent repairs it as before
                    raise OutputValidationError(
                        f"recorded reply for agent {agent!r} is not a valid {output_type.__name__}",
                        raw_reply=str(entry["invalid_reply"]),
                        errors=[str(e) for e in entry.get("errors", [])],
                        usage=Usage(**entry.get("usage", {})),
                    )
                return self._replayed(entry, output_type, agent), Usage(**entry.get("usage", {}))
            if self.mode == "replay":
                raise self.cassette.miss_error(agent, canonical)
        assert self.wrapped is not None
        try:
            output, usage = await self.wrapped.request(messages, output_type, settings, context=context)
        except OutputValidationError as exc:  # recorded too, so a replayed run repairs the same way
            self.cassette.put(
                key,
                {
                    "agent": agent,
                    "output_type": output_type.__name__,
                    "request": canonical,
                    "invalid_reply": exc.raw_reply,
                    "errors": exc.errors,
                    "usage": dataclasses.asdict(exc.usage) if isinstance(exc.usage, Usage) else {},
                },
                model=self.name,
                vision=self.vision,
            )
            raise
        except (ModelDeadlineExceeded, ModelUnavailableError, ReplayMissError):
            raise  # the run's own limits, not the server's answer: nothing to replay
        except ModelError as exc:  # time-outs, HTTP errors after the retries, context refusals
            self.cassette.put(
                key,
                {
                    "agent": agent,
                    "output_type": output_type.__name__,
                    "request": canonical,
                    "error": _error_record(exc),
                    "usage": _usage_of(exc),
                },
                model=self.name,
                vision=self.vision,
            )
            raise
        entry = {
            "agent": agent,
            "output_type": output_type.__name__,
            "request": canonical,
            "reply": output.model_dump(mode="json"),
            "usage": dataclasses.asdict(usage),
        }
        # put() is synchronous, so concurrent requests on one event loop never interleave writes.
        self.cassette.put(key, entry, model=self.name, vision=self.vision)
        log.debug("recorded model reply", model=self.name, agent=agent, key=key[:12])
        return output, usage

    async def generate_image(self, prompt: str, *, size: str = "1024x1024", model: str | None = None) -> tuple[bytes, Usage]:
        """Replay, record or pass through an images request (entry ``agent`` = ``"images"``, the
        PNG stored base64 in ``image_png``)."""
        if self.mode == "off":
            assert self.wrapped is not None
            return await self.wrapped.generate_image(prompt, size=size, model=model)
        canonical = {"model": self.name, "images": {"prompt": prompt, "size": size, "image_model": model}}
        key = request_key(canonical)
        if self.mode in ("replay", "record_missing"):
            entry = self.cassette.get(key)
            if entry is not None:
                if "error" in entry:
                    raise _recorded_error(entry["error"])
                return base64.b64decode(str(entry["image_png"])), Usage(**entry.get("usage", {}))
            if self.mode == "replay":
                raise self.cassette.miss_error("images", canonical)
        assert self.wrapped is not None
        try:
            png, usage = await self.wrapped.generate_image(prompt, size=size, model=model)
        except (ModelDeadlineExceeded, ModelUnavailableError, ReplayMissError):
            raise
        except ModelError as exc:
            entry = {"agent": "images", "request": canonical, "error": _error_record(exc), "usage": _usage_of(exc)}
            self.cassette.put(key, entry, model=self.name, vision=self.vision)
            raise
        entry = {
            "agent": "images",
            "request": canonical,
            "image_png": base64.b64encode(png).decode("ascii"),
            "usage": dataclasses.asdict(usage),
        }
        self.cassette.put(key, entry, model=self.name, vision=self.vision)
        return png, usage

    def _replayed(self, entry: dict[str, Any], output_type: type[OutputT], agent: str | None) -> OutputT:
        try:
            return output_type.model_validate(entry["reply"])
        except ValidationError as exc:
            raise OutputValidationError(
                f"recorded reply for agent {agent!r} in {self.cassette.path} is not a valid {output_type.__name__}",
                raw_reply=_dumps(entry.get("reply")),
                errors=[str(e["msg"]) for e in exc.errors(include_url=False)],
            ) from exc

    async def aclose(self) -> None:
        """Close the wrapped model, if any."""
        if self.wrapped is not None:
            await self.wrapped.aclose()

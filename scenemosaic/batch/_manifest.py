"""The batch manifest: one JSON object a line, each a ``generate`` job.

A line names its ``input`` (relative to the manifest's folder), an optional ``id`` and any of
the :class:`~scenemosaic.pipeline.GenerateConfig` settings that fit in JSON. Every line is
checked (by :class:`ManifestLine`) before any job runs; all bad lines are reported at once,
each with its line number.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from dataclasses import fields
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.pipeline import GenerateConfig

__all__ = [
    "JOB_SETTINGS",
    "BatchJob",
    "ManifestError",
    "ManifestLine",
    "load_manifest",
    "sanitize_id",
]

_RECORDING_SCHEMES = ("record", "record_missing")
_CASSETTE_SCHEMES = ("replay", *_RECORDING_SCHEMES)
_PATH_SETTINGS = ("asset_dir", "priors_dir", "detections")
_MAX_ID_LENGTH = 100


class ManifestError(ImportFormatError):
    """A manifest line is malformed, or the manifest as a whole is unusable.

    ``problems`` holds one message per bad line (``line 3: ...``); ``line`` is the number of the
    first bad line (1-based), ``None`` for a problem of the whole file.
    """

    def __init__(self, message: str, *, path: str, problems: list[str], line: int | None = None) -> None:
        super().__init__(message, path=path)
        self.problems = list(problems)
        self.line = line


class ManifestLine(BaseModel):
    """One manifest line as written: the input, an optional id and the job's settings.

    Unknown keys are refused. The settings carry the meaning of the
    :class:`~scenemosaic.pipeline.GenerateConfig` field of the same name; ``timeout_s`` (not a
    ``GenerateConfig`` field) overrides the batch's per-job time-out for this line.
    """

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)

    input: str = Field(min_length=1)
    id: str | None = None
    timeout_s: float | None = Field(default=None, gt=0)
    # GenerateConfig settings (same names, same defaults)
    format: str = "auto"
    variants: int = Field(default=0, ge=0)
    evolve: bool = True
    evolve_rounds: int = Field(default=8, ge=1)
    save_views: bool = False
    model: str = "rules"
    seed: int = 0
    room: str | None = None
    asset_dir: str | None = None
    vision: bool | None = None
    solver_fallback: bool = True
    request_timeout_s: float | None = Field(default=None, gt=0)
    max_concurrency: int | None = Field(default=None, ge=1)
    requests_per_minute: float | None = Field(default=None, gt=0)
    tokens_per_minute: float | None = Field(default=None, gt=0)
    deadline_s: float | None = Field(default=None, gt=0)
    stabilize: bool = True
    strict: bool = False
    priors_dir: str | None = None
    detections: str | None = None
    segmenter: str = "auto"
    reconstructor: str = "auto"
    hfov_deg: float | None = Field(default=None, ge=5, le=170)

    @model_validator(mode="after")
    def _variants_need_evolve(self) -> ManifestLine:
        if self.variants > 0 and not self.evolve:
            raise ValueError("variants come from the evolve stage: drop \"evolve\": false, or ask for 0 variants")
        return self


JOB_SETTINGS: tuple[str, ...] = tuple(
    name for name in ManifestLine.model_fields if name not in ("input", "id", "timeout_s")
)
"""The manifest keys that map onto :class:`~scenemosaic.pipeline.GenerateConfig` fields.

The other ``GenerateConfig`` fields are the batch's business (``overwrite``, ``resume``,
``cache_dir``, ``reply_cache``, ``rate_limit_dir``) or cannot be written in JSON (``agents``)."""

_unknown_settings = set(JOB_SETTINGS) - {f.name for f in fields(GenerateConfig)}
if _unknown_settings:  # pragma: no cover - a guard for maintainers
    raise ImportError(f"ManifestLine settings that GenerateConfig lacks: {sorted(_unknown_settings)}")


class BatchJob(BaseModel):
    """One job of a batch, as the manifest defines it, with its paths made absolute.

    ``settings`` holds the ``GenerateConfig`` keyword arguments the line gives or defaults
    (JSON values; folders as absolute path strings). ``line`` is the manifest line (1-based).
    """

    model_config = ConfigDict(frozen=True)

    id: str
    line: int
    input: Path
    settings: dict[str, Any]
    timeout_s: float | None = None

    def config(
        self, *, cache_dir: Path | None = None, reply_cache: Path | None = None, rate_limit_dir: Path | None = None
    ) -> GenerateConfig:
        """The job's :class:`~scenemosaic.pipeline.GenerateConfig`.

        A batch owns its job folders, so ``overwrite`` is on (a folder whose results came from
        another input or other settings is replaced) and ``resume`` is off (an unfinished job
        starts again).
        """
        kwargs = dict(self.settings)
        for key in _PATH_SETTINGS:
            if kwargs.get(key) is not None:
                kwargs[key] = Path(kwargs[key])
        return GenerateConfig(
            **kwargs, cache_dir=cache_dir, reply_cache=reply_cache, rate_limit_dir=rate_limit_dir, overwrite=True, resume=False
        )

    @property
    def recording_cassette(self) -> Path | None:
        """The cassette this job records into (``record:`` and ``record_missing:`` models)."""
        scheme, sep, rest = str(self.settings.get("model", "")).partition(":")
        if not sep or scheme not in _RECORDING_SCHEMES:
            return None
        return Path(rest.partition("=")[0])


_UNSAFE_ID = re.compile(r"[^A-Za-z0-9._-]+")


def sanitize_id(text: str) -> str:
    """A job id that is safe as one folder name on every platform.

    Runs of characters other than ASCII letters, digits, ``.``, ``_`` and ``-`` become one
    ``_``; leading and trailing ``.``, ``_`` and ``-`` are dropped (no hidden folders, no
    ``..``); the result is cut to 100 characters and is ``job`` when nothing is left.
    """
    cleaned = _UNSAFE_ID.sub("_", text).strip("._-")[:_MAX_ID_LENGTH].rstrip("._-")
    return cleaned or "job"


def _resolve_model(model: str, folder: Path) -> str:
    """Cassette paths in a model string, made absolute against the manifest's folder."""
    scheme, sep, rest = model.partition(":")
    if not sep or scheme not in _CASSETTE_SCHEMES:
        return model
    path, eq, inner = rest.partition("=")
    if not path:
        return model  # parse_model names the problem when the job runs
    resolved = (folder / Path(path).expanduser()).resolve()
    return f"{scheme}:{resolved}{eq}{inner}"


def _describe(error: ValidationError) -> str:
    parts = []
    for item in error.errors():
        loc = ".".join(str(p) for p in item["loc"])
        if item["type"] == "extra_forbidden":
            allowed = ", ".join(sorted(ManifestLine.model_fields))
            parts.append(f"unknown key {loc!r} (allowed: {allowed})")
        elif item["type"] == "missing":
            parts.append(f"{loc!r} is required")
        elif loc:
            parts.append(f"{loc!r}: {item['msg']}")
        else:
            parts.append(str(item["msg"]).removeprefix("Value error, "))
    return "; ".join(parts)


def _parse_line(text: str, folder: Path) -> tuple[ManifestLine, Path]:
    """The validated line and its absolute input path; raises ``ValueError`` with the problem."""
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise ValueError(f"not valid JSON ({exc})") from exc
    if not isinstance(data, dict):
        raise ValueError(f"expected a JSON object, got {type(data).__name__}")
    try:
        line = ManifestLine.model_validate(data)
    except ValidationError as exc:
        raise ValueError(_describe(exc)) from exc
    path = (folder / Path(line.input).expanduser()).resolve()
    if not path.exists():
        raise ValueError(f"input not found: {path}")
    return line, path


def _assign_ids(parsed: list[tuple[int, ManifestLine, Path]], source: str) -> list[str]:
    """Ids for every job: the sanitized ``id`` when given, else the input's stem, numbered when shared."""
    explicit: dict[str, int] = {}
    problems: list[tuple[int, str]] = []
    for number, line, _ in parsed:
        if line.id is None:
            continue
        job_id = sanitize_id(line.id)
        if job_id.lower() in explicit:
            problems.append((number, f"id {job_id!r} is already used on line {explicit[job_id.lower()]}"))
        else:
            explicit[job_id.lower()] = number
    if problems:
        raise _bad_lines(source, problems)
    stems = Counter(sanitize_id(path.stem).lower() for _, line, path in parsed if line.id is None)
    taken = set(explicit)
    ids: list[str] = []
    for _, line, path in parsed:
        if line.id is not None:
            ids.append(sanitize_id(line.id))
            continue
        stem = sanitize_id(path.stem)
        candidate = stem
        if stems[stem.lower()] > 1 or stem.lower() in taken:
            index = 1
            while f"{stem}-{index}".lower() in taken:
                index += 1
            candidate = f"{stem}-{index}"
        taken.add(candidate.lower())
        ids.append(candidate)
    return ids


def _bad_lines(source: str, problems: list[tuple[int, str]]) -> ManifestError:
    """One error for all bad lines, each named by its number."""
    lines = [f"line {number}: {text}" for number, text in problems]
    head = "1 bad line" if len(lines) == 1 else f"{len(lines)} bad lines"
    shown = lines[:20]
    more = [f"... and {len(lines) - len(shown)} more"] if len(lines) > len(shown) else []
    message = f"manifest has {head}:\n  " + "\n  ".join([*shown, *more])
    return ManifestError(message, path=source, problems=lines, line=problems[0][0])


def load_manifest(path: str | Path) -> list[BatchJob]:
    """Read and check a JSONL manifest; returns its jobs in file order.

    Blank lines are skipped. Raises :class:`ManifestError` naming every bad line (not JSON, not
    an object, an unknown key, a wrong type, a missing ``input`` key, an input that does not
    exist, a duplicate ``id``) and when the manifest holds no job. Inputs and cassette paths in
    ``model`` strings (``replay:``, ``record:``, ``record_missing:``) are relative to the
    manifest's folder; they come back absolute (symlinks resolved), so the same manifest gives
    the same paths, and the same ``provenance.source_path`` in the scenes, from any working folder.
    """
    manifest = Path(path).expanduser().resolve()
    source = str(manifest)
    try:
        text = manifest.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ManifestError(f"cannot read the manifest: {exc}", path=source, problems=[str(exc)]) from exc
    folder = manifest.parent
    parsed: list[tuple[int, ManifestLine, Path]] = []
    problems: list[tuple[int, str]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        if not raw.strip():
            continue
        try:
            line, input_path = _parse_line(raw, folder)
        except ValueError as exc:
            problems.append((number, str(exc)))
            continue
        parsed.append((number, line, input_path))
    if problems:
        raise _bad_lines(source, problems)
    if not parsed:
        raise ManifestError("manifest holds no job", path=source, problems=["no job"])
    ids = _assign_ids(parsed, source)
    jobs: list[BatchJob] = []
    for (number, line, input_path), job_id in zip(parsed, ids, strict=True):
        settings = line.model_dump(include=set(JOB_SETTINGS))
        settings["model"] = _resolve_model(line.model, folder)
        for key in _PATH_SETTINGS:
            if settings[key] is not None:
                settings[key] = str((folder / Path(settings[key]).expanduser()).resolve())
        jobs.append(BatchJob(id=job_id, line=number, input=input_path, settings=settings, timeout_s=line.timeout_s))
    return jobs

"""The batch manifest: one JSON object a line, each a ``generate`` job.

A line is a :class:`~scenemosaic.pipeline.GenerateConfig` written as JSON, with the same names
and the same validation (the manifest takes the settings in :data:`JOB_SETTINGS`; those in
:data:`NOT_IN_MANIFEST` are the batch's own business or Python objects, each with the reason),
plus the job's own keys (:data:`LINE_KEYS`): its ``input`` (relative to the manifest's folder;
a line with a ``prompt`` has none), an optional ``id`` and ``timeout_s``. Every line is checked
before any job runs; all bad lines are reported at once, each with its line number.

A dataset of houses (``.jsonl``/``.jsonl.gz``, one house a line: ``exchange.is_dataset``) is a
manifest too: one job a house, named ``<file stem>-<index>``, with the default settings
(:func:`dataset_jobs`); a manifest line names one house of a dataset by its ``index`` setting.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.exchange import dataset_entries, dataset_stem, is_dataset
from scenemosaic.pipeline import SETTINGS, GenerateConfig, SettingsError
from scenemosaic.scene import sanitize_id as scene_sanitize_id

__all__ = [
    "JOB_SETTINGS",
    "LINE_KEYS",
    "NOT_IN_MANIFEST",
    "BatchJob",
    "ManifestError",
    "ManifestLine",
    "dataset_jobs",
    "holds_houses",
    "load_manifest",
    "sanitize_id",
]

_RECORDING_SCHEMES = ("record", "record_missing")
_CASSETTE_SCHEMES = ("replay", *_RECORDING_SCHEMES)
_MAX_ID_LENGTH = 100
_PROMPT_STEM = "prompt"

LINE_KEYS: tuple[str, ...] = ("input", "id", "timeout_s")
"""A manifest line's own keys, which are not ``GenerateConfig`` settings: the input (required
unless the line has a ``prompt``), the job's id and its time-out (instead of the batch's)."""

JOB_SETTINGS: tuple[str, ...] = tuple(name for name, s in SETTINGS.items() if s.no_manifest is None)
"""The ``GenerateConfig`` settings a manifest line takes, by the field's name (every setting
whose :class:`~scenemosaic.pipeline.Setting` has no ``no_manifest`` reason)."""

NOT_IN_MANIFEST: Mapping[str, str] = MappingProxyType(
    {name: s.no_manifest for name, s in SETTINGS.items() if s.no_manifest is not None}
)
"""The ``GenerateConfig`` settings a manifest line deliberately does not take, each with the reason."""

_PATH_SETTINGS = tuple(name for name in JOB_SETTINGS if SETTINGS[name].path)


class ManifestError(ImportFormatError):
    """A manifest line is malformed, or the manifest as a whole is unusable.

    ``problems`` holds one message per bad line (``line 3: ...``); ``line`` is the number of the
    first bad line (1-based), ``None`` for a problem of the whole file.
    """

    def __init__(self, message: str, *, path: str, problems: list[str], line: int | None = None) -> None:
        super().__init__(message, path=path)
        self.problems = list(problems)
        self.line = line


class _OwnKeys(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)

    input: str | None = Field(default=None, min_length=1)
    id: str | None = None
    timeout_s: float | None = Field(default=None, gt=0)


class ManifestLine(BaseModel):
    """One checked manifest line: the job's own keys and its settings.

    ``settings`` is the job's :class:`~scenemosaic.pipeline.GenerateConfig` as the line gives it
    (paths and cassettes already made absolute against the manifest's folder), validated by
    ``GenerateConfig`` itself; ``timeout_s`` overrides the batch's per-job time-out for this line.
    Build one with :meth:`parse`.
    """

    model_config = ConfigDict(frozen=True)

    input: Path | None
    """The input, absolute; ``None`` for a line with a ``prompt``."""
    id: str | None = None
    timeout_s: float | None = None
    settings: GenerateConfig

    @classmethod
    def parse(cls, data: Mapping[str, Any], folder: Path) -> ManifestLine:
        """Check one line's JSON object; raises ``ValueError`` naming every problem of the line.

        Unknown keys and settings a manifest does not take are refused; the settings are
        validated by ``GenerateConfig``; the input must exist.
        """
        problems: list[str] = []
        own: dict[str, Any] = {}
        settings: dict[str, Any] = {}
        allowed = ", ".join(sorted((*LINE_KEYS, *JOB_SETTINGS)))
        for key, value in data.items():
            if key in LINE_KEYS:
                own[key] = value
            elif key in JOB_SETTINGS:
                settings[key] = _relative_to(folder, key, value)
            elif key in NOT_IN_MANIFEST:
                problems.append(f"key {key!r} is not taken in a manifest: {NOT_IN_MANIFEST[key]}")
            else:
                problems.append(f"unknown key {key!r} (allowed: {allowed})")
        keys = _OwnKeys()
        try:
            keys = _OwnKeys.model_validate(own)
        except ValidationError as exc:
            problems.extend(f"{'.'.join(map(str, e['loc']))!r}: {e['msg']}" for e in exc.errors())
        config: GenerateConfig | None = None
        try:
            config = GenerateConfig.model_validate(settings, context={"json_numbers": True})
        except SettingsError as exc:
            problems.extend(exc.describe())
        has_prompt = settings.get("prompt") is not None
        path: Path | None = None
        if "input" not in own and not has_prompt:
            problems.append("'input' is required (or a 'prompt' to draw the room from)")
        elif "input" in own and has_prompt:
            problems.append("give an 'input' or a 'prompt', not both")
        elif keys.input is not None:
            path = (folder / Path(keys.input).expanduser()).resolve()
            if not path.exists():
                problems.append(f"input not found: {path}")
            elif is_dataset(path) and settings.get("index") is None:
                problems.append(f"input {path.name} is a dataset of houses: give the house's 'index' (from 0)")
        if settings.get("index") is not None and (path is None or not is_dataset(path)):
            problems.append("'index' picks a house of a dataset input (.jsonl, .jsonl.gz)")
        if problems or config is None:
            raise ValueError("; ".join(problems))
        return cls(input=path, id=keys.id, timeout_s=keys.timeout_s, settings=config)


def _relative_to(folder: Path, key: str, value: Any) -> Any:
    """A setting's value with its path made absolute against the manifest's folder (paths are
    folder and file settings and the cassette of a ``replay:``/``record:`` model); other values
    as they are, for ``GenerateConfig`` to check."""
    if not isinstance(value, str):
        return value
    if key in _PATH_SETTINGS:
        return str((folder / Path(value).expanduser()).resolve())
    if key == "model":
        return _resolve_model(value, folder)
    return value


def _json_value(value: Any) -> Any:
    return str(value) if isinstance(value, Path) else value


class BatchJob(BaseModel):
    """One job of a batch, as the manifest defines it, with its paths made absolute.

    ``settings`` holds the ``GenerateConfig`` keyword arguments of every setting in
    :data:`JOB_SETTINGS`, as the line gives or defaults them (JSON values; folders and files as
    absolute path strings). ``input`` is ``None`` for a job drawn from a ``prompt``. ``line`` is
    the manifest line (1-based).
    """

    model_config = ConfigDict(frozen=True)

    id: str
    line: int
    input: Path | None
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
        return GenerateConfig(
            **self.settings,
            cache_dir=cache_dir,
            reply_cache=reply_cache,
            rate_limit_dir=rate_limit_dir,
            overwrite=True,
            resume=False,
        )

    @property
    def label(self) -> str:
        """The input's absolute path, or ``prompt: <text>`` for a job drawn from a prompt."""
        return str(self.input) if self.input is not None else f"prompt: {self.settings.get('prompt')}"

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

    Text beyond ASCII first goes through the scene's id sanitization
    (:func:`scenemosaic.scene.sanitize_id`: accents dropped, other scripts replaced and a short
    hash of the text appended, so ``椅子`` and ``桌子`` stay two jobs). Then runs of characters
    other than ASCII letters, digits, ``.``, ``_`` and ``-`` become one ``_``; leading and
    trailing ``.``, ``_`` and ``-`` are dropped (no hidden folders, no ``..``); the result is
    cut to 100 characters and is ``job`` when nothing is left."""
    if not text.isascii():  # other scripts: transliterated, or a hash keeps them apart
        text = scene_sanitize_id(text, fallback="job")
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


def _parse_line(text: str, folder: Path) -> ManifestLine:
    """The checked line; raises ``ValueError`` naming its problems."""
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise ValueError(f"not valid JSON ({exc})") from exc
    if not isinstance(data, dict):
        raise ValueError(f"expected a JSON object, got {type(data).__name__}")
    return ManifestLine.parse(data, folder)


def _stem(line: ManifestLine) -> str:
    if line.input is None:
        return _PROMPT_STEM
    if line.settings.index is not None:
        return sanitize_id(f"{dataset_stem(line.input)}-{line.settings.index}")
    return sanitize_id(line.input.stem)


def _assign_ids(parsed: list[tuple[int, ManifestLine]], source: str) -> list[str]:
    """Ids for every job: the sanitized ``id`` when given, else the input's stem (``prompt`` for a
    line with a prompt), numbered when shared."""
    explicit: dict[str, int] = {}
    problems: list[tuple[int, str]] = []
    for number, line in parsed:
        if line.id is None:
            continue
        job_id = sanitize_id(line.id)
        if job_id.lower() in explicit:
            problems.append((number, f"id {job_id!r} is already used on line {explicit[job_id.lower()]}"))
        else:
            explicit[job_id.lower()] = number
    if problems:
        raise _bad_lines(source, problems)
    stems = Counter(_stem(line).lower() for _, line in parsed if line.id is None)
    taken = set(explicit)
    ids: list[str] = []
    for _, line in parsed:
        if line.id is not None:
            ids.append(sanitize_id(line.id))
            continue
        stem = _stem(line)
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


def holds_houses(path: str | Path) -> bool:
    """Whether ``path`` is a dataset of houses rather than a manifest of jobs: a ``.jsonl`` or
    ``.jsonl.gz`` file whose first line is a house (a JSON object with ``rooms``, and neither
    ``input`` nor ``prompt``; only that line is read)."""
    p = Path(path).expanduser()
    if not is_dataset(p) or not p.is_file():
        return False
    try:
        first = next(dataset_entries(p), None)
    except ImportFormatError:
        return p.name.lower().endswith(".gz")  # a manifest is plain text; load_manifest names the damage
    if first is None:
        return False
    try:
        data = json.loads(first.text)
    except ValueError:
        return False
    return isinstance(data, dict) and "rooms" in data and "input" not in data and "prompt" not in data


def dataset_jobs(path: str | Path, index: slice | None = None) -> list[BatchJob]:
    """One job a house of the dataset ``path`` (``index``: those of that range of indices, a
    :class:`slice` of non-negative bounds), each ``<file stem>-<index>`` with the default settings
    (a manifest line ``{"input": FILE, "index": N, ...}`` gives one house other settings). The
    file is streamed and no house is parsed: a job holds its index, and its run reads its line."""
    dataset = Path(path).expanduser().resolve()
    start, stop = (index.start or 0, index.stop) if index is not None else (0, None)
    if start < 0 or (stop is not None and stop < start) or (index is not None and index.step not in (None, 1)):
        raise UsageError(f"index {start}:{stop if stop is not None else ''}: a range of house indices counts up from 0")
    stem = dataset_stem(dataset)
    defaults = GenerateConfig()
    jobs: list[BatchJob] = []
    seen = 0
    for entry in dataset_entries(dataset):
        seen += 1
        if entry.index < start:
            continue
        if stop is not None and entry.index >= stop:
            break
        settings = {name: _json_value(getattr(defaults, name)) for name in JOB_SETTINGS}
        settings["index"] = entry.index
        jobs.append(BatchJob(id=sanitize_id(f"{stem}-{entry.index}"), line=entry.line, input=dataset, settings=settings))
    if not jobs:
        raise ManifestError(
            f"the dataset holds {seen} houses; none in the range asked for", path=str(dataset), problems=["no job"]
        )
    return jobs


def load_manifest(path: str | Path, index: slice | None = None) -> list[BatchJob]:
    """Read and check a JSONL manifest; returns its jobs in file order.

    Blank lines are skipped. Raises :class:`ManifestError` naming every bad line (not JSON, not
    an object, an unknown key or one a manifest does not take, a setting ``GenerateConfig``
    refuses, neither ``input`` nor ``prompt`` or both, an input that does not exist, a duplicate
    ``id``) and when the manifest holds no job. Inputs, folder and file settings and cassette
    paths in ``model`` strings (``replay:``, ``record:``, ``record_missing:``) are relative to the
    manifest's folder; they come back absolute (symlinks resolved), so the same manifest gives
    the same paths, and the same ``provenance.source_path`` in the scenes, from any working folder.
    A dataset of houses (:func:`holds_houses`) gives :func:`dataset_jobs` (``index``: a range of its
    houses); ``index`` on a manifest of jobs raises :class:`~scenemosaic.exceptions.UsageError`.
    """
    if holds_houses(path):
        return dataset_jobs(path, index)
    if index is not None:
        raise UsageError(f"an index range picks houses of a dataset (.jsonl, .jsonl.gz of houses); {path} is a manifest of jobs")
    manifest = Path(path).expanduser().resolve()
    source = str(manifest)
    try:
        text = manifest.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ManifestError(f"cannot read the manifest: {exc}", path=source, problems=[str(exc)]) from exc
    folder = manifest.parent
    parsed: list[tuple[int, ManifestLine]] = []
    problems: list[tuple[int, str]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        if not raw.strip():
            continue
        try:
            line = _parse_line(raw, folder)
        except ValueError as exc:
            problems.append((number, str(exc)))
            continue
        parsed.append((number, line))
    if problems:
        raise _bad_lines(source, problems)
    if not parsed:
        raise ManifestError("manifest holds no job", path=source, problems=["no job"])
    ids = _assign_ids(parsed, source)
    jobs: list[BatchJob] = []
    for (number, line), job_id in zip(parsed, ids, strict=True):
        settings = {name: _json_value(getattr(line.settings, name)) for name in JOB_SETTINGS}
        jobs.append(BatchJob(id=job_id, line=number, input=line.input, settings=settings, timeout_s=line.timeout_s))
    return jobs

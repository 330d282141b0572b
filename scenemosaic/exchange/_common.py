"""Shared pieces of the importers: JSON reading, field checks that name the field, the checks of
the scene limits and of file references in the file's own terms."""

from __future__ import annotations

import gzip
import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from pydantic import ValidationError

from scenemosaic.exceptions import ImportFormatError, UnsafePathError
from scenemosaic.scene import SceneObject, confined_path, object_count_problem

__all__ = ["POSES_FILE", "FieldReader", "normalize_label", "read_json"]

POSES_FILE = "poses.json"
"""Name of the pose file inside a SAM3D object folder (here, not in ``_sam3d``, so that the
format registry names it without importing that reader)."""

_LABEL_RE = re.compile(r"^[a-z][a-z0-9_]{0,47}$")


def read_json(path: Path) -> Any:
    """Parse a JSON file (gzip-compressed when its name ends ``.gz``, as Objaverse's annotation
    files ship); unreadable, non-UTF-8 or malformed text raises ``ImportFormatError`` naming it."""
    try:
        if path.name.lower().endswith(".gz"):
            text = gzip.decompress(path.read_bytes()).decode("utf-8")
        else:
            text = path.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise ImportFormatError("file not found", path=str(path)) from exc
    except UnicodeDecodeError as exc:
        raise ImportFormatError(f"not UTF-8 text ({exc.reason})", path=str(path)) from exc
    except (OSError, EOFError) as exc:  # gzip: BadGzipFile is an OSError, a cut-off file an EOFError
        raise ImportFormatError(f"cannot read: {getattr(exc, 'strerror', None) or exc}", path=str(path)) from exc
    return parse_json(text, path)


def parse_json(text: str, path: Path) -> Any:
    """Parse JSON text read from ``path``: malformed text, nesting deeper than Python can follow
    and numbers too long to convert raise ``ImportFormatError`` naming the file."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ImportFormatError(
            f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", path=str(path)
        ) from exc
    except RecursionError as exc:
        raise ImportFormatError("the JSON is nested too deeply to read", path=str(path)) from exc
    except ValueError as exc:  # an integer literal beyond the interpreter's digit limit
        raise ImportFormatError(f"the JSON holds a number too long to read ({exc})", path=str(path)) from exc


class FieldReader:
    """Typed access to parsed JSON whose every failure is an ``ImportFormatError`` naming file and field.

    Field names are written the way a reader finds them in the file, e.g.
    ``ThreedFront.<model>[3].size`` or ``objects[2].position``.
    """

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, field: str, message: str) -> NoReturn:
        """Raise the ``ImportFormatError`` for ``field``."""
        raise ImportFormatError(message, path=str(self.path), field=field or None)

    def mapping(self, value: Any, field: str) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            self.fail(field, f"expected a JSON object, got {_kind(value)}")
        return value

    def array(self, value: Any, field: str) -> list[Any]:
        if not isinstance(value, list):
            self.fail(field, f"expected a JSON array, got {_kind(value)}")
        return value

    def get(self, obj: Mapping[str, Any], key: str, field: str) -> Any:
        """``obj[key]``; a missing key names ``field.key``."""
        if key not in obj:
            self.fail(_join(field, key), "missing required field")
        return obj[key]

    def text(self, value: Any, field: str) -> str:
        if not isinstance(value, str):
            self.fail(field, f"expected a string, got {_kind(value)}")
        return value

    def number(self, value: Any, field: str) -> float:
        """A finite number (booleans are refused)."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(field, f"expected a number, got {_kind(value)}")
        try:
            out = float(value)
        except OverflowError:  # an integer of hundreds of digits: past any float
            digits = int(int(value).bit_length() * math.log10(2))
            self.fail(field, f"must be finite, got an integer of about {digits} digits")
        if not math.isfinite(out):
            self.fail(field, f"must be finite, got {value!r}")
        return out

    def vector(self, value: Any, length: int, field: str) -> tuple[float, ...]:
        """A list of ``length`` finite numbers."""
        items = self.array(value, field)
        if len(items) != length:
            self.fail(field, f"expected {length} numbers, got {len(items)}")
        return tuple(self.number(v, f"{field}[{i}]") for i, v in enumerate(items))

    def xyz(self, value: Any, field: str, keys: Iterable[str] = ("x", "y", "z")) -> tuple[float, ...]:
        """A ``{"x": .., "y": .., "z": ..}`` object of finite numbers."""
        obj = self.mapping(value, field)
        return tuple(self.number(self.get(obj, k, field), _join(field, k)) for k in keys)

    def check(self, problem: str | None, field: str, *, what: str = "") -> None:
        """Fail on ``field`` (of ``what``, e.g. ``object 'chair_1'``) when a limit check
        (``scenemosaic.scene.size_problem``...) found a problem."""
        if problem is not None:
            self.fail(field, f"{what}: {problem}" if what else problem)

    def objects(self, value: Any, field: str) -> list[Any]:
        """A JSON array of objects, at most ``MAX_OBJECTS`` long (checked before any is read)."""
        items = self.array(value, field)
        self.check(object_count_problem(len(items)), field)
        return items

    def file(self, base: Path, uri: str, field: str, *, roots: Sequence[Path] = (), what: str = "") -> Path:
        """The file ``uri`` names, resolved, when it lies inside ``base`` or ``roots``
        (:func:`scenemosaic.scene.confined_path`); otherwise an error naming ``field`` (and
        ``what``: the object it belongs to)."""
        try:
            return confined_path(base, uri, roots=roots)
        except UnsafePathError as exc:
            prefix = f"{what}: " if what else ""
            raise ImportFormatError(f"{prefix}{exc}", path=str(self.path), field=field) from exc

    def scene_object(self, field: str, what: str, **fields: Any) -> SceneObject:
        """``SceneObject(**fields)``; a value the scene model refuses fails on ``field`` naming ``what``.

        The readers check the usual problems in their own terms first; this catches the rest
        (a size beyond the limits that only appears once a mesh is measured, say).
        """
        try:
            return SceneObject(**fields)
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(p) for p in err["loc"])
            detail = str(err["msg"]).removeprefix("Value error, ")
            if detail.startswith(f"{what}: "):  # the model's own message already names the object
                detail = detail[len(what) + 2 :]
            self.fail(field, f"{what}: {where + ': ' if where else ''}{detail}")

    def label(self, value: Any, field: str) -> str:
        """A category label, normalized (see :func:`normalize_label`)."""
        raw = self.text(value, field)
        label = normalize_label(raw)
        if label is None:
            self.fail(field, f"label {raw!r} is not a category name (letters, digits, spaces, '_' or '-')")
        return label


def normalize_label(raw: str) -> str | None:
    """``"Dining Chair"`` -> ``"dining_chair"``; ``None`` when the text is not a usable category name."""
    label = re.sub(r"[\s\-]+", "_", raw.strip().lower())
    return label if _LABEL_RE.match(label) else None


def _join(field: str, key: str) -> str:
    return f"{field}.{key}" if field else key


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value[:40]!r}"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, Mapping):
        return "an object"
    return type(value).__name__

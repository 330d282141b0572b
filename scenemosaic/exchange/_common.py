"""Shared pieces of the importers: JSON reading, field checks that name the field, id helpers."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, NoReturn

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.scene import CEILING, FLOOR

__all__ = ["FieldReader", "normalize_label", "read_json", "sanitize_id", "unique_id"]

_LABEL_RE = re.compile(r"^[a-z][a-z0-9_]{0,47}$")
_ID_BAD_CHARS = re.compile(r"[^A-Za-z0-9_.\-]+")
_MAX_ID = 64


def read_json(path: Path) -> Any:
    """Parse a JSON file; unreadable, non-UTF-8 or malformed text raises ``ImportFormatError`` naming it."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise ImportFormatError("file not found", path=str(path)) from exc
    except UnicodeDecodeError as exc:
        raise ImportFormatError(f"not UTF-8 text ({exc.reason})", path=str(path)) from exc
    except OSError as exc:
        raise ImportFormatError(f"cannot read: {exc.strerror}", path=str(path)) from exc
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ImportFormatError(
            f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", path=str(path)
        ) from exc


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
        out = float(value)
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


def sanitize_id(raw: str) -> str:
    """Map any text to the object-id alphabet (``[A-Za-z0-9_.-]``, at most 64 characters)."""
    cleaned = _ID_BAD_CHARS.sub("_", raw).strip("_")
    return (cleaned or "object")[:_MAX_ID]


def unique_id(candidate: str, taken: set[str]) -> str:
    """``candidate`` or ``candidate_2``, ``_3``...: the first one not in ``taken`` nor an anchor id; adds it."""
    reserved = {FLOOR, CEILING}
    out = candidate
    n = 2
    while out in taken or out in reserved or re.fullmatch(r"wall_\d+", out):
        suffix = f"_{n}"
        out = candidate[: _MAX_ID - len(suffix)] + suffix
        n += 1
    taken.add(out)
    return out


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

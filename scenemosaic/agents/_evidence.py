"""Evidence as prompt text: compact tables and a legend of what each field means.

A small model's context is the scarce resource, so the evidence a model reads is written
once, tersely: a list of records becomes a table (the column names once, one row per record,
``|`` between values), numbers lose trailing zeros and are rounded to 1 cm (plenty for structuring decisions; a
millimetre digit costs a token per number on tokenizers that split digits), empty values are
left blank, and fields marked ``prompt=False`` (``Field(json_schema_extra={"prompt": False})``,
e.g. a footprint that follows from centre, size and heading) stay out of the text; rule solvers
read the evidence objects, never this text. The legend lists each field's description once.
"""

from __future__ import annotations

import json
from typing import Any

from pydantic import BaseModel

__all__ = ["NESTED_ROWS_NOTE", "TABLE_NOTE", "evidence_legend", "evidence_text"]

TABLE_NOTE = (
    "Evidence format: a list of records is a table: its column names once, then one record per "
    "line with the values in that order, separated by '|'; a blank value is empty (none); a pair "
    "or triple of numbers is written x,y or x,y,z; a list of pairs x,y;x,y. Lengths are metres, "
    "angles degrees."
)
"""How to read :func:`evidence_text`, said once in each system prompt."""
NESTED_ROWS_NOTE = (
    "A column written name(a,b,c) holds a list of records in each row: the records separated by ';', "
    "each one's values a,b,c separated by ','."
)
"""How to read the records nested in a table's cells (``evidence_text(..., nested_rows=True)``);
said in the system prompt of an agent that uses them."""

def _in_prompt(model: type[BaseModel], field: str) -> bool:
    extra = model.model_fields[field].json_schema_extra
    return not (isinstance(extra, dict) and extra.get("prompt") is False)


def _shown(cls: type[BaseModel], field: str, omit: frozenset[str], extra: frozenset[str]) -> bool:
    return (_in_prompt(cls, field) or field in extra) and field not in omit


def _plain(value: Any, digits: int, omit: frozenset[str], extra: frozenset[str] = frozenset()) -> Any:
    """Prompt data: models as dicts of their shown fields (``None`` dropped), floats rounded."""
    if isinstance(value, BaseModel):
        cls = type(value)
        return {
            k: _plain(v, digits, omit, extra)
            for k, v in ((k, getattr(value, k)) for k in cls.model_fields if _shown(cls, k, omit, extra))
            if v is not None
        }
    if isinstance(value, dict):
        return {str(k): _plain(v, digits, omit, extra) for k, v in value.items() if v is not None}
    if isinstance(value, list | tuple):
        return [_plain(v, digits, omit, extra) for v in value]
    if isinstance(value, float):
        r = round(value, digits)
        return int(r) if r.is_integer() else r
    return value


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
            return ",".join(str(v) for v in value)
        if all(isinstance(v, list) for v in value):
            return ";".join(_cell(v) for v in value)
        return ",".join(_cell(v) for v in value)
    if isinstance(value, dict):
        return json.dumps(value, separators=(",", ":"), sort_keys=True)
    return str(value).replace("|", "/").replace("\n", " ")


def _records(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _table(name: str, rows: list[dict[str, Any]], nested_rows: bool = False) -> str:
    columns: list[str] = []
    for row in rows:
        columns += [k for k in row if k not in columns]
    inner: dict[str, list[str]] = {}  # a column of lists of records: its records' own columns
    if nested_rows:
        for c in columns:
            cells = [row[c] for row in rows if row.get(c) not in (None, [])]
            if cells and all(_records(v) for v in cells):
                inner[c] = []
                for record in (r for v in cells for r in v):
                    inner[c] += [k for k in record if k not in inner[c]]
    header = [f"{c}({','.join(inner[c])})" if c in inner else c for c in columns]
    lines = [f"{name} ({len(rows)}; columns {'|'.join(header)}):"]
    for row in rows:
        cells = []
        for c in columns:
            if c in inner:
                records = row.get(c) or []
                cells.append(";".join(",".join(_cell(r.get(k)) for k in inner[c]) for r in records))
            else:
                cells.append(_cell(row.get(c)))
        lines.append("|".join(cells))
    return "\n".join(lines)


def _block(name: str, value: Any, nested_rows: bool = False) -> str:
    if _records(value):
        return _table(name, value, nested_rows)
    if isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()):
        parts = [_block(f"{name}.{k}", v, nested_rows) for k, v in value.items()]
        return "\n".join(parts)
    return f"{name}: {json.dumps(value, separators=(',', ':'), sort_keys=True)}"


def evidence_text(
    evidence: BaseModel,
    *,
    digits: int = 2,
    omit: frozenset[str] = frozenset(),
    extra: frozenset[str] = frozenset(),
    nested_rows: bool = False,
) -> str:
    """The evidence as compact text: one block per field, tables for lists of records, numbers
    rounded to ``digits`` decimals (2: 1 cm); fields named in ``omit`` are left out of every
    record, fields named in ``extra`` shown even when marked ``prompt=False``. With
    ``nested_rows``, a table column holding lists of records is written as rows of its own
    (:data:`NESTED_ROWS_NOTE`) instead of JSON objects, which repeat every key in every record."""
    data = _plain(evidence, digits, omit, extra)
    return "\n".join(_block(k, v, nested_rows) for k, v in data.items())


def evidence_legend(
    model: type[BaseModel], omit: frozenset[str] = frozenset(), extra: frozenset[str] = frozenset()
) -> str:
    """One line per described field of ``model`` and the models it nests, each field once
    (the fields :func:`evidence_text` shows with the same ``omit`` and ``extra``)."""
    lines: list[str] = []
    seen: set[str] = set()
    visited: set[type[BaseModel]] = set()

    def walk(cls: type[BaseModel]) -> None:
        if cls in visited:
            return
        visited.add(cls)
        for name, info in cls.model_fields.items():
            if not _shown(cls, name, omit, extra):
                continue
            if info.description and name not in seen:
                seen.add(name)
                lines.append(f"- {name}: {info.description}")
            for sub in _models_in(info.annotation):
                walk(sub)

    walk(model)
    return "Fields:\n" + "\n".join(lines) if lines else ""


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """Pydantic model classes inside a field annotation (``list[X]``, ``X | None``, ``dict[str, X]``)."""
    out: list[type[BaseModel]] = []
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    for arg in getattr(annotation, "__args__", ()) or ():
        out += _models_in(arg)
    return out

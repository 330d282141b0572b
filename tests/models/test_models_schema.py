"""strict_json_schema (closed, bounded schemas) and extract_json (JSON in prose)."""

from __future__ import annotations

from typing import Any, Literal

import pytest
from pydantic import BaseModel, Field

from scenemosaic.models import SchemaBounds, extract_json, strict_json_schema


class Pose2D(BaseModel):
    u: float
    v: float
    rotation_degrees: float = 0.0


class Placement(BaseModel):
    object_id: str = Field(max_length=40)
    kind: Literal["attach", "contain"]
    center: Pose2D
    tags: list[str] = Field(default_factory=list, max_length=5)


class Plan(BaseModel):
    reasoning: str
    placements: list[Placement]
    scores: dict[str, float] = {}
    note: str | None = None


def _walk(node: Any) -> list[dict[str, Any]]:
    found: list[dict[str, Any]] = []
    if isinstance(node, dict):
        found.append(node)
        for value in node.values():
            found.extend(_walk(value))
    elif isinstance(node, list):
        for value in node:
            found.extend(_walk(value))
    return found


def test_every_record_is_closed_and_fully_required() -> None:
    schema = strict_json_schema(Plan)
    records = [n for n in _walk(schema) if "properties" in n]
    assert len(records) == 3  # Plan, Placement, Pose2D
    for record in records:
        assert record["additionalProperties"] is False
        assert sorted(record["required"]) == sorted(record["properties"])
    assert not any("default" in n for n in _walk(schema))
    # A dict field keeps its value schema: closing it would forbid every key.
    assert schema["properties"]["scores"]["additionalProperties"] == {"type": "number"}


def test_unbounded_arrays_and_strings_get_bounds_existing_ones_are_kept() -> None:
    schema = strict_json_schema(Plan, SchemaBounds(max_items=12, max_length=300))
    placement = schema["$defs"]["Placement"]["properties"]
    assert schema["properties"]["placements"]["maxItems"] == 12
    assert schema["properties"]["reasoning"]["maxLength"] == 300
    assert placement["object_id"]["maxLength"] == 40
    assert placement["tags"]["maxItems"] == 5
    assert placement["tags"]["items"]["maxLength"] == 300
    assert "maxLength" not in placement["kind"]  # an enum bounds itself
    note_string = next(s for s in schema["properties"]["note"]["anyOf"] if s.get("type") == "string")
    assert note_string["maxLength"] == 300
    # The pydantic model itself is untouched.
    assert "maxItems" not in Plan.model_json_schema()["properties"]["placements"]


@pytest.mark.parametrize(
    "text",
    [
        '{"a": 1}',
        '  \n{"a": 1}\n',
        'Sure:\n```json\n{"a": 1}\n```',
        '```\n{"a": 1}\n```',
        'The answer is {"a": 1} as requested.',
        'Thinking {not json} ... final: {"a": 1}',
    ],
)
def test_extract_json_finds_the_object(text: str) -> None:
    assert extract_json(text) == {"a": 1}


def test_extract_json_rejects_text_without_json() -> None:
    with pytest.raises(ValueError, match="not JSON"):
        extract_json("The layout looks fine to me.")
    with pytest.raises(ValueError):
        extract_json('{"should_modify": true, "notes": ["a')

"""strict_json_schema (closed, bounded schemas) and extract_json (JSON in prose)."""

from __future__ import annotations

import time
from typing import Any, Literal

import pytest
from pydantic import BaseModel, Field, ValidationError

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


def test_unbounded_arrays_get_bounds_existing_ones_are_kept_and_string_bounds_are_left_to_pydantic() -> None:
    schema = strict_json_schema(Plan, SchemaBounds(max_items=12))
    placement = schema["$defs"]["Placement"]["properties"]
    assert schema["properties"]["placements"]["maxItems"] == 12
    assert placement["tags"]["maxItems"] == 5
    # OpenAI's strict subset has no string length keywords: none is sent, pydantic still checks.
    assert not any("maxLength" in n or "minLength" in n for n in _walk(schema))
    with pytest.raises(ValidationError):
        Placement.model_validate(
            {"object_id": "x" * 41, "kind": "attach", "center": {"u": 0, "v": 0}, "tags": []}
        )
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


# -- the strict subset, on every built-in agent's output ------------------------------------

# Keywords OpenAI documents for strict structured outputs (types, anyOf, $defs/$ref, number
# bounds, minItems/maxItems), plus the annotations title and description. Written out here
# rather than imported, so the test checks the module instead of repeating it.
OPENAI_STRICT = {
    "type", "properties", "required", "additionalProperties", "items", "anyOf", "enum", "const",
    "$defs", "$ref", "title", "description",
    "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "multipleOf", "minItems", "maxItems",
}  # fmt: skip


def _schemas(node: Any, where: str = "#") -> list[tuple[str, dict[str, Any]]]:
    """Every sub-schema with its path: keyword positions only, never property names."""
    if not isinstance(node, dict):
        return []
    found = [(where, node)]
    for key in ("properties", "$defs"):
        for name, sub in node.get(key, {}).items():
            found.extend(_schemas(sub, f"{where}/{key}/{name}"))
    for key in ("items", "additionalProperties"):
        found.extend(_schemas(node.get(key), f"{where}/{key}"))
    for i, sub in enumerate(node.get("anyOf", [])):
        found.extend(_schemas(sub, f"{where}/anyOf/{i}"))
    return found


def _agent_output_types() -> list[Any]:
    from scenemosaic.structure import DEFAULT_AGENTS, ManagerAgent

    types = [agent.output_type for agent in DEFAULT_AGENTS] + [ManagerAgent.output_type]
    return [pytest.param(t, id=t.__name__) for t in types]


@pytest.mark.parametrize("output_type", _agent_output_types())
def test_every_built_in_agent_schema_is_in_the_strict_subset(output_type: type[BaseModel]) -> None:
    schema = strict_json_schema(output_type)
    assert schema["type"] == "object" and "anyOf" not in schema  # the root is a plain object
    for where, node in _schemas(schema):
        unknown = set(node) - OPENAI_STRICT
        assert not unknown, f"{output_type.__name__} {where}: {sorted(unknown)}"
        if "$ref" in node:
            assert set(node) == {"$ref"}, f"{where}: a $ref with siblings"
        if node.get("type") == "object" or "properties" in node:
            assert node["additionalProperties"] is False, f"{where}: open object"
            assert node["required"] == list(node["properties"]), f"{where}: not every property required"
        if node.get("type") == "array":
            assert isinstance(node["items"], dict) and node["maxItems"] >= node.get("minItems", 0), where


def test_a_fixed_length_tuple_becomes_a_bounded_array() -> None:
    class Shape(BaseModel):
        point: tuple[float, float]
        mixed: tuple[int, str, int]
        tail: tuple[float, ...]

    props = strict_json_schema(Shape)["properties"]
    assert props["point"] == {
        "type": "array",
        "title": "Point",
        "items": {"type": "number"},
        "minItems": 2,
        "maxItems": 2,
    }
    assert props["mixed"]["items"] == {"anyOf": [{"type": "integer"}, {"type": "string"}]}
    assert (props["mixed"]["minItems"], props["mixed"]["maxItems"]) == (3, 3)
    assert props["tail"]["maxItems"] == 64 and "prefixItems" not in props["tail"]
    # Client-side, pydantic still holds the tuple to its shape.
    with pytest.raises(ValidationError):
        Shape.model_validate({"point": [1.0, 2.0, 3.0], "mixed": [1, "a", 2], "tail": []})


def test_string_constraints_are_dropped_and_still_enforced_by_pydantic() -> None:
    class Named(BaseModel):
        id: str = Field(pattern=r"^[a-z_]+\d*$", min_length=2, max_length=10)
        when: str = Field(json_schema_extra={"format": "date-time"})
        tags: set[str] = Field(default_factory=set)

    schema = strict_json_schema(Named)
    assert schema["properties"]["id"] == {"type": "string", "title": "Id"}
    assert "format" not in schema["properties"]["when"]
    assert "uniqueItems" not in schema["properties"]["tags"]
    with pytest.raises(ValidationError):
        Named.model_validate({"id": "Bad-Id", "when": "now"})


def test_a_described_reference_is_inlined_since_strict_refs_stand_alone() -> None:
    class Inner(BaseModel):
        x: int

    class Outer(BaseModel):
        inner: Inner = Field(description="the inner part")

    schema = strict_json_schema(Outer)
    inner = schema["properties"]["inner"]
    assert "$ref" not in inner and inner["description"] == "the inner part"
    assert (
        inner["properties"] == {"x": {"type": "integer", "title": "X"}}
        and inner["additionalProperties"] is False
    )


# -- extract_json stays linear ---------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "{" * 2_000_000,
        "[" * 2_000_000,
        '{"a":' * 400_000,
        "```" * 700_000,
        '{"' * 1_000_000,
        "{x}" * 700_000,
        'x{"a\\' * 400_000,
    ],
    ids=["braces", "brackets", "nested-keys", "fences", "open-strings", "many-small-spans", "escapes"],
)
def test_extract_json_refuses_pathological_replies_quickly(text: str) -> None:
    # A regression guard with a generous bound (the precise figures: benchmarks/models.py).
    started = time.perf_counter()
    with pytest.raises(ValueError, match="not JSON"):
        extract_json(text)
    assert time.perf_counter() - started < 10.0


def test_extract_json_finds_an_object_after_many_broken_ones() -> None:
    text = "{oops} " * 10 + 'final answer: {"a": {"b": "}{"}, "c": "\\"{"}'
    assert extract_json(text) == {"a": {"b": "}{"}, "c": '"{'}


def test_extract_json_takes_an_inner_object_when_the_outer_one_is_broken() -> None:
    assert extract_json('{"wrapper": oops, "answer": {"a": 1}}') == {"a": 1}


def test_extract_json_handles_an_inline_fence_and_a_fence_without_a_tag() -> None:
    assert extract_json('```{"a": 1}```') == {"a": 1}
    assert extract_json('text\n```jsonc\n{"a": 1}\n```') == {"a": 1}
    assert extract_json("```\n[1, 2]\n```") == [1, 2]

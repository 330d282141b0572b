"""Output schemas on the wire and JSON in replies.

Two jobs, both about the contract between a pydantic output type and a server:

* :func:`strict_json_schema` turns ``output_type.model_json_schema()`` into a schema a
  constrained decoder can follow safely: every object closed (``additionalProperties:
  false``) with every property required, and every array and string given an upper
  bound. Unbounded arrays are how a grammar-constrained small model loops until
  ``max_tokens``; a bound makes the grammar itself finish.
* :func:`extract_json` finds the JSON object in a reply that is not pure JSON (prose
  around it, Markdown code fences), for servers without structured output.
"""

from __future__ import annotations

import copy
import json
import re
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel

__all__ = ["SchemaBounds", "extract_json", "strict_json_schema"]

# Keywords strict decoders (OpenAI structured outputs, llama.cpp grammars) reject or ignore;
# the pydantic model still validates them after the reply arrives.
_DROPPED_KEYWORDS = ("default", "discriminator", "examples")


@dataclass(frozen=True)
class SchemaBounds:
    """Upper bounds added where the pydantic model leaves arrays or strings unbounded."""

    max_items: int = 64
    """``maxItems`` for arrays without one. 64 covers every list an agent returns for one room."""
    max_length: int = 1000
    """``maxLength`` for strings without one (characters). Enough for a paragraph of reasoning."""


def strict_json_schema(output_type: type[BaseModel], bounds: SchemaBounds | None = None) -> dict[str, Any]:
    """The JSON schema of ``output_type``, made strict-compatible and bounded.

    Objects get ``additionalProperties: false`` and list all their properties as
    required (strict structured output demands it; a field with a default simply has
    to be written out). ``oneOf`` becomes ``anyOf``; ``default``, ``discriminator`` and
    ``examples`` are dropped. Bounds the model already sets are kept; missing ones come
    from ``bounds``. The pydantic model is untouched: replies are validated against it.
    """
    limits = bounds or SchemaBounds()
    schema = copy.deepcopy(output_type.model_json_schema())
    return _tighten(schema, limits)  # type: ignore[no-any-return]


def _tighten(node: Any, limits: SchemaBounds) -> Any:
    if isinstance(node, list):
        return [_tighten(item, limits) for item in node]
    if not isinstance(node, dict):
        return node
    out: dict[str, Any] = {}
    for key, value in node.items():
        if key in _DROPPED_KEYWORDS:
            continue
        if key in ("properties", "$defs", "definitions", "patternProperties"):
            out[key] = {name: _tighten(sub, limits) for name, sub in value.items()}
        elif key == "oneOf":
            out["anyOf"] = _tighten(value, limits)
        else:
            out[key] = _tighten(value, limits)
    kinds = out.get("type")
    kind_set = set(kinds) if isinstance(kinds, list) else {kinds}
    if "object" in kind_set or "properties" in out:
        props = out.get("properties", {})
        out["required"] = list(props)
        # A dict[str, X] field (schema object with additionalProperties: X) cannot be
        # closed without losing its meaning; only closed records are made strict.
        if not isinstance(out.get("additionalProperties"), dict):
            out["additionalProperties"] = False
    if "array" in kind_set and "maxItems" not in out:
        out["maxItems"] = limits.max_items
    if "string" in kind_set and "maxLength" not in out and "enum" not in out and "const" not in out:
        out["maxLength"] = limits.max_length
    return out


_FENCE = re.compile(r"```(?:json|JSON)?\s*\n?(.*?)```", re.DOTALL)


def extract_json(text: str) -> Any:
    """The JSON value in a model reply.

    Tries, in order: the whole text; the contents of each Markdown code fence; the first
    balanced ``{...}`` object found anywhere in the text. Raises ``ValueError`` (with the
    parser's complaint) when none of these parses.
    """
    stripped = text.strip()
    try:
        return json.loads(stripped)
    except json.JSONDecodeError as exc:
        first_error = exc
    for block in _FENCE.findall(stripped):
        try:
            return json.loads(block.strip())
        except json.JSONDecodeError:
            continue
    decoder = json.JSONDecoder()
    start = stripped.find("{")
    while start != -1:
        try:
            value, _ = decoder.raw_decode(stripped, start)
            return value
        except json.JSONDecodeError:
            start = stripped.find("{", start + 1)
    raise ValueError(
        f"reply is not JSON ({first_error.msg} at char {first_error.pos}) and holds no JSON object"
    )

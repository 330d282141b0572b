"""Output schemas on the wire and JSON in replies.

Two jobs, both about the contract between a pydantic output type and a server:

* :func:`strict_json_schema` turns ``output_type.model_json_schema()`` into a schema in the
  subset OpenAI documents for strict structured outputs (which llama.cpp and vLLM also
  follow): every object closed (``additionalProperties: false``) with every property
  required, only the keywords of :data:`STRICT_SCHEMA_KEYWORDS`, and every array given an
  upper bound. Unbounded arrays are how a grammar-constrained small model loops until
  ``max_tokens``; a bound makes the grammar itself finish.
* :func:`extract_json` finds the JSON object in a reply that is not pure JSON (prose
  around it, Markdown code fences), for servers without structured output. It runs in
  time linear in the reply's length, whatever the reply holds.
"""

from __future__ import annotations

import copy
import json
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel

__all__ = ["STRICT_SCHEMA_KEYWORDS", "SchemaBounds", "extract_json", "strict_json_schema"]

STRICT_SCHEMA_KEYWORDS = frozenset(
    {
        # structure
        "type", "properties", "required", "additionalProperties", "items", "anyOf", "enum", "const",
        "$defs", "$ref",
        # annotations (they guide the model; a decoder ignores them)
        "title", "description",
        # numbers
        "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "multipleOf",
        # arrays
        "minItems", "maxItems",
    }
)  # fmt: skip
"""Every keyword :func:`strict_json_schema` may emit: OpenAI's documented subset for strict
structured outputs (supported types, ``anyOf``, ``$defs``/``$ref``, the number keywords,
``minItems``/``maxItems``), without its string keywords (``pattern``, ``format``; see
:func:`strict_json_schema`). ``minLength``/``maxLength``, ``prefixItems``, ``uniqueItems``,
``allOf``, ``not``, ``default`` and the like are not in it."""


@dataclass(frozen=True)
class SchemaBounds:
    """Upper bounds added where the pydantic model leaves arrays unbounded."""

    max_items: int = 64
    """``maxItems`` for arrays without one. 64 covers every list an agent returns for one room."""


def strict_json_schema(output_type: type[BaseModel], bounds: SchemaBounds | None = None) -> dict[str, Any]:
    """The JSON schema of ``output_type`` in the strict structured-output subset, arrays bounded.

    * Objects get ``additionalProperties: false`` and list all their properties as
      required (strict mode demands it; a field with a default simply has to be written out).
    * ``oneOf`` becomes ``anyOf``; a ``$ref`` with sibling keywords is replaced by the
      definition it points to (strict mode wants a bare ``$ref``).
    * A fixed-length tuple (``prefixItems``) becomes an array of its item type (an ``anyOf``
      of the distinct item types) with ``minItems`` = ``maxItems`` = its length.
    * Arrays without ``maxItems`` get ``bounds.max_items`` (64).
    * Every keyword outside :data:`STRICT_SCHEMA_KEYWORDS` is dropped. That includes the
      string keywords ``minLength``, ``maxLength``, ``pattern`` and ``format``: OpenAI does
      not support the length keywords, a pydantic ``pattern`` is a Python regular expression
      whose syntax servers read differently, and fine-tuned OpenAI models refuse
      ``pattern`` and ``format`` altogether. Strings are bounded by ``max_tokens`` instead.

    Dropping a keyword only lets the decoder produce more than the pydantic model accepts;
    the reply is still validated against the untouched pydantic model, so every dropped
    constraint is enforced client-side (and a violation is sent back for repair).
    """
    limits = bounds or SchemaBounds()
    schema = copy.deepcopy(output_type.model_json_schema())
    defs = schema.get("$defs", {})
    return _tighten(schema, limits, defs if isinstance(defs, dict) else {})  # type: ignore[no-any-return]


def _tighten(node: Any, limits: SchemaBounds, defs: dict[str, Any]) -> Any:
    if isinstance(node, list):
        return [_tighten(item, limits, defs) for item in node]
    if not isinstance(node, dict):
        return node
    node = _inline_ref(node, defs)
    if "oneOf" in node and "anyOf" not in node:
        node = {("anyOf" if k == "oneOf" else k): v for k, v in node.items()}
    if isinstance(node.get("allOf"), list) and len(node["allOf"]) == 1:
        # Older pydantic wraps a described reference as allOf: [ {$ref} ]; one element merges.
        node = {**_inline_ref(node["allOf"][0], defs), **{k: v for k, v in node.items() if k != "allOf"}}
    if isinstance(node.get("prefixItems"), list):
        node = _tuple_as_array(node)
    out: dict[str, Any] = {}
    for key, value in node.items():
        if key not in STRICT_SCHEMA_KEYWORDS:
            continue
        if key in ("properties", "$defs"):
            out[key] = {name: _tighten(sub, limits, defs) for name, sub in value.items()}
        elif key in ("enum", "const", "required", "type", "title", "description"):
            out[key] = value  # values, not schemas
        else:
            out[key] = _tighten(value, limits, defs)
    kinds = out.get("type")
    kind_set = set(kinds) if isinstance(kinds, list) else {kinds}
    if "object" in kind_set or "properties" in out:
        out["required"] = list(out.get("properties", {}))
        # A dict[str, X] field (an object whose additionalProperties is a schema) cannot be
        # closed without losing its meaning; strict mode has no form for it, so it stays open.
        if not isinstance(out.get("additionalProperties"), dict):
            out["additionalProperties"] = False
    if "array" in kind_set and "maxItems" not in out:
        out["maxItems"] = max(limits.max_items, int(out.get("minItems", 0)))
    return out


def _inline_ref(node: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    """A ``$ref`` with sibling keywords, replaced by its definition (the siblings win)."""
    ref = node.get("$ref")
    if not isinstance(ref, str) or len(node) == 1 or not ref.startswith("#/$defs/"):
        return node
    target = defs.get(ref[len("#/$defs/") :])
    if not isinstance(target, dict):
        return node
    return {**target, **{k: v for k, v in node.items() if k != "$ref"}}


def _tuple_as_array(node: dict[str, Any]) -> dict[str, Any]:
    """``prefixItems: [A, B]`` as ``items: A`` (or ``anyOf: [A, B]``) with both length bounds."""
    slots: list[Any] = node["prefixItems"]
    distinct: list[Any] = []
    for slot in slots:
        if slot not in distinct:
            distinct.append(slot)
    if isinstance(node.get("items"), dict) and node["items"] not in distinct:
        distinct.append(node["items"])  # tuple[A, *tuple[B, ...]]: the open tail's type
        open_tail = True
    else:
        open_tail = False
    out = {k: v for k, v in node.items() if k not in ("prefixItems", "items")}
    out["items"] = distinct[0] if len(distinct) == 1 else {"anyOf": distinct}
    out.setdefault("minItems", len(slots))
    if not open_tail:
        out.setdefault("maxItems", len(slots))
    return out


# -- JSON in a reply -----------------------------------------------------------------------

MAX_JSON_CANDIDATES = 64
"""How many fenced blocks and ``{...}`` spans :func:`extract_json` tries before giving up."""

_FENCE = "```"
_OBJECT_TOKENS = re.compile(r'[{}"\\]')


def extract_json(text: str) -> Any:
    """The JSON value in a model reply.

    Tries, in order: the whole text; the contents of each Markdown code fence; each
    balanced ``{...}`` span, outermost and leftmost first (one scan that follows strings and
    escapes finds them all). Each candidate is parsed at most once and at most
    :data:`MAX_JSON_CANDIDATES` of them are tried, so the work is linear in the length of
    the text (a 2 MB reply of ``{`` characters is refused in well under a second). Raises
    ``ValueError`` (with the parser's complaint) when none of these parses.
    """
    stripped = text.strip()
    try:
        return json.loads(stripped)
    except json.JSONDecodeError as exc:
        complaint = f"{exc.msg} at char {exc.pos}"
    except RecursionError:  # "[[[[..." deeper than the parser's recursion limit
        complaint = "nested too deeply"
    tried = 0
    for block in _fenced_blocks(stripped):
        tried += 1
        if tried > MAX_JSON_CANDIDATES:
            break
        value = _loads_or_none(block)
        if value is not None:
            return value
    # Nested spans overlap, so parsing every one could cost the text's length per level of
    # nesting; a budget of a few times the text's length keeps the total linear.
    budget = 4 * len(stripped) + 4096
    for start, end in sorted(_object_spans(stripped))[: max(0, MAX_JSON_CANDIDATES - tried)]:
        budget -= end - start
        if budget < 0:
            break
        value = _loads_or_none(stripped[start:end])
        if value is not None:
            return value
    raise ValueError(f"reply is not JSON ({complaint}) and holds no JSON object")


def _loads_or_none(candidate: str) -> Any:
    """The parsed candidate, or ``None`` when it is not JSON (``null`` itself is no answer either)."""
    try:
        return json.loads(candidate)
    except (json.JSONDecodeError, RecursionError):
        return None


def _fenced_blocks(text: str) -> Iterator[str]:
    """The contents of each fenced block, language tag line removed, in order (one pass)."""
    pos = 0
    while True:
        opening = text.find(_FENCE, pos)
        if opening < 0:
            return
        closing = text.find(_FENCE, opening + len(_FENCE))
        if closing < 0:
            return
        block = text[opening + len(_FENCE) : closing]
        tag, newline, rest = block.partition("\n")
        if newline and (not tag.strip() or tag.strip().isidentifier()):
            block = rest  # "```json\n..." or "```\n...": the first line is only a language tag
        yield block.strip()
        pos = closing + len(_FENCE)


def _object_spans(text: str) -> list[tuple[int, int]]:
    """``(start, end)`` of every balanced ``{...}`` in ``text``, found in one left-to-right scan.

    Braces inside JSON strings do not count; quotes outside any brace are prose and are
    ignored. Only the characters ``{ } " \\`` are visited.
    """
    spans: list[tuple[int, int]] = []
    open_at: list[int] = []
    in_string = False
    skip_to = -1  # the character after a backslash in a string is escaped, whatever it is
    for match in _OBJECT_TOKENS.finditer(text):
        i = match.start()
        char = text[i]
        if not open_at:
            if char == "{":
                open_at.append(i)
            continue
        if in_string:
            if i < skip_to:
                continue
            if char == "\\":
                skip_to = i + 2
            elif char == '"':
                in_string = False
            continue
        if char == '"':
            in_string = True
        elif char == "{":
            open_at.append(i)
        elif char == "}":
            spans.append((open_at.pop(), i + 1))
    return spans

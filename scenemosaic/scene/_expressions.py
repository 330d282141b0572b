"""The pose expression language: exact 2D edits of a unit's layout, evaluated in a sandbox.

One assignment per line::

    chair_0.center.u = table_0.bbox.max_u + chair_0.size.u / 2 + 0.05
    chair_0.rotation_degrees = 90

Targets: ``<id>.center.u``, ``<id>.center.v``, ``<id>.rotation_degrees``. References:
``<id>.center.u|v``, ``<id>.size.u|v``, ``<id>.bbox.min_u|min_v|max_u|max_v``,
``<id>.rotation_degrees`` (``center_2d``, ``size_2d``, ``bbox_2d`` are accepted aliases).
Operators: numbers, ``+ - * /``, unary minus and plus, parentheses, and the functions
``min``, ``max``, ``abs``, ``round``, ``clamp(x, lo, hi)``. Assignments run in order, each
against the layout as the previous ones left it (turning an object updates its size and box).

Nothing is executed: the right-hand side is parsed with :mod:`ast` and walked node by node;
any other node (names, calls of anything else, subscripts, attribute chains off the grammar,
``**``, comparisons, lambdas, strings...) is refused, as are inputs longer than
:data:`MAX_EXPRESSION_CHARS`, nesting deeper than :data:`MAX_NESTING`, literals with more than
:data:`MAX_LITERAL_DIGITS` digits and results beyond :data:`MAX_ABS_VALUE`. A refusal raises
:class:`~scenemosaic.exceptions.ExpressionError` with one message per bad line, written to be
sent back to the model that wrote them.
"""

from __future__ import annotations

import ast
import keyword
import math
import re
import threading
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass

from pydantic import ValidationError

from scenemosaic.exceptions import ExpressionError
from scenemosaic.scene._ids import FLOOR
from scenemosaic.scene._model import LocalUnit, Scene
from scenemosaic.scene._surface import UnitLayout, normalize_degrees
from scenemosaic.scene._tree import rigid_moves

__all__ = [
    "MAX_ABS_VALUE",
    "MAX_EXPRESSIONS",
    "MAX_EXPRESSION_CHARS",
    "MAX_LITERAL_DIGITS",
    "MAX_NESTING",
    "Assignment",
    "apply_expressions",
    "edit_scene",
    "parse_assignment",
    "split_expressions",
]

MAX_EXPRESSION_CHARS = 400
"""Longest accepted assignment, characters."""
MAX_EXPRESSIONS = 64
"""Most assignments in one edit."""
MAX_NESTING = 12
"""Deepest accepted nesting of parentheses and function calls."""
MAX_LITERAL_DIGITS = 12
"""Most digits in one number literal."""
MAX_ABS_VALUE = 1.0e4
"""Largest magnitude of any literal, intermediate or result (metres or degrees)."""

_FIELDS = {"center": "center", "center_2d": "center", "size": "size", "size_2d": "size", "bbox": "bbox", "bbox_2d": "bbox"}
_COMPONENTS = {"center": ("u", "v"), "size": ("u", "v"), "bbox": ("min_u", "min_v", "max_u", "max_v")}
_FUNCTIONS = {"min": (2, 8), "max": (2, 8), "abs": (1, 1), "round": (1, 2), "clamp": (3, 3)}
_GRAMMAR = (
    "write one assignment per line, like `a.center.u = b.bbox.max_u + a.size.u / 2 + 0.05` or "
    "`a.rotation_degrees = 90`, using only numbers, <id>.center.u|v, <id>.size.u|v, "
    "<id>.bbox.min_u|min_v|max_u|max_v, <id>.rotation_degrees, + - * /, parentheses, min, max, abs, round, clamp"
)


@dataclass(frozen=True)
class Assignment:
    """One parsed assignment: the target object and field, and the checked right-hand side."""

    text: str
    object_id: str
    field: str
    """``center.u``, ``center.v`` or ``rotation_degrees``."""
    expression: ast.expr
    aliases: tuple[tuple[str, str], ...]


def split_expressions(text: str | Iterable[str]) -> list[str]:
    """Assignments of a text (one per line or separated by ``;``) or of a list of strings."""
    items = [text] if isinstance(text, str) else list(text)
    out: list[str] = []
    for item in items:
        if not isinstance(item, str):
            raise ExpressionError(f"an expression must be a string, got {type(item).__name__}", problems=[repr(item)[:80]])
        out += [p.strip() for p in re.split(r"[;\n]", item) if p.strip()]
    return out


def _depth(text: str) -> int:
    depth = best = 0
    for ch in text:
        if ch in "([{":
            depth += 1
            best = max(best, depth)
        elif ch in ")]}":
            depth -= 1
    return best


def _aliased(text: str, ids: Sequence[str]) -> tuple[str, dict[str, str]]:
    """Replace ids that are not Python identifiers (``a.b``, ``x-1``) by placeholder names."""
    aliases: dict[str, str] = {}
    odd = sorted((i for i in ids if not i.isidentifier() or keyword.iskeyword(i)), key=len, reverse=True)
    for k, oid in enumerate(odd):
        name = f"id\u00b7{k}"  # a middle dot: valid in a Python name, impossible in an object id
        pattern = re.compile(r"(?<![A-Za-z0-9_.\-])" + re.escape(oid) + r"(?=\.)")
        if pattern.search(text):
            text = pattern.sub(name, text)
            aliases[name] = oid
    return text, aliases


_PARSE_LOCK = threading.Lock()
"""One ``ast.parse`` at a time in the process: CPython 3.11 keeps the depth of the tree it is
turning into Python objects in one counter per interpreter, and two threads parsing at once (a
unit's variants evolve in threads) can fail with ``SystemError: AST constructor recursion depth
mismatch``."""


def parse_assignment(text: str, ids: Sequence[str]) -> Assignment:
    """Parse and check one assignment against the unit's object ids (no evaluation yet)."""
    if len(text) > MAX_EXPRESSION_CHARS:
        raise ExpressionError(f"too long ({len(text)} characters, at most {MAX_EXPRESSION_CHARS})")
    if _depth(text) > MAX_NESTING:
        raise ExpressionError(f"nested too deeply (more than {MAX_NESTING} levels)")
    for run in re.findall(r"\d+", text):
        if len(run) > MAX_LITERAL_DIGITS:
            raise ExpressionError(f"a number with {len(run)} digits (at most {MAX_LITERAL_DIGITS})")
    parts = re.split(r"(?<![=!<>])=(?!=)", text)
    if len(parts) != 2:
        raise ExpressionError(f"not one assignment: {_GRAMMAR}")
    lhs, rhs = parts[0].strip(), parts[1].strip()
    lhs_a, lhs_alias = _aliased(lhs, ids)
    rhs_a, rhs_alias = _aliased(rhs, ids)
    m = re.fullmatch(r"([^\W\d][\w\u00b7]*)\.(?:(center|center_2d)\.(u|v)|(rotation_degrees))", lhs_a)
    if m is None:
        raise ExpressionError(
            f"cannot assign to {lhs[:60]!r}: the target must be <id>.center.u, <id>.center.v or <id>.rotation_degrees"
        )
    target = lhs_alias.get(m.group(1), m.group(1))
    if target not in ids:
        raise ExpressionError(f"unknown object {target!r} (this unit has: {', '.join(ids)})")
    field = f"center.{m.group(3)}" if m.group(3) else "rotation_degrees"
    try:
        with _PARSE_LOCK:
            tree = ast.parse(rhs_a, mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise ExpressionError(f"not an arithmetic expression ({type(exc).__name__}): {_GRAMMAR}") from None
    aliases = {**lhs_alias, **rhs_alias}
    _check(tree.body, set(ids), aliases, 0)
    return Assignment(text, target, field, tree.body, tuple(sorted(aliases.items())))


def _reference(node: ast.Attribute, ids: set[str], aliases: dict[str, str]) -> tuple[str, str, str]:
    """``(object_id, field, component)`` of a reference node, or an error naming what is wrong."""
    chain: list[str] = []
    cur: ast.expr = node
    while isinstance(cur, ast.Attribute):
        chain.append(cur.attr)
        cur = cur.value
    if not isinstance(cur, ast.Name):
        raise ExpressionError("only <id>.<field>.<component> references are allowed")
    chain.reverse()
    oid = aliases.get(cur.id, cur.id)
    if any(part.startswith("__") for part in [cur.id, *chain]):
        raise ExpressionError("names starting with '__' are not allowed")
    if oid not in ids:
        raise ExpressionError(f"unknown object {oid!r} (this unit has: {', '.join(sorted(ids))})")
    if chain == ["rotation_degrees"]:
        return oid, "rotation_degrees", ""
    if len(chain) != 2 or chain[0] not in _FIELDS:
        raise ExpressionError(f"{oid}.{'.'.join(chain)} is not a reference: {_GRAMMAR}")
    fld = _FIELDS[chain[0]]
    if chain[1] not in _COMPONENTS[fld]:
        raise ExpressionError(f"{oid}.{'.'.join(chain)}: {chain[0]} has {', '.join(_COMPONENTS[fld])}")
    return oid, fld, chain[1]


def _check(node: ast.expr, ids: set[str], aliases: dict[str, str], depth: int) -> None:
    if depth > 4 * MAX_NESTING:
        raise ExpressionError(f"nested too deeply (more than {MAX_NESTING} levels)")
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            raise ExpressionError(f"only numbers are allowed as constants, not {type(node.value).__name__}")
        if not math.isfinite(node.value) or abs(node.value) > MAX_ABS_VALUE:
            raise ExpressionError(f"number {node.value!r} out of range (|x| <= {MAX_ABS_VALUE:g})")
        return
    if isinstance(node, ast.Attribute):
        _reference(node, ids, aliases)
        return
    if isinstance(node, ast.BinOp):
        if not isinstance(node.op, ast.Add | ast.Sub | ast.Mult | ast.Div):
            raise ExpressionError(f"operator {type(node.op).__name__} is not allowed (only + - * /)")
        _check(node.left, ids, aliases, depth + 1)
        _check(node.right, ids, aliases, depth + 1)
        return
    if isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, ast.USub | ast.UAdd):
            raise ExpressionError(f"operator {type(node.op).__name__} is not allowed")
        _check(node.operand, ids, aliases, depth + 1)
        return
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in _FUNCTIONS:
            raise ExpressionError(f"only the functions {', '.join(_FUNCTIONS)} may be called")
        if node.keywords:
            raise ExpressionError(f"{node.func.id}() takes no keyword arguments")
        lo, hi = _FUNCTIONS[node.func.id]
        if not lo <= len(node.args) <= hi:
            raise ExpressionError(f"{node.func.id}() takes {lo}{'' if lo == hi else f' to {hi}'} arguments")
        for a in node.args:
            if isinstance(a, ast.Starred):
                raise ExpressionError("* arguments are not allowed")
            _check(a, ids, aliases, depth + 1)
        return
    if isinstance(node, ast.Name):
        raise ExpressionError(f"bare name {node.id[:40]!r} is not allowed: refer to <id>.<field>.<component>")
    raise ExpressionError(f"{type(node).__name__} is not allowed: {_GRAMMAR}")


def _finite(x: float) -> float:
    if not math.isfinite(x) or abs(x) > MAX_ABS_VALUE:
        raise ExpressionError(f"a value went out of range ({x!r}; |x| <= {MAX_ABS_VALUE:g})")
    return x


def _read(layout: UnitLayout, oid: str, fld: str, comp: str) -> float:
    if fld == "rotation_degrees":
        return layout.rotation(oid)
    u, v = layout.center(oid)
    if fld == "center":
        return u if comp == "u" else v
    su, sv = layout.extent(oid)
    if fld == "size":
        return su if comp == "u" else sv
    return {"min_u": u - su / 2, "max_u": u + su / 2, "min_v": v - sv / 2, "max_v": v + sv / 2}[comp]


def _evaluate(node: ast.expr, layout: UnitLayout, aliases: dict[str, str]) -> float:
    if isinstance(node, ast.Constant):
        assert isinstance(node.value, int | float)  # _check refused every other constant
        return float(node.value)
    if isinstance(node, ast.Attribute):
        oid, fld, comp = _reference(node, set(layout.ids), aliases)
        return _read(layout, oid, fld, comp)
    if isinstance(node, ast.UnaryOp):
        x = _evaluate(node.operand, layout, aliases)
        return -x if isinstance(node.op, ast.USub) else x
    if isinstance(node, ast.BinOp):
        a = _evaluate(node.left, layout, aliases)
        b = _evaluate(node.right, layout, aliases)
        if isinstance(node.op, ast.Add):
            return _finite(a + b)
        if isinstance(node.op, ast.Sub):
            return _finite(a - b)
        if isinstance(node.op, ast.Mult):
            return _finite(a * b)
        if abs(b) < 1e-12:
            raise ExpressionError("division by zero")
        return _finite(a / b)
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    args = [_evaluate(a, layout, aliases) for a in node.args]
    name = node.func.id
    if name == "min":
        return min(args)
    if name == "max":
        return max(args)
    if name == "abs":
        return abs(args[0])
    if name == "round":
        digits = 0 if len(args) == 1 else args[1]
        if digits != int(digits) or not 0 <= digits <= 6:
            raise ExpressionError("round(x, n) needs a whole n between 0 and 6")
        return float(round(args[0], int(digits)))
    lo, hi = args[1], args[2]
    if lo > hi:
        raise ExpressionError(f"clamp(x, lo, hi) needs lo <= hi, got {lo:g} > {hi:g}")
    return min(max(args[0], lo), hi)


def apply_expressions(
    layout: UnitLayout,
    expressions: str | Iterable[str],
    *,
    allowed: Collection[str] | None = None,
    frozen_rotation: bool = False,
) -> list[tuple[str, float]]:
    """Apply assignments to ``layout`` in order; returns ``(target, value)`` per assignment.

    ``allowed`` limits which objects may be assigned (the ones a critic's notes name); others
    may still be read. With ``frozen_rotation`` (containment units) rotations are refused.
    Every line is checked before anything changes: when any line is refused, the layout is left
    as it was and :class:`~scenemosaic.exceptions.ExpressionError` lists every problem.
    """
    lines = split_expressions(expressions)
    if len(lines) > MAX_EXPRESSIONS:
        raise ExpressionError(f"too many assignments ({len(lines)}, at most {MAX_EXPRESSIONS})")
    ids = layout.ids
    parsed: list[Assignment] = []
    problems: list[str] = []
    for line in lines:
        try:
            a = parse_assignment(line, ids)
        except ExpressionError as exc:
            problems.append(f"`{line[:120]}`: {exc}")
            continue
        if allowed is not None and a.object_id not in allowed:
            problems.append(f"`{line[:120]}`: {a.object_id} may not change (only {', '.join(sorted(allowed)) or 'nothing'})")
        elif frozen_rotation and a.field == "rotation_degrees":
            problems.append(f"`{line[:120]}`: rotations are frozen in this unit; only centres may change")
        else:
            parsed.append(a)
    if problems:
        raise ExpressionError("refused: " + "; ".join(problems), problems=problems)
    trial = layout.copy()
    results: list[tuple[str, float]] = []
    for a in parsed:
        try:
            value = _finite(_evaluate(a.expression, trial, dict(a.aliases)))
        except ExpressionError as exc:
            problems.append(f"`{a.text[:120]}`: {exc}")
            continue
        if a.field == "rotation_degrees":
            value = normalize_degrees(value)
            trial.set_rotation(a.object_id, value)
        else:
            u, v = trial.center(a.object_id)
            if a.field == "center.u":
                trial.set_center(a.object_id, value, v)
            else:
                trial.set_center(a.object_id, u, value)
        results.append((f"{a.object_id}.{a.field}", value))
    if problems:
        raise ExpressionError("refused: " + "; ".join(problems), problems=problems)
    for oid in ids:  # commit
        layout.set_center(oid, *trial.center(oid))
        if abs(normalize_degrees(trial.rotation(oid) - layout.rotation(oid))) > 1e-9:
            layout.set_rotation(oid, trial.rotation(oid))
    return results


def edit_scene(scene: Scene, expressions: str | Iterable[str], *, unit: LocalUnit | str | None = None) -> Scene:
    """A NEW scene with pose expressions applied to one unit's layout (see :meth:`Scene.edit`)."""
    lines = split_expressions(expressions)
    if not lines:
        raise ExpressionError("no expression to apply")
    if unit is None:
        anchors: set[str] = set()
        for line in lines:
            head = line.split("=", 1)[0].strip()
            oid = next((o.id for o in sorted(scene.objects, key=lambda o: -len(o.id)) if head.startswith(o.id + ".")), None)
            if oid is None:
                raise ExpressionError(f"`{line[:120]}`: the target names no object of this scene")
            rel = scene.support_of(oid)
            anchors.add(rel.parent if rel is not None else FLOOR)
        if len(anchors) != 1:
            raise ExpressionError(f"the targets belong to several units ({', '.join(sorted(anchors))}); pass unit=")
        unit = anchors.pop()
    anchor = unit if isinstance(unit, str) else unit.anchor_id
    try:
        scene.anchor_kind(anchor)
    except KeyError:
        raise ExpressionError(f"unknown unit {anchor!r}") from None
    if not scene.children_of(anchor):
        raise ExpressionError(f"unit {anchor!r} has no children to edit")
    layout = UnitLayout.from_scene(scene, anchor)
    apply_expressions(layout, lines, frozen_rotation=layout.surface.projection == "anchor_front")
    try:
        moved = rigid_moves(scene, layout.poses())
        data = scene.model_dump()
        data["objects"] = [
            {**o.model_dump(), "pose": moved[o.id].model_dump()} if o.id in moved else o.model_dump() for o in scene.objects
        ]
        out = Scene.model_validate(data)
    except ValidationError as exc:  # a value the scene's limits refuse (a position 5 km away)
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        detail = str(first["msg"]).removeprefix("Value error, ")
        raise ExpressionError(f"the edit puts the scene beyond its limits ({where}: {detail})") from None
    out.provenance.steps.append("edit")
    out.provenance.notes.append(f"edit of unit {anchor}: " + "; ".join(lines)[:300])
    return out

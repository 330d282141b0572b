"""Headings from the evidence: which way each floor object of a photograph faces.

A box fit alone tells an object's long axis at best (its projected box is the same turned by a
half turn), and nothing when the picture's border cuts the box. A person reading the picture
also uses the room and what the object belongs to. Each floor object's yaw is chosen from the
room frame's four directions by the sum of these costs (chi-square units, so the box evidence
and the rules weigh against each other):

* **the box**: how well the projected 3D box matches the pixel box with that yaw, the object
  refitted (place and size) with the camera fixed;
* **the wall** (:data:`WALL_WEIGHT`): furniture that stands against a wall (``against_wall``)
  backs onto the room's edge: the side its back faces must be the room's outermost side there
  (no other object, nor the camera's foot, beyond it);
* **what it belongs to** (:data:`BELONGS_WEIGHT`): a chair faces the nearest table or desk
  within reach, a sofa or armchair the television (its stand) or else the coffee table, a
  television stand the sofa, a nightstand faces where its bed faces, and a bed weighs its
  nightstands' own box fits, since they share its axis;
* **the dining group** (:data:`ROW_WEIGHT`): chairs side by side (closer than
  :data:`ROW_SPACING`) stand in a row and face across it; a dining table lies along the rows of
  its chairs; with the table out of view, a row faces the group's middle;
* **the camera** (:data:`CAMERA_WEIGHT`), a weak default: with no other evidence an object
  shows its front.

The reason, the term that decided against the box-only choice (or ``box`` when the box decided
alone), is recorded per object in ``perception.json`` (``headings``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from scenemosaic.scene import FloatArray, normalize_category, traits

__all__ = [
    "BELONGS_WEIGHT",
    "CAMERA_WEIGHT",
    "ROW_WEIGHT",
    "WALL_WEIGHT",
    "HeadingChoice",
    "HeadingItem",
    "bed_nightstands",
    "choose_headings",
    "front_of",
    "furniture_role",
    "half_extent",
    "nearest_item",
]

WALL_WEIGHT = 12.0
"""Cost (chi-square units) per metre by which the side a wall piece's back faces is not the
room's outermost (capped at 2 m): a bed whose head would stand in the middle of the room."""
WALL_GAP = 0.3
"""Metres of room beyond a wall piece's back that still count as backing onto the wall."""
BELONGS_WEIGHT = 16.0
"""Cost (chi-square units) of a chair turned a half turn from its table (half of it for a quarter turn)."""
CAMERA_WEIGHT = 1.0
"""Cost (chi-square units) of showing the camera the back rather than the front: a weak default."""
REACH = 1.5
"""Metres between footprints within which a chair belongs to a table, a nightstand to a bed."""
BOX_TEMPER = 0.25
"""The box fit's cost is multiplied by this before it is weighed against the rules: furniture is
not a box (a chair's back, a bed's headboard), so its misfit is systematic, not noise."""


@dataclass(frozen=True)
class HeadingItem:
    """A floor object to turn: its id, category, floor-frame bottom centre and size (w, d, h)."""

    id: str
    category: str
    centre: FloatArray
    size: FloatArray


@dataclass(frozen=True)
class HeadingChoice:
    """The chosen yaw (radians, floor frame), which of the four directions it is, and why."""

    yaw: float
    quarter: int
    reason: str


def front_of(yaw: float) -> FloatArray:
    """The front (local -Y) of an object turned by ``yaw``, in the floor frame."""
    return np.array([math.sin(yaw), -math.cos(yaw)])


def _aligned(weight: float, direction: FloatArray, yaw: float) -> float:
    """``weight`` for a front turned away from ``direction`` (a unit floor vector), 0 along it."""
    return weight * 0.5 * (1.0 - float(front_of(yaw) @ direction))


def _parallel(weight: float, along: float, yaw: float) -> float:
    """``weight`` for an axis square to the yaw ``along``, 0 along it either way."""
    return weight * 0.5 * (1.0 - math.cos(2.0 * (yaw - along)))


def half_extent(size: FloatArray, yaw: float, direction: FloatArray) -> float:
    """Half the footprint's extent along a unit floor direction."""
    c, s = math.cos(yaw), math.sin(yaw)
    return 0.5 * (abs(float(direction @ np.array([c, s]))) * float(size[0]) + abs(float(direction @ np.array([-s, c]))) * float(size[1]))


def _footprint_gap(a: HeadingItem, b: HeadingItem) -> float:
    """Distance between two footprints, approximated by their circumscribed discs' gap."""
    return float(np.linalg.norm(a.centre[:2] - b.centre[:2]) - 0.5 * (max(a.size[:2]) + max(b.size[:2])) * 0.75)


def _nearest_point(table: HeadingItem, yaw: float, point: FloatArray) -> FloatArray:
    """The point of a table's footprint nearest ``point`` (its middle when inside)."""
    c, s = math.cos(yaw), math.sin(yaw)
    rel = point - table.centre[:2]
    local = np.array([c * rel[0] + s * rel[1], -s * rel[0] + c * rel[1]])
    half = np.asarray(table.size[:2], dtype=np.float64) / 2
    if np.all(np.abs(local) <= half):
        out: FloatArray = table.centre[:2].copy()
        return out
    local = np.clip(local, -half, half)
    near: FloatArray = np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]]) + table.centre[:2]
    return near


def _group_target(points: Sequence[FloatArray], me: FloatArray) -> FloatArray:
    """Where a chair of a dining group faces when its table is out of view: across the group's
    long axis when the chairs stand in two rows, else the group's middle."""
    pts = np.asarray(points, dtype=np.float64)
    middle: FloatArray = pts.mean(axis=0)
    if len(pts) < 3:
        return middle
    evals, evecs = np.linalg.eigh(np.cov((pts - middle).T))
    if evals[1] < 2.0 * max(evals[0], 1e-9):
        return middle
    major = evecs[:, 1]
    along = float((me - middle) @ major)
    out: FloatArray = middle + along * major  # the point of the middle line level with the chair
    return out


ROW_SPACING = 1.0
"""Metres between two chairs' middles under which they stand side by side in one row (a dining
chair is 0.45-0.65 m wide); chairs facing each other across a table stand further apart (the
table's width and a seat's depth, 1.2 m or more)."""
ROW_WEIGHT = 8.0
"""Cost (chi-square units) of a chair turned square to its row, or of a table whose long axis
lies across the rows of its chairs."""


def _row_direction(points: Sequence[FloatArray], room_yaw: float) -> float | None:
    """The direction (radians, floor frame, one of the room's axes) of the rows a dining group's
    chairs stand in: every two chairs closer than :data:`ROW_SPACING` stand side by side, and the
    line through them runs along their row. Their directions are averaged on the doubled angle,
    snapped to the room's nearer axis; ``None`` without such a pair or when they disagree."""
    votes = np.zeros(2)
    total = 0.0
    for a in range(len(points)):
        for b in range(a + 1, len(points)):
            d = np.asarray(points[b][:2] - points[a][:2], dtype=np.float64)
            r = float(np.linalg.norm(d))
            if 1e-6 < r < ROW_SPACING:
                phi = math.atan2(d[1], d[0]) - room_yaw
                votes += [math.cos(2 * phi), math.sin(2 * phi)]
                total += 1.0
    if total == 0.0:
        return None
    # along the room's first axis (+1) or its second (-1): the doubled angle's cosine
    along_first = float(votes[0]) / total
    if abs(along_first) < 0.3:
        return None
    return room_yaw if along_first > 0 else room_yaw + math.pi / 2


REASON_MARGIN = 0.5
"""A term names itself in the reason when it favours the choice over the runner-up by this much."""


def _reason(
    k_best: int, totals: Sequence[float], box: Sequence[float], terms: Sequence[tuple[str, Callable[[float], float]]], yaws: Sequence[float]
) -> str:
    """What made ``k_best`` win over the runner-up: every term (the box included) favouring it by
    at least :data:`REASON_MARGIN`, the strongest first; ``box`` when nothing did."""
    runner = min((k for k in range(4) if k != k_best), key=lambda k: totals[k])
    gains = [(box[runner] - box[k_best], "box")]
    gains += [(f(yaws[runner]) - f(yaws[k_best]), name) for name, f in terms]
    named = [name for gain, name in sorted(gains, key=lambda g: -g[0]) if gain >= REASON_MARGIN]
    return ", ".join(named) if named else "box"


def furniture_role(category: str) -> str:
    """What a category is to the heading rules: ``bed``, ``nightstand``, ``tv`` (a television or
    its stand), ``sofa``, ``armchair``, ``chair``, ``coffee_table``, ``table`` (desks too) or ``other``."""
    c = normalize_category(category)
    t = traits(c)
    if "nightstand" in c or "bedside" in c:
        return "nightstand"
    if "bed" in c and "bedside" not in c:
        return "bed"
    if "tv_stand" in c or c in ("television", "tv"):
        return "tv"
    if t.seat and "sofa" in c:
        return "sofa"
    if c in ("armchair", "lounge_chair"):
        return "armchair"
    if t.seat:
        return "chair"
    if "coffee_table" in c or "tea_table" in c:
        return "coffee_table"
    if t.table or "table" in c or "desk" in c:
        return "table"
    return "other"


def nearest_item(
    items: Sequence[HeadingItem], i: int, roles: Sequence[str], reach: float = REACH
) -> int | None:
    """The index of the item of one of ``roles`` (:func:`furniture_role`) whose footprint comes
    nearest ``items[i]``'s, within ``reach`` metres; ``None`` when none does."""
    best, best_gap = None, reach
    for j, it in enumerate(items):
        if j != i and furniture_role(it.category) in roles:
            gap = _footprint_gap(items[i], it)
            if gap < best_gap:
                best, best_gap = j, gap
    return best


def bed_nightstands(items: Sequence[HeadingItem], bed: int) -> list[int]:
    """The nightstands of the bed ``items[bed]``: those whose footprints come within :data:`REACH`."""
    return [
        j
        for j, it in enumerate(items)
        if furniture_role(it.category) == "nightstand" and _footprint_gap(items[bed], it) < REACH
    ]


def choose_headings(
    items: Sequence[HeadingItem],
    room_yaw: float,
    refit: Callable[[int, int], tuple[float, FloatArray, FloatArray]],
    camera_xy: FloatArray | None = None,
) -> dict[str, HeadingChoice]:
    """The yaw of each floor object (see the module's docstring). ``refit(i, k)``: the box fit
    of object ``i`` turned by ``room_yaw + k * 90`` degrees: its cost (chi-square / 2), bottom
    centre and size; ``camera_xy``: the camera's foot (the floor frame's origin by default)."""
    cam = np.zeros(2) if camera_xy is None else np.asarray(camera_xy, dtype=np.float64)
    roles = [furniture_role(it.category) for it in items]
    yaws_k = [math.remainder(room_yaw + k * math.pi / 2, 2 * math.pi) for k in range(4)]
    chosen: dict[str, HeadingChoice] = {}
    chairs = [j for j, r in enumerate(roles) if r == "chair"]
    rank = {"bed": 0, "table": 0, "tv": 1, "sofa": 2, "armchair": 3, "coffee_table": 4}
    order = sorted(range(len(items)), key=lambda i: rank.get(roles[i], 5))

    def turned(i: int, yaw: float) -> HeadingItem:
        """Object ``i`` where its box puts it when turned by ``yaw``."""
        _cost, centre, size = refit(i, yaws_k.index(yaw))
        return HeadingItem(items[i].id, items[i].category, centre, size)

    def wall_cost(i: int, yaw: float) -> float:
        it = turned(i, yaw)
        back = -front_of(yaw)
        mine = float(it.centre[:2] @ back) + half_extent(it.size, yaw, back)
        beyond = float(cam @ back) + 0.3
        for j, other in enumerate(items):
            if j != i and not (roles[i] == "bed" and roles[j] == "nightstand"):  # they stand by its head, flush with the wall
                other_yaw = chosen[other.id].yaw if other.id in chosen else yaws_k[0]
                beyond = max(beyond, float(other.centre[:2] @ back) + half_extent(other.size, other_yaw, back))
        return WALL_WEIGHT * min(2.0, max(0.0, beyond - mine - WALL_GAP))

    def toward(i: int, target: FloatArray, yaw: float) -> float:
        d = target - turned(i, yaw).centre[:2]
        n = float(np.linalg.norm(d))
        if n < 1e-6:
            return 0.0
        return BELONGS_WEIGHT * 0.5 * (1.0 - float(front_of(yaw) @ (d / n)))

    def nearest(i: int, wanted: Sequence[str], reach: float = REACH) -> int | None:
        return nearest_item(items, i, wanted, reach)

    def toward_table(i: int, table: HeadingItem, yaw: float) -> float:
        return toward(i, _nearest_point(table, chosen[table.id].yaw, items[i].centre[:2]), yaw)

    def flank_cost(i: int, stands: Sequence[int], yaw: float) -> float:
        """How far the nightstands are from the places beside the head of a bed turned by ``yaw``."""
        it = turned(i, yaw)
        back, side = -front_of(yaw), np.array([math.cos(yaw), math.sin(yaw)])
        cost = 0.0
        for j in stands:
            depth = 0.5 * (float(it.size[1]) - float(items[j].size[1]))
            reach = 0.5 * (float(it.size[0]) + float(items[j].size[0]))
            spots = [it.centre[:2] + back * depth + sign * side * reach for sign in (-1.0, 1.0)]
            miss = min(float(np.linalg.norm(items[j].centre[:2] - spot)) for spot in spots)
            cost += BELONGS_WEIGHT * min(1.0, miss / 1.0)
        return cost / len(stands)

    def stands_box(stands: Sequence[int], yaw: float) -> float:
        """The tempered box fit of a bed's nightstands turned the way the bed is turned."""
        k = yaws_k.index(yaw)
        return sum(BOX_TEMPER * refit(j, k)[0] for j in stands)

    for i in order:
        it, role = items[i], roles[i]
        terms: list[tuple[str, Callable[[float], float]]] = []
        if traits(it.category).against_wall:
            terms.append(("backs onto the wall", partial(wall_cost, i)))
        partner: int | None = None
        if role == "chair":
            partner = nearest(i, ("table", "coffee_table"))
        elif role in ("sofa", "armchair"):
            partner = nearest(i, ("tv",), reach=6.0)
            if partner is None:
                partner = nearest(i, ("coffee_table", "table"), reach=REACH)
        elif role == "tv":
            partner = nearest(i, ("sofa", "armchair"), reach=6.0)
        if partner is not None and role == "chair" and items[partner].id in chosen:
            # a chair faces the nearest edge of its table, not the table's middle
            terms.append((f"faces {items[partner].id}", partial(toward_table, i, items[partner])))
        elif partner is not None:
            terms.append((f"faces {items[partner].id}", partial(toward, i, items[partner].centre[:2])))
        group = [j for j in chairs if j != i and _footprint_gap(it, items[j]) < 2.0]
        if role == "chair" and group:
            points = [items[j].centre[:2] for j in [i, *group]]
            rows = _row_direction(points, room_yaw)
            in_row = any(float(np.linalg.norm(p - it.centre[:2])) < ROW_SPACING for p in points[1:])
            if rows is not None and in_row:  # a chair stands in a row of its group, square to it
                terms.append(("in its row", partial(_parallel, ROW_WEIGHT, rows)))
            if partner is None and rows is not None:
                # its table out of view: it faces across its row, toward the group's middle, and
                # the chairs of one row (side by side) face the same way: the row's middle decides
                across = np.array([-math.sin(rows), math.cos(rows)])
                row = [p for p in points if float(np.linalg.norm(p - it.centre[:2])) < ROW_SPACING]
                offset = float((np.mean(points, axis=0) - np.mean(row, axis=0)) @ across)
                if abs(offset) > 0.3:
                    terms.append(("faces its dining group", partial(toward, i, it.centre[:2] + offset * across)))
            elif partner is None:  # chairs round a table out of view face the middle of their group
                middle = _group_target(points, it.centre[:2])
                if float(np.linalg.norm(middle - it.centre[:2])) > 0.3:
                    terms.append(("faces its dining group", partial(toward, i, middle)))
        if role == "table" and "desk" not in normalize_category(it.category):  # its long axis along its chairs' rows
            near = [j for j in chairs if _footprint_gap(it, items[j]) < REACH]
            rows = _row_direction([items[j].centre[:2] for j in near], room_yaw) if len(near) >= 2 else None
            if rows is not None:
                terms.append(("along its chairs", partial(_parallel, ROW_WEIGHT, rows)))
        if role == "bed":  # nightstands stand at the head, one on each side
            stands = bed_nightstands(items, i)
            if stands:
                terms.append((f"{items[stands[0]].id} at its head", partial(flank_cost, i, stands)))
                # a nightstand faces where its bed faces: its own box's evidence counts for the bed
                terms.append((f"{items[stands[0]].id}'s box", partial(stands_box, stands)))
        if role == "coffee_table":  # it lies along the sofa it serves
            sofa = nearest(i, ("sofa",), reach=REACH)
            if sofa is not None and items[sofa].id in chosen:
                terms.append((f"along {items[sofa].id}", partial(_parallel, BELONGS_WEIGHT, chosen[items[sofa].id].yaw)))
        if role == "nightstand":
            bed = nearest(i, ("bed",))
            if bed is not None and items[bed].id in chosen:
                terms.append((f"flanks {items[bed].id}", partial(_aligned, BELONGS_WEIGHT, front_of(chosen[items[bed].id].yaw))))
        to_cam = cam - it.centre[:2]
        to_cam = to_cam / max(float(np.linalg.norm(to_cam)), 1e-6)
        terms.append(("faces the camera", partial(_aligned, CAMERA_WEIGHT, to_cam)))
        box = [BOX_TEMPER * refit(i, k)[0] for k in range(4)]
        totals = [box[k] + sum(f(yaws_k[k]) for _, f in terms) for k in range(4)]
        k_best = int(np.argmin(totals))
        chosen[it.id] = HeadingChoice(yaws_k[k_best], k_best, _reason(k_best, totals, box, terms, yaws_k))
    return chosen

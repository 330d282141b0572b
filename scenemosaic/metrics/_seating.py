"""Seating etiquette, measured: is every chair at a table or desk seated the way a person would
seat it?

This is the judge of the evolution's seating rules, written apart from them on purpose (the
critic in ``scenemosaic.evolve`` places seats; this module only reads a finished scene), so a
figure it reports is not the critic grading itself.

* A seat belongs to the nearest table or desk whose footprint is within ``SEAT_PAIR_M`` of its
  own in the base scene (:func:`seat_pairs`).
* The **side** a seat sits at is the table side its centre lies beyond the furthest; the seat is
  **square** when its front is within ``SEAT_SQUARE_DEG`` of that side's inward normal, and
  **on its side** when its centre projects inside the side's extent (:func:`seat_checks`).
* A table's **long sides are balanced** when their seat counts differ by at most one; a table
  with a wall less than ``AGAINST_WALL_M`` in front of a long side (the strip that deep along the
  side's middle 80 % leaves the floor) is not judged (its seats go elsewhere).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from scenemosaic.scene import Scene, SceneObject, front_vector, traits

__all__ = [
    "AGAINST_WALL_M",
    "SEAT_PAIR_M",
    "SEAT_SQUARE_DEG",
    "SeatCheck",
    "TableBalance",
    "seat_checks",
    "seat_pairs",
    "seating_figures",
    "table_balance",
]

SEAT_SQUARE_DEG = 5.0
"""A seat is square to its side when its front is within this many degrees of the side's normal."""
SEAT_PAIR_M = 0.5
"""A seat belongs to a table or desk whose footprint is within this distance of its own, metres."""
AGAINST_WALL_M = 0.45
"""A table side this close to a wall is against it (no seat expected there), metres."""
_LOUNGE = ("armchair", "sofa", "lounge")


def _is_seat(o: SceneObject) -> bool:
    t = traits(o.category)
    return t.seat and not t.against_wall and not any(k in o.category for k in _LOUNGE)


def _is_table(o: SceneObject) -> bool:
    return traits(o.category).table and "dressing" not in o.category


def seat_pairs(base: Scene) -> dict[str, str]:
    """Seat id -> the table or desk it belongs to, read from the base scene."""
    tables = [o for o in base.objects if _is_table(o)]
    out: dict[str, str] = {}
    for s in base.objects:
        if not _is_seat(s):
            continue
        near = sorted((float(Polygon(s.footprint()).distance(Polygon(t.footprint()))), t.id) for t in tables)
        if near and near[0][0] <= SEAT_PAIR_M:
            out[s.id] = near[0][1]
    return out


@dataclass(frozen=True)
class _Frame:
    centre: np.ndarray
    front: np.ndarray
    lat: np.ndarray
    half_front: float
    half_lat: float

    @classmethod
    def of(cls, table: SceneObject) -> _Frame:
        c = np.asarray(table.pose.position[:2], dtype=np.float64)
        f = front_vector(table.pose.quaternion)[:2]
        f = f / float(np.linalg.norm(f))
        lat = np.array([f[1], -f[0]])
        rel = table.footprint() - c
        return cls(c, f, lat, float(np.ptp(rel @ f)) / 2, float(np.ptp(rel @ lat)) / 2)

    def sides(self) -> dict[str, tuple[np.ndarray, float, float]]:
        """Side name -> (outward normal, half length along it, distance of its edge from the centre)."""
        return {
            "front": (self.front, self.half_lat, self.half_front),
            "back": (-self.front, self.half_lat, self.half_front),
            "right": (self.lat, self.half_front, self.half_lat),
            "left": (-self.lat, self.half_front, self.half_lat),
        }


@dataclass(frozen=True)
class SeatCheck:
    """One seat at its table in one scene."""

    seat: str
    table: str
    side: str
    off_deg: float
    """Angle between the seat's front and the inward normal of its side."""
    on_side: bool

    @property
    def square(self) -> bool:
        return self.off_deg <= SEAT_SQUARE_DEG


def seat_checks(scene: Scene, pairs: Mapping[str, str]) -> list[SeatCheck]:
    """How each paired seat sits at its table in ``scene`` (pairs from :func:`seat_pairs`)."""
    out: list[SeatCheck] = []
    for seat_id, table_id in sorted(pairs.items()):
        try:
            seat, table = scene.get(seat_id), scene.get(table_id)
        except KeyError:
            continue
        fr = _Frame.of(table)
        rel = np.asarray(seat.pose.position[:2], dtype=np.float64) - fr.centre
        name, (normal, half_len, _edge) = max(
            fr.sides().items(), key=lambda kv: float(rel @ kv[1][0]) - kv[1][2]
        )
        along = np.array([normal[1], -normal[0]])
        f = front_vector(seat.pose.quaternion)[:2]
        f = f / float(np.linalg.norm(f))
        off = math.degrees(math.acos(max(-1.0, min(1.0, float(f @ -normal)))))
        out.append(SeatCheck(seat_id, table_id, name, off, abs(float(rel @ along)) <= half_len + 1e-6))
    return out


@dataclass(frozen=True)
class TableBalance:
    """Seats on each side of one table; ``balanced`` is ``None`` when not judged."""

    table: str
    counts: Mapping[str, int]
    balanced: bool | None


def _against_wall(scene: Scene, table: SceneObject, normal: np.ndarray, half_len: float, edge: float) -> bool:
    if scene.room is None:
        return False
    fr_c = np.asarray(table.pose.position[:2], dtype=np.float64)
    mid = fr_c + normal * edge
    along = np.array([normal[1], -normal[0]]) * half_len * 0.8
    out = normal * AGAINST_WALL_M
    strip = Polygon([mid - along, mid + along, mid + along + out, mid - along + out])
    return not Polygon(scene.room.floor).buffer(1e-6).covers(strip)


def table_balance(scene: Scene, checks: list[SeatCheck]) -> list[TableBalance]:
    """Per table: seats per side, and whether its long sides hold them evenly."""
    out: list[TableBalance] = []
    for table_id in sorted({c.table for c in checks}):
        table = scene.get(table_id)
        fr = _Frame.of(table)
        counts = {name: 0 for name in fr.sides()}
        for c in checks:
            if c.table == table_id:
                counts[c.side] += 1
        sides = fr.sides()
        long_pair = ("right", "left") if fr.half_front > fr.half_lat else ("front", "back")
        if "desk" in table.category or any(_against_wall(scene, table, *sides[n]) for n in long_pair):
            out.append(TableBalance(table_id, counts, None))
            continue
        a, b = (counts[n] for n in long_pair)
        out.append(TableBalance(table_id, counts, abs(a - b) <= 1))
    return out


def seating_figures(base: Scene, scenes: list[Scene]) -> dict[str, float | int]:
    """Pooled figures over ``scenes`` (the base and its variants, say), seats paired in ``base``:
    ``seats``, ``seats_square`` and ``seats_on_side`` (fractions of seat placements),
    ``tables`` and ``sides_balanced`` (fraction of judged table placements); 1.0 when empty."""
    pairs = seat_pairs(base)
    checks = [c for s in scenes for c in seat_checks(s, pairs)]
    balances = [b for s in scenes for b in table_balance(s, seat_checks(s, pairs)) if b.balanced is not None]
    n = len(checks)
    return {
        "seats": n,
        "seats_square": round(sum(c.square for c in checks) / n, 4) if n else 1.0,
        "seats_on_side": round(sum(c.on_side for c in checks) / n, 4) if n else 1.0,
        "tables": len(balances),
        "sides_balanced": round(sum(bool(b.balanced) for b in balances) / len(balances), 4) if balances else 1.0,
    }

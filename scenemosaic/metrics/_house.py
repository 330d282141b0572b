"""A whole house's figures: the house-wide checks (:func:`house_checks`) and every metric of a base
house and its variants (:func:`~scenemosaic.metrics.evaluate` of a house), room by room and for the house.

The pipeline's house run reports exactly these (``report.json`` ``validation`` and
``metrics``), and ``scenemosaic evaluate`` prints :func:`~scenemosaic.metrics.evaluate` of a house for a house run, so the
report and the command agree. The checks and their constants: ``docs/houses.md``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from shapely.geometry import Polygon

from scenemosaic.assets import HullCache
from scenemosaic.metrics._metrics import evaluate_scenes, house_diversity, relkeep
from scenemosaic.physics import is_thin
from scenemosaic.scene import (
    FLOOR,
    House,
    Scene,
    door_blockers,
    house_walkable,
    is_fixture,
    normalize_degrees,
    wall_crossings,
    yaw_from_quat,
)

__all__ = ["FURNITURE_M2", "HOUSE_BASE_FIGURES", "MOVED_M", "TURNED_DEG", "furniture", "house_checks", "moved_furniture"]

HOUSE_BASE_FIGURES = ("house_nav", "unreachable_rooms", "door_blockers", "wall_crossings")
"""The keys of :func:`house_checks` that :func:`~scenemosaic.metrics.evaluate` of a house reports for the base house."""


def house_checks(house: House) -> dict[str, Any]:
    """Door clearance, reachability and walls: what only the whole house can say, JSON-ready.

    ``house_nav`` (the largest walkable piece over every floor and doorway, ``house_walkable``),
    ``rooms_reached`` (per room, its share of that piece), ``unreachable_rooms``,
    ``door_blockers`` (``"<object> (<door>)"`` per object in a door's zone), ``wall_crossings``
    (``"<object> (<room>, <depth> m)"`` per object reaching past its room's floor) and
    ``doorways`` (how many doors and open stretches join rooms or lead outside).
    """
    walk = house_walkable(house)
    blockers = door_blockers(house)
    crossings = wall_crossings(house)
    return {
        "house_nav": round(walk.nav, 4),
        "rooms_reached": {k: round(v, 4) for k, v in walk.reached().items()},
        "unreachable_rooms": walk.unreachable_rooms(),
        "door_blockers": [f"{b.object_id} ({b.door})" for b in blockers],
        "wall_crossings": [f"{o} ({r}, {d:.3f} m)" for r, o, d in crossings],
        "doorways": len(house.doorways()),
    }


def _evaluate_house(
    base: House,
    variants: Sequence[House] = (),
    *,
    base_dir: str | Path | None = None,
    variant_dirs: Sequence[str | Path | None] = (),
    hull_cache: HullCache | None = None,
    base_checks: dict[str, Any] | None = None,
    variant_checks: Sequence[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Every metric of a base house and its whole-house variants, JSON-ready.

    ``{"house": {...}, "rooms": {room id: ...}}``:

    * ``rooms``: per room, :func:`~scenemosaic.metrics.evaluate` of the base's room and the same
      room of every variant (COL, OOB, NAV, RelKeep, Div-IoU, Div-N of that room);
    * ``house``: ``base`` (:data:`HOUSE_BASE_FIGURES` of :func:`house_checks`), ``variants`` (per
      variant: ``house_nav``, ``unreachable_rooms``, how many ``door_blockers`` and
      ``wall_crossings``, ``RelKeep``, the smallest over its rooms, 1.0 for a house without
      rooms to compare, ``parts_blocked``, how many drawers, doors and lids of its rooms cannot
      open, ``windows_blocked``, how many windows furniture stands before, and ``screens_behind``, how
      many beds and sofas have a screen behind their backs, as the base's) and, with variants, ``diversity`` (:func:`house_diversity`),
      ``rooms_rearranged`` (rooms with furniture some variant moves: :func:`moved_furniture`) and
      ``rooms_not_rearranged`` (the ids of rooms with furniture no variant moves).

    ``base_dir`` and ``variant_dirs`` (one per variant; default: none) resolve each house's
    relative mesh uris: the delivered ``base/`` and ``variant_<i>/`` folders a house was read
    from, or the input's folder for houses in memory. ``base_checks`` and ``variant_checks`` are
    :func:`house_checks` already measured on these houses (a run's validate and compose stages);
    they are measured here when not given.
    """
    dirs = list(variant_dirs) or [None] * len(variants)
    rooms: dict[str, Any] = {}
    for k, scene in enumerate(base.rooms):
        rooms[scene.id] = evaluate_scenes(
            scene, [v.rooms[k] for v in variants], base_dir=base_dir, variant_dirs=dirs, hull_cache=hull_cache
        )
    base_figures = base_checks if base_checks is not None else house_checks(base)
    checks = list(variant_checks) if variant_checks is not None else [house_checks(v) for v in variants]
    house: dict[str, Any] = {"base": {k: base_figures[k] for k in HOUSE_BASE_FIGURES}, "variants": []}
    house["base"]["parts_blocked"] = sum(len(r["base"]["parts_blocked"]) for r in rooms.values())
    house["base"]["windows_blocked"] = sum(len(r["base"]["windows_blocked"]) for r in rooms.values())
    house["base"]["screens_behind"] = sum(len(r["base"]["screens_behind"]) for r in rooms.values())
    for i, (v, c) in enumerate(zip(variants, checks, strict=True)):
        keep = [relkeep(b, s) for b, s in zip(base.rooms, v.rooms, strict=True)]
        house["variants"].append(
            {
                "house_nav": c["house_nav"],
                "unreachable_rooms": c["unreachable_rooms"],
                "door_blockers": len(c["door_blockers"]),
                "wall_crossings": len(c["wall_crossings"]),
                "RelKeep": round(min(keep), 4) if keep else 1.0,
                "parts_blocked": sum(len(r["variants"][i]["parts_blocked"]) for r in rooms.values()),
                "windows_blocked": sum(len(r["variants"][i]["windows_blocked"]) for r in rooms.values()),
                "screens_behind": sum(len(r["variants"][i]["screens_behind"]) for r in rooms.values()),
            }
        )
    if variants:
        house["diversity"] = house_diversity(variants)
        frozen = []
        for k, scene in enumerate(base.rooms):
            pieces = furniture(scene)
            if pieces and not moved_furniture(scene, [v.rooms[k] for v in variants]):
                frozen.append(scene.id)
        house["rooms_rearranged"] = sum(1 for s in base.rooms if furniture(s)) - len(frozen)
        house["rooms_not_rearranged"] = frozen
    return {"house": house, "rooms": rooms}


FURNITURE_M2 = 0.15
"""A floor piece with at least this much footprint (square metres) that is no fixture is furniture."""
MOVED_M = 0.3
"""Furniture moved when it is this far (metres) from where it stood in the base..."""
TURNED_DEG = 20.0
"""... or turned this many degrees."""


def furniture(scene: Scene) -> list[str]:
    """The room's furniture: floor-standing, solid, no fixture (``scene.is_fixture``), with at
    least :data:`FURNITURE_M2` of footprint (a chair, not a plunger)."""
    out = []
    for o in scene.objects:
        rel = scene.support_of(o.id)
        standing = (rel is None or rel.parent == FLOOR) and not is_thin(o) and not is_fixture(o.category)
        if standing and float(Polygon(o.footprint()).area) >= FURNITURE_M2:
            out.append(o.id)
    return out


def moved_furniture(base: Scene, variants: Sequence[Scene]) -> list[str]:
    """The furniture of ``base`` (:func:`furniture`) that some variant moves by :data:`MOVED_M` or
    turns by :data:`TURNED_DEG`."""
    out = []
    for oid in furniture(base):
        a = base.get(oid)
        for v in variants:
            b = v.get(oid)
            shift = math.dist(a.pose.position[:2], b.pose.position[:2])
            turn = abs(normalize_degrees(math.degrees(yaw_from_quat(b.pose.quaternion) - yaw_from_quat(a.pose.quaternion))))
            if shift >= MOVED_M or turn >= TURNED_DEG:
                out.append(oid)
                break
    return out

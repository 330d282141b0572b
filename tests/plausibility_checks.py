"""Would a person arrange it so? Judged from a run's output files, by code apart from the critic's.

Seats are judged by ``scenemosaic.metrics``' seating judge (written apart from the evolution's
rules); lamps over their groups and a sofa facing its TV are judged here with plain geometry.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from shapely.geometry import Point, Polygon
from shapely.ops import unary_union

from scenemosaic.exchange import read_scene
from scenemosaic.metrics import seat_checks, seat_pairs, table_balance
from scenemosaic.scene import CEILING, Scene, front_vector

LAMPS = ("pendant_lamp", "ceiling_lamp", "chandelier")
GROUP_KINDS = ("table", "desk", "bed", "sofa", "armchair")
OVER_M = 0.3
FACE_DEG = 20.0


def delivered(out: Path) -> tuple[Scene, list[Scene]]:
    """The base and the variants a run wrote."""
    variants = [read_scene(p) for p in sorted(out.glob("variant_*"), key=lambda p: int(p.name.split("_")[1]))]
    return read_scene(out / "base"), variants


def seat_problems(base: Scene, scenes: list[Scene]) -> list[str]:
    """Seats at a table or desk not square to their side (5 degrees), centred past its extent,
    or long sides holding counts more than one apart (tables against a wall excepted)."""
    pairs = seat_pairs(base)
    out: list[str] = []
    for i, s in enumerate(scenes):
        checks = seat_checks(s, pairs)
        out += [f"scene {i}: {c.seat} {c.off_deg:.1f} deg off the {c.side} of {c.table}" for c in checks if not c.square]
        out += [f"scene {i}: {c.seat} past the end of the {c.side} of {c.table}" for c in checks if not c.on_side]
        out += [f"scene {i}: {b.table} sides {dict(b.counts)}" for b in table_balance(s, checks) if b.balanced is False]
    return out


def _foot(scene: Scene, oid: str) -> Polygon:
    return Polygon(scene.get(oid).footprint())


def lamp_problems(base: Scene, variants: list[Scene]) -> list[str]:
    """Ceiling lamps that hung over a table, bed or seat group in the base (centre inside its
    footprint grown by 0.3 m) and no longer do in a variant."""
    out: list[str] = []
    for lamp in base.objects:
        rel = base.support_of(lamp.id)
        if not any(k in lamp.category for k in LAMPS) or rel is None or rel.parent != CEILING:
            continue
        at = Point(lamp.pose.position[:2])
        group = [o.id for o in base.objects if any(k in o.category for k in GROUP_KINDS) and _foot(base, o.id).buffer(OVER_M).contains(at)]
        if not group:
            continue
        for i, v in enumerate(variants, start=1):
            area = unary_union([_foot(v, g).buffer(OVER_M) for g in group])
            if not area.contains(Point(v.get(lamp.id).pose.position[:2])):
                out.append(f"variant {i}: {lamp.id} no longer over {group}")
    return out


def _off(scene: Scene, a: str, b: str) -> float:
    f = front_vector(scene.get(a).pose.quaternion)[:2]
    d = np.asarray(scene.get(b).pose.position[:2]) - np.asarray(scene.get(a).pose.position[:2])
    c = float(f @ d) / (float(np.linalg.norm(f)) * float(np.linalg.norm(d)))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def sofa_tv_problems(base: Scene, variants: list[Scene]) -> list[str]:
    """A sofa and a TV stand that faced each other in the base (each within 20 degrees of the
    way to the other) and no longer do in a variant."""
    sofas = [o.id for o in base.objects if "sofa" in o.category]
    tvs = [o.id for o in base.objects if o.category in ("tv_stand", "television")]
    out: list[str] = []
    for s in sofas:
        for t in tvs:
            if _off(base, s, t) > FACE_DEG or _off(base, t, s) > FACE_DEG:
                continue
            for i, v in enumerate(variants, start=1):
                if _off(v, s, t) > FACE_DEG or _off(v, t, s) > FACE_DEG:
                    out.append(f"variant {i}: {s} and {t} no longer face each other")
    return out

"""Plausibility: the arrangement rules a person checks at a glance, measured on any scene.

Written apart from the evolution's own rules (like the seating judge of ``_seating.py``), so a
variant the solver believes right is still judged. Each figure is the fraction of the pieces it
judges that pass (1.0 when the scene has none to judge):

* ``tv_faces_stand`` — a television standing on a TV stand (or any cabinet), or hung over one,
  faces the way the stand faces (within :data:`TV_STAND_DEG`): a TV turned to the wall behind
  it is wrong however clean its physics;
* ``tv_off_headboard`` — a wall-hung television is not on the wall behind a bed's head
  (``scene.on_backing_wall``: the wall the bed backs onto, where their spans along it overlap):
  nobody watches the wall they lie against;
* ``tv_not_behind_sofa`` — a television is not behind a sofa it stands within
  :data:`SOFA_REACH_M` of (on the side the sofa's back faces, within the sofa's width): the sofa
  would face away from it;
* ``seats_square`` — seats square to their table side (``seating_figures``, the seating judge).

:func:`plausibility` gives them for one scene; ``PLAUS`` in the metrics rows
(:func:`~scenemosaic.metrics.evaluate`) is their lowest.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import Polygon

from scenemosaic.metrics._seating import seating_figures
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    Scene,
    SceneObject,
    front_vector,
    is_screen,
    normalize_category,
    on_backing_wall,
    traits,
)

__all__ = ["PLAUSIBILITY_RULES", "SOFA_REACH_M", "TV_STAND_DEG", "plausibility"]

TV_STAND_DEG = 45.0
"""A TV faces the way its stand faces when their fronts are this close, degrees."""
SOFA_REACH_M = 1.5
"""A TV this close to a sofa's footprint (metres) and on its back side is behind it."""
PLAUSIBILITY_RULES = ("tv_faces_stand", "tv_off_headboard", "tv_not_behind_sofa", "seats_square")
"""The figures :func:`plausibility` returns, each a fraction of the pieces judged."""


def _front(o: SceneObject) -> np.ndarray:
    f = front_vector(o.pose.quaternion)[:2]
    n = float(np.linalg.norm(f))
    return f / n if n > 1e-9 else np.array([0.0, -1.0])


def _cat(o: SceneObject) -> str:
    return normalize_category(o.category)


def _xy(o: SceneObject) -> np.ndarray:
    return np.asarray(o.pose.position[:2], dtype=np.float64)


def _stand_of(scene: Scene, tv: SceneObject) -> SceneObject | None:
    """The cabinet a TV stands on, or hangs over (its centre above the stand's footprint)."""
    rel = scene.support_of(tv.id)
    if rel is not None and rel.parent not in (FLOOR, CEILING) and scene.anchor_kind(rel.parent) == "object":
        parent = scene.get(rel.parent)
        return parent if traits(parent.category).contains or "stand" in _cat(parent) else None
    from shapely.geometry import Point

    centre = Point(_xy(tv))
    below = [
        o for o in scene.objects
        if o.id != tv.id and traits(o.category).contains and traits(o.category).against_wall
        and float(o.aabb()[1][2]) <= float(tv.aabb()[0][2]) + 0.05 and Polygon(o.footprint()).buffer(0.3).contains(centre)
    ]  # fmt: skip
    return min(below, key=lambda o: (float(Polygon(o.footprint()).distance(centre)), o.id)) if below else None


def plausibility(scene: Scene) -> dict[str, float]:
    """The plausibility figures of one scene (module docstring), each in [0, 1]."""
    tvs = [o for o in scene.objects if is_screen(o.category)]
    facing: list[bool] = []
    headboard: list[bool] = []
    behind: list[bool] = []
    sofas = [o for o in scene.objects if "sofa" in _cat(o)]
    cos_stand = math.cos(math.radians(TV_STAND_DEG))
    for tv in tvs:
        stand = _stand_of(scene, tv)
        if stand is not None:
            facing.append(float(_front(tv) @ _front(stand)) >= cos_stand)
        rel = scene.support_of(tv.id)
        if rel is not None and rel.parent not in (FLOOR, CEILING) and scene.anchor_kind(rel.parent) == "wall":
            headboard.append(on_backing_wall(scene, tv.id, kind="bed") is None)
        for sofa in sofas:
            foot = Polygon(sofa.footprint())
            if foot.distance(Polygon(tv.footprint())) > SOFA_REACH_M:
                continue
            f = _front(sofa)
            rel_xy = _xy(tv) - _xy(sofa)
            half = float(np.ptp((sofa.footprint() - _xy(sofa)) @ np.array([f[1], -f[0]]))) / 2
            if abs(float(rel_xy @ np.array([f[1], -f[0]]))) > half:
                continue  # beside the sofa, not behind it
            behind.append(float(rel_xy @ f) >= 0.0)
    seats = seating_figures(scene, [scene])

    def share(flags: list[bool]) -> float:
        return round(sum(flags) / len(flags), 4) if flags else 1.0

    return {
        "tv_faces_stand": share(facing),
        "tv_off_headboard": share(headboard),
        "tv_not_behind_sofa": share(behind),
        "seats_square": float(seats["seats_square"]),
    }

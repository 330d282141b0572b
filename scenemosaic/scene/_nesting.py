"""Furniture standing inside furniture: boxes seen from above that share too much floor.

Hull collision checks miss this when stand-in meshes have legs and gaps (a TV stand slid under a
dressing table): the meshes do not touch, but no real pair of cabinets can stand that way. One
definition, used by the verification agent (which repairs it) and by physics validation (which
reports what is left).
"""

from __future__ import annotations

from dataclasses import dataclass

from shapely.geometry import Polygon

from scenemosaic.scene._categories import traits
from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._ids import FLOOR
from scenemosaic.scene._model import Scene, SceneObject
from scenemosaic.scene._planar import convex_hull_2d, sat_overlap

__all__ = [
    "CONCAVE_FOOTPRINTS",
    "NESTED_FRACTION",
    "NestedPair",
    "footprint_hull",
    "may_share_floor",
    "nested_pairs",
]

NESTED_FRACTION = 0.25
"""Two floor furniture boxes sharing more than this fraction of the smaller footprint, at heights
that overlap, stand inside each other: real furniture cannot (chairs tucked under a table excepted)."""
CONCAVE_FOOTPRINTS = ("l_shaped", "corner_sofa", "sectional")
"""Category fragments of furniture whose box is much larger than its footprint (an L-shaped sofa's
box holds the corner table in the crook of the L)."""
_HEIGHT_OVERLAP_M = 0.05


@dataclass(frozen=True)
class NestedPair:
    """Two floor-standing pieces whose boxes stand inside each other.

    ``shared``: the fraction of the smaller footprint both boxes cover; ``depth_m`` and ``axis``:
    the separating-axis overlap of the two footprints, so moving ``b`` by ``depth_m * axis`` (or
    ``a`` by ``-depth_m * axis``) parts them.
    """

    a: str
    b: str
    shared: float
    depth_m: float
    axis: tuple[float, float]

    def label(self) -> str:
        """``"a ~ b"``, the form reports use."""
        return f"{self.a} ~ {self.b}"


def footprint_hull(obj: SceneObject) -> FloatArray:
    """The object's box seen from above: a counter-clockwise convex polygon, shape (4, 2)."""
    return convex_hull_2d(obj.corners()[:, :2])


def may_share_floor(a: SceneObject, b: SceneObject) -> bool:
    """Pairs whose boxes may overlap in a real room: a seat tucked under a table, and anything in
    the crook of an L-shaped sofa."""
    ta, tb = traits(a.category), traits(b.category)
    if (ta.seat and tb.table) or (tb.seat and ta.table):
        return True
    return any(k in c for c in (a.category, b.category) for k in CONCAVE_FOOTPRINTS)


def _floor_furniture(scene: Scene) -> list[SceneObject]:
    return [
        o
        for o in scene.objects
        if (rel := scene.support_of(o.id)) is not None
        and rel.parent == FLOOR
        and traits(o.category).placement == "floor"
    ]


def nested_pairs(scene: Scene, *, fraction: float = NESTED_FRACTION) -> list[NestedPair]:
    """Pairs of floor-standing furniture whose boxes stand inside each other (in object order).

    Both stand on the floor, their heights overlap by more than 5 cm, they are not a pair that
    may share floor (:func:`may_share_floor`), and their boxes share more than ``fraction`` of
    the smaller footprint.
    """
    floor = _floor_furniture(scene)
    hulls = {o.id: footprint_hull(o) for o in floor}
    found: list[NestedPair] = []
    for i, a in enumerate(floor):
        (_, _, az0), (_, _, az1) = a.aabb()
        for b in floor[i + 1 :]:
            if may_share_floor(a, b):
                continue
            (_, _, bz0), (_, _, bz1) = b.aabb()
            if min(az1, bz1) - max(az0, bz0) <= _HEIGHT_OVERLAP_M:
                continue
            pa, pb = Polygon(hulls[a.id]), Polygon(hulls[b.id])
            smaller = min(pa.area, pb.area)
            if smaller <= 0:
                continue
            shared = float(pa.intersection(pb).area) / smaller
            if shared <= fraction:
                continue
            depth, axis = sat_overlap(hulls[a.id], hulls[b.id])
            found.append(
                NestedPair(a.id, b.id, round(shared, 4), float(depth), (float(axis[0]), float(axis[1])))
            )
    return found

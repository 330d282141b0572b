"""``fill``: receptacles emptier than the priors' typical density get small objects drawn from the
priors, packed, settled with their unit and kept only when they rest.

For each receptacle of the scene (an object whose type ProcTHOR's ``receptacles.json`` lists), in
id order, when it holds fewer small objects than the type's typical density
(:class:`~scenemosaic.clutter.ClutterPriors`):

1. its surfaces (:func:`~scenemosaic.clutter.receptacle_surfaces`: the top, each compartment) are
   filled one at a time: a type is drawn with the priors' weights for the receptacle type and the
   room's kind, an asset of that type that fits the surface's headroom is drawn uniformly from the
   shipped asset database, a heading is drawn, and ``scene.pack_surface`` (the packing physics uses
   for crowded surfaces and compartments) looks for a free place nearest a drawn point; objects are
   added until the surface holds ``density`` objects per square metre (what stood there already
   counted), or several draws in a row find
   no place;
2. the receptacle's new objects are settled as one unit (``physics.settle_unit``: containment,
   snapping onto the board or top, separation, MuJoCo with gravity), every other object a static
   neighbour.

Then the whole scene is checked as it will be delivered (:func:`~scenemosaic.clutter.rest_check`):
an added object that moves :data:`REST_TOLERANCE_M` or more in :data:`REST_SECONDS` of plain
MuJoCo, or interpenetrates anything, is placed again once elsewhere on its surface, and dropped
(reported) when it still does not rest.
"""

from __future__ import annotations

import math
import time
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import structlog
from shapely.geometry import Point, Polygon

from scenemosaic.assets import HullCache, swept_footprints
from scenemosaic.clutter._priors import ClutterAsset, ClutterPriors, room_kind
from scenemosaic.clutter._rest import REST_SECONDS, REST_TOLERANCE_M, rest_check
from scenemosaic.clutter._surfaces import Surface, receptacle_surfaces
from scenemosaic.physics import ObjectShape, SettleSettings, SimSettings, UnitPlan, object_shape, settle_unit
from scenemosaic.scene import (
    CEILING,
    CLUTTER_METADATA,
    AssetRef,
    PackItem,
    Pose,
    Scene,
    SceneObject,
    SimAttributes,
    pack_surface,
    unique_id,
)

__all__ = [
    "CLUTTER_METADATA",
    "DEFAULT_DENSITY",
    "MIN_BASE_RATIO",
    "ClutterReport",
    "clutter_ids",
    "fill_scene",
    "new_clutter_object",
]

log = structlog.get_logger(__name__)

DEFAULT_DENSITY = 10.0
"""Default number of small objects per square metre of receptacle surface after ``fill`` (a laid
dining table of 1.6 square metres: sixteen)."""
MIN_BASE_RATIO = 0.3
"""An asset whose narrower base side is below this share of its height (a tall bottle, a book on
edge) is not drawn: it tips at the first touch, so it would be dropped anyway."""
MAX_MISSES = 6
"""Draws in a row that find no free place before a surface counts as full."""
MAX_PER_SURFACE = 16
"""Most objects one surface receives in one fill."""
CAP_TYPICAL_FACTOR = 4.0
"""A receptacle holds at most this many times its type's typical density (and at least
:data:`CAP_MIN` may be placed): a wardrobe's ten compartments would otherwise take sixty objects
whose weight alone shifts it on the floor."""
CAP_MIN = 6
"""The least cap of a receptacle (see :data:`CAP_TYPICAL_FACTOR`)."""
FULL_TYPICAL = 3.0
"""A receptacle type whose typical density (small objects per receptacle in ProcTHOR) reaches this
is filled to the whole ``density``; a type that holds fewer is filled to that share of it (a
chair, 0.14 objects on average, to a twentieth of it: one thing on its seat, not eight)."""
MIN_TYPICAL = 0.1
"""A receptacle type whose typical density is below this (a stool, a garbage can: one in ten or
fewer holds anything in ProcTHOR) receives nothing."""
DROP_GAP_M = 0.002
"""Height above its surface at which an object is put before it settles, metres."""


@dataclass
class ClutterReport:
    """What a clutter pass did to one scene: objects added (by receptacle), moved, swapped,
    dropped (with why), and the rest check's figures."""

    mode: str
    added: dict[str, list[str]] = field(default_factory=dict)
    moved: list[str] = field(default_factory=list)
    swapped: list[str] = field(default_factory=list)
    dropped: dict[str, str] = field(default_factory=dict)
    retried: list[str] = field(default_factory=list)
    checked: int = 0
    stable: int = 0
    seconds: float = 0.0

    @property
    def added_count(self) -> int:
        """How many objects were added and kept."""
        return sum(len(v) for v in self.added.values())

    @property
    def stable_share(self) -> float:
        """Share of the checked small objects that rest (1.0 when none were checked)."""
        return self.stable / self.checked if self.checked else 1.0

    def summary(self) -> dict[str, object]:
        """The report as ``report.json``'s stage detail."""
        return {
            "mode": self.mode,
            "added": self.added_count,
            "added_by_receptacle": {k: len(v) for k, v in sorted(self.added.items()) if v},
            "moved": len(self.moved),
            "swapped": len(self.swapped),
            "retried": len(self.retried),
            "dropped": dict(sorted(self.dropped.items())),
            "stable_share": round(self.stable_share, 4),
            "seconds": round(self.seconds, 3),
        }


def clutter_ids(scene: Scene) -> list[str]:
    """Ids of the small objects a clutter pass placed in ``scene`` (its metadata's record)."""
    record = scene.metadata.get(CLUTTER_METADATA) or {}
    objects = record.get("objects") or {}
    present = {o.id for o in scene.objects}
    return [oid for oid in objects if oid in present]


def new_clutter_object(
    asset: ClutterAsset, oid: str, surface: Surface, xy: tuple[float, float], yaw: float
) -> SceneObject:
    """An object of the database ``asset`` standing on ``surface`` at ``xy`` (world) turned ``yaw``;
    its mass and friction from the attributes table, free to move."""
    words = asset.category.replace("_", " ")
    return SceneObject(
        id=oid,
        category=asset.category,
        description=f"{words} (AI2-THOR asset {asset.asset_id})",
        asset=AssetRef(kind="procedural", category=asset.category, extents=asset.size),
        pose=Pose.from_yaw((xy[0], xy[1], surface.height + DROP_GAP_M), yaw),
        sim=SimAttributes(
            mass_kg=asset.mass_kg(),
            friction=asset.friction(),
            static=False,
            source=f"clutter: asset database {asset.asset_id}, attributes table",
        ),
    )


def _seed(seed: int, *parts: object) -> int:
    return zlib.crc32(":".join(str(p) for p in (seed, *parts)).encode())


def _footprint(asset: ClutterAsset, xy: tuple[float, float], yaw: float) -> np.ndarray:
    w, d = asset.size[0] / 2, asset.size[1] / 2
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[-w, -d], [w, -d], [w, d], [-w, d]])
    out: np.ndarray = local @ np.array([[c, s], [-s, c]]) + np.asarray(xy)
    return out


def _random_point(poly: Polygon, rng: np.random.Generator) -> tuple[float, float]:
    minx, miny, maxx, maxy = poly.bounds
    for _ in range(50):
        x, y = float(rng.uniform(minx, maxx)), float(rng.uniform(miny, maxy))
        if poly.contains(Point(x, y)):
            return x, y
    c = poly.representative_point()
    return float(c.x), float(c.y)


def _occupied(
    scene: Scene, surface: Surface, skip: set[str] | frozenset[str] = frozenset()
) -> list[np.ndarray]:
    """Footprints of the objects already on or in ``surface`` (but ``skip``): the receptacle's
    children whose bottom lies near its height and whose centre lies over it."""
    out = []
    for cid in scene.children_of(surface.receptacle):
        if cid in skip:
            continue
        obj = scene.get(cid)
        lo = obj.aabb()[0]
        if abs(float(lo[2]) - surface.height) > 0.05 or not surface.polygon.buffer(0.02).contains(
            Point(*obj.pose.position[:2])
        ):
            continue
        out.append(obj.footprint())
    return out


def place_on_surface(
    scene: Scene,
    surface: Surface,
    asset: ClutterAsset,
    rng: np.random.Generator,
    taken: list[np.ndarray],
) -> tuple[tuple[float, float], float] | None:
    """A free place for ``asset`` on ``surface`` beside the footprints ``taken`` (which it joins) and
    out of the way of every part that opens through the surface's height band
    (``assets.swept_footprints``): ``scene.pack_surface`` from a drawn point and heading; ``None``
    when there is none."""
    if asset.size[2] + 0.01 > surface.headroom:
        return None
    start = _random_point(surface.polygon, rng)
    # on a top any heading; in a compartment square to its walls, a quarter turn at most
    yaw = (
        float(rng.uniform(-math.pi, math.pi))
        if surface.placement == "on"
        else surface.yaw + (math.pi / 2) * int(rng.integers(0, 2))
    )
    corners = _footprint(asset, start, yaw)
    items = [PackItem(f"taken_{k}", c, movable=False) for k, c in enumerate(taken)]
    # where a drawer, door or lid passes on its way open (the microwave's door, the toilet's lid)
    inside = surface.receptacle if surface.placement == "in" else None  # a drawer's or cupboard's own parts close over it
    swept = swept_footprints(scene, surface.height, surface.height + asset.size[2], surface.polygon.bounds, skip=inside)
    items += [PackItem(f"swept_{k}", c, movable=False) for k, c in enumerate(swept)]
    items.append(PackItem("new", corners, movable=True, may_turn=surface.placement == "in"))
    result = pack_surface(surface.polygon, items)
    if "new" in result.unplaced or "new" not in result.shifts:
        return None
    if "new" in result.turned:
        yaw += math.pi / 2
    footprint = result.footprint(items[-1])
    centre = footprint.mean(axis=0)
    taken.append(footprint)
    return (float(centre[0]), float(centre[1])), yaw


def _asset_of(scene: Scene, oid: str, priors: ClutterPriors) -> ClutterAsset | None:
    record = ((scene.metadata.get(CLUTTER_METADATA) or {}).get("objects") or {}).get(oid) or {}
    asset = priors.by_id.get(str(record.get("asset_id")))
    if asset is None:  # a source object: its asset in the database (a ProcTHOR one), else a stand-in of its type and size
        source = scene.provenance.asset_ids.get(oid)
        asset = priors.by_id.get(str(source))
    if asset is None:
        obj = scene.get(oid)
        t = priors.object_type(obj.category)
        if t is None:
            return None
        w, d, h = (float(v) for v in obj.size)
        asset = ClutterAsset(f"source:{oid}", t, obj.category, (w, d, h))
    return asset


def _fits(asset: ClutterAsset, surface: Surface) -> bool:
    minx, miny, maxx, maxy = surface.polygon.bounds
    reach = max(maxx - minx, maxy - miny)
    return (
        asset.size[2] + 0.01 <= surface.headroom
        and max(asset.size[0], asset.size[1]) + 0.05 <= reach
        and min(asset.size[0], asset.size[1]) >= MIN_BASE_RATIO * asset.size[2]
        and asset.footprint_m2 <= 0.5 * surface.polygon.area
    )


def draw_asset(
    priors: ClutterPriors, receptacle_type: str, kind: str | None, surface: Surface, rng: np.random.Generator
) -> ClutterAsset | None:
    """A type drawn with the priors' weights for ``receptacle_type`` in a room of ``kind``, then one
    of its assets that fits ``surface``, uniformly; ``None`` when nothing fits."""
    choices = [
        (t, p)
        for t, p in priors.choices(receptacle_type, kind)
        if any(_fits(a, surface) for a in priors.assets[t])
    ]
    if not choices:
        return None
    weights = np.array([p for _, p in choices])
    t = choices[int(rng.choice(len(choices), p=weights / weights.sum()))][0]
    fitting = [a for a in priors.assets[t] if _fits(a, surface)]
    return fitting[int(rng.integers(0, len(fitting)))]


def _receptacles(scene: Scene, priors: ClutterPriors) -> list[tuple[str, str]]:
    """The scene's receptacles, by id, with their types: the standing pieces whose type the
    priors know as a receptacle that holds at least :data:`MIN_TYPICAL` objects, and that are no
    small object themselves (a plate, a bowl, a box)."""
    out = []
    for obj in sorted(scene.objects, key=lambda o: o.id):
        rel = scene.support_of(obj.id)
        if rel is not None and (rel.parent == CEILING or scene.anchor_kind(rel.parent) == "wall"):
            continue  # hung pieces hold nothing
        t = priors.receptacle_type(obj.category)
        if t is not None and t not in priors.assets and priors.typical.get(t, 0.0) >= MIN_TYPICAL:
            out.append((obj.id, t))
    return out


def receptacles(scene: Scene, priors: ClutterPriors) -> list[tuple[str, str]]:
    """The receptacles ``fill`` considers in ``scene``, as ``(object id, receptacle type)`` in id
    order: standing pieces whose type the priors know as a receptacle holding at least
    :data:`MIN_TYPICAL` objects on average, not small objects themselves. The densities of
    ``docs/clutter.md`` (*Houses*) are counted over these."""
    return _receptacles(scene, priors)


def _near(scene: Scene, anchor: str, reach: float = 0.6) -> list[str]:
    lo, hi = scene.get(anchor).aabb()
    out = []
    for o in scene.objects:
        if o.id == anchor:
            continue
        olo, ohi = o.aabb()
        if np.all(olo[:2] <= hi[:2] + reach) and np.all(ohi[:2] >= lo[:2] - reach):
            out.append(o.id)
    return out


def _settle(scene: Scene, anchor: str, new: list[str], shapes: dict[str, ObjectShape], seed: int) -> None:
    """Settle ``new`` (children of ``anchor``) as one unit, everything near it static; in place."""
    plan = UnitPlan(anchor, "object", tuple(new), depth=1)
    neighbours = [oid for oid in _near(scene, anchor) if oid not in set(new)]
    poses, _ = settle_unit(
        scene, plan, shapes, [anchor, *neighbours], sim=SimSettings(), settle=SettleSettings(), seed=seed
    )
    for oid, pose in poses.items():
        scene.get(oid).pose = pose


def fill_scene(
    scene: Scene,
    *,
    density: float = DEFAULT_DENSITY,
    priors: ClutterPriors,
    seed: int = 0,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
    id_prefix: str = "",
) -> tuple[Scene, ClutterReport]:
    """A copy of ``scene`` whose emptier receptacles hold small objects drawn from ``priors``, up to
    ``density`` objects per square metre of each surface (see the module docstring). Deterministic for a ``seed``.

    New ids are the category, numbered where taken (``book``, ``book_2``), after ``id_prefix``: a
    room of a house passes its own id, so two rooms' new objects never share one."""
    t0 = time.perf_counter()
    out = scene.model_copy(deep=True)
    report = ClutterReport(mode="fill")
    kind = room_kind(out)
    shapes = {o.id: object_shape(o, base_dir, cache=hull_cache) for o in out.objects}
    taken_ids = {o.id for o in out.objects}
    record = out.metadata.setdefault(CLUTTER_METADATA, {"objects": {}})
    record.setdefault("objects", {})
    surfaces_of: dict[str, Surface] = {}
    for receptacle, rtype in _receptacles(out, priors):
        held = len(out.children_of(receptacle))
        if held >= priors.typical[rtype]:
            continue
        rng = np.random.default_rng(_seed(seed, "fill", receptacle))
        new: list[str] = []
        cap = max(CAP_MIN, math.ceil(CAP_TYPICAL_FACTOR * priors.typical[rtype])) - held
        for surface in receptacle_surfaces(out, receptacle, shapes):
            taken = _occupied(out, surface)
            target = density * min(1.0, priors.typical[rtype] / FULL_TYPICAL) * surface.polygon.area
            standing = len(taken)
            misses = placed = 0
            while (
                standing + placed < target
                and misses < MAX_MISSES
                and placed < MAX_PER_SURFACE
                and len(new) < cap
            ):
                asset = draw_asset(priors, rtype, kind, surface, rng)
                if asset is None:
                    break
                spot = place_on_surface(out, surface, asset, rng, taken)
                if spot is None:
                    misses += 1
                    continue
                misses = 0
                oid = unique_id(f"{id_prefix}{asset.category}", taken_ids)
                obj = new_clutter_object(asset, oid, surface, *spot)
                out.objects.append(obj)
                out.relations.append(surface.support_relation(oid))
                shapes[oid] = object_shape(obj, base_dir, cache=hull_cache)
                record["objects"][oid] = {
                    "asset_id": asset.asset_id,
                    "receptacle": receptacle,
                    "placement": surface.placement,
                }
                surfaces_of[oid] = surface
                placed += 1
                new.append(oid)
        if new:
            _settle(out, receptacle, new, shapes, _seed(seed, "settle", receptacle))
            report.added[receptacle] = new
    _keep_resting(out, report, surfaces_of, shapes, priors, seed, base_dir, hull_cache)
    record["mode"] = "fill"
    out.provenance.steps.append("clutter")
    report.seconds = time.perf_counter() - t0
    log.info(
        "clutter_filled",
        scene=out.id,
        added=report.added_count,
        dropped=len(report.dropped),
        seconds=round(report.seconds, 3),
    )
    return out, report


def remove_objects(scene: Scene, ids: set[str]) -> None:
    """Take ``ids`` (small objects nothing rests on) out of ``scene``, with their relations, the
    cross-unit constraints' mentions of them (a constraint anchored on one goes) and their record."""
    if not ids:
        return
    # references first: the scene checks them on every assignment
    kept = []
    for c in scene.constraints:
        if c.anchor_a.anchor_id in ids or c.anchor_b.anchor_id in ids:
            continue
        for clause in (c.anchor_a, c.anchor_b):
            clause.related_objects = [oid for oid in clause.related_objects if oid not in ids]
        kept.append(c)
    scene.constraints = kept
    scene.relations = [r for r in scene.relations if r.child not in ids and r.parent not in ids]
    scene.objects = [o for o in scene.objects if o.id not in ids]
    record = (scene.metadata.get(CLUTTER_METADATA) or {}).get("objects") or {}
    for oid in ids:
        record.pop(oid, None)


OFF_SURFACE_M = 0.02
"""How far (metres) a settled object's centre may lie outside its surface's outline, or its bottom
below the surface, before it counts as off its receptacle (placed again, then dropped)."""


def _off_surface(
    scene: Scene, ids: list[str], surfaces_of: Mapping[str, Surface], shapes: Mapping[str, ObjectShape]
) -> set[str]:
    """The objects among ``ids`` that settling took off their receptacle: out of every compartment
    and off the top (they may rest, on the floor beside it, yet are no longer on or in it). The
    settling may move an object into a neighbouring compartment of the same receptacle: it is
    still in it."""
    out = set()
    found: dict[str, list[Surface]] = {}
    for oid in ids:
        surface = surfaces_of.get(oid)
        if surface is None:
            continue
        if surface.receptacle not in found:
            found[surface.receptacle] = receptacle_surfaces(scene, surface.receptacle, shapes)
        x, y, z = (float(v) for v in scene.get(oid).pose.position)
        if not any(
            z >= s.height - OFF_SURFACE_M and s.polygon.buffer(OFF_SURFACE_M).covers(Point(x, y))
            for s in [surface, *found[surface.receptacle]]
        ):
            out.add(oid)
    return out


def _keep_resting(
    scene: Scene,
    report: ClutterReport,
    surfaces_of: dict[str, Surface],
    shapes: dict[str, ObjectShape],
    priors: ClutterPriors,
    seed: int,
    base_dir: str | Path | None,
    hull_cache: HullCache | None,
    back: Mapping[str, Surface] | None = None,
    moved: Callable[[str, Surface], None] | None = None,
) -> None:
    """The rest check; what fails it is placed once more elsewhere on its surface (first on its
    surface in ``back`` when it has one there, a varied object's own place; ``moved`` is told when
    it goes there), then dropped."""
    candidates = [oid for oids in report.added.values() for oid in oids]
    if not candidates:
        return
    failed = rest_check(scene, candidates, shapes, base_dir=base_dir, hull_cache=hull_cache)
    failed |= _off_surface(scene, candidates, surfaces_of, shapes)
    if failed:
        report.retried = sorted(failed)
        by_receptacle: dict[str, list[str]] = {}
        again: dict[str, list[np.ndarray]] = {}  # footprints of the objects placed again, per surface
        for oid in sorted(failed):
            obj = scene.get(oid)
            rng = np.random.default_rng(_seed(seed, "retry", oid))
            asset = _asset_of(scene, oid, priors)
            if asset is None:
                continue
            spot = None
            home = (back or {}).get(oid)
            for surface in [home, surfaces_of[oid]] if home is not None else [surfaces_of[oid]]:
                taken = _occupied(scene, surface, skip=failed) + again.setdefault(surface.key, [])
                spot = place_on_surface(scene, surface, asset, rng, taken)
                if spot is not None:
                    break
            if spot is None:
                continue
            again[surface.key].append(taken[-1])
            (x, y), yaw = spot
            obj.pose = Pose.from_yaw((x, y, surface.height + DROP_GAP_M), yaw, obj.pose.scale)
            if surface.key != surfaces_of[oid].key:
                surfaces_of[oid] = surface
                if moved is not None:
                    moved(oid, surface)
            by_receptacle.setdefault(surface.receptacle, []).append(oid)
        for receptacle, ids in by_receptacle.items():
            _settle(scene, receptacle, ids, shapes, _seed(seed, "resettle", receptacle))
        still = rest_check(scene, candidates, shapes, base_dir=base_dir, hull_cache=hull_cache)
        off = _off_surface(scene, candidates, surfaces_of, shapes)
        gone = {
            oid: f"did not rest within {REST_TOLERANCE_M * 100:.0f} cm over {REST_SECONDS:g} s, placed twice"
            for oid in still
        }
        gone.update({oid: "settled off its receptacle's surface, placed twice" for oid in sorted(off - still)})
        report.dropped.update(gone)
        remove_objects(scene, set(gone))
        for receptacle in list(report.added):
            report.added[receptacle] = [oid for oid in report.added[receptacle] if oid not in gone]
    kept = [oid for oids in report.added.values() for oid in oids]
    report.checked = len(candidates)
    report.stable = len(kept)

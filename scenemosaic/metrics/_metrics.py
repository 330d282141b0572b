"""The field's scene metrics, each a documented function.

Physical metrics (SceneEval's definitions, our implementation):

* :func:`col` — COL, the fraction of objects in collision: a pair counts only when the two still
  interpenetrate after being moved 5 mm apart, i.e. when the hull penetration is deeper than
  ``COL_SEPARATION_M`` (SceneEval's rule; our hulls are CoACD pieces). Thin objects (rugs,
  sheets of paper; ``physics.is_thin``) are left out, as in the method.
* :func:`oob` — OOB, the fraction of objects of which fewer than ``OOB_INSIDE`` (99 %) of
  ``OOB_SAMPLES`` (1000) points sampled on the visual mesh's surface land on the floor polygon when
  cast straight down.
* :func:`nav` — NAV, the floor rasterized at ``NAV_GRID`` x ``NAV_GRID`` over its bounding box,
  objects whose bottom is below ``NAV_MAX_HEIGHT`` (2 m) drawn as their 2D boxes (thin objects are
  walked over), the free floor eroded by a robot of radius ``NAV_ROBOT_RADIUS`` (0.2 m); the
  largest connected free area over all free area (1.0 when the free floor is one piece).

Diversity over selected variants (the method's evaluation):

* :func:`div_iou` — the mean pairwise IoU of top-down occupancy maps (``DIV_GRID`` squared over
  the floor's bounding box, every non-thin object's 2D box filled); lower is more diverse.
* :func:`div_n` — the mean pairwise novelty distance N, the earlier-selected scene the reference.
* :func:`relkeep` — the fraction of the base scene's attach/contain relations still satisfied in
  a variant (:func:`relation_holds`).
* :func:`relkeep_by_kind` — RelKeep per kind: ``support`` (the above) and each functional
  relation of the base (``scene.functional_relations``: faces, over, under, beside, flanks);
  ``None`` for a kind the base does not have.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from shapely import contains_xy, prepare
from shapely.geometry import Polygon, box

from scenemosaic._memo import Memo
from scenemosaic.assets import HullCache, asset_fingerprint, object_articulation, part_blockers, short_parts
from scenemosaic.compose import Arrangement, novelty_distance
from scenemosaic.metrics._plausibility import plausibility
from scenemosaic.physics import check_collisions, is_thin
from scenemosaic.render import object_world_arrays, object_world_mesh
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    FUNCTIONAL_KINDS,
    HOUSE_CELL_M,
    ROBOT_RADIUS,
    WALK_GRID,
    WALK_MAX_HEIGHT,
    FloatArray,
    FloorRaster,
    House,
    Relation,
    Scene,
    SceneObject,
    blocked_windows,
    convex_hull_2d,
    functional_holds,
    functional_relations,
    mask_iou,
    screens_behind,
)

__all__ = [
    "COL_SEPARATION_M",
    "DIV_GRID",
    "NAV_GRID",
    "NAV_MAX_HEIGHT",
    "NAV_ROBOT_RADIUS",
    "OOB_EDGE_M",
    "OOB_INSIDE",
    "OOB_SAMPLES",
    "RELATION_TOLERANCE_M",
    "blocked_parts",
    "col",
    "div_iou",
    "div_n",
    "evaluate_scenes",
    "house_diversity",
    "house_occupancy",
    "nav",
    "occupancy",
    "oob",
    "parts_free",
    "relation_holds",
    "relkeep",
    "relkeep_by_kind",
    "relkeep_summary",
    "scene_metrics",
]

COL_SEPARATION_M = 0.005
"""SceneEval: a mesh pair is in collision only if it still intersects after separating the two by 5 mm."""
OOB_SAMPLES = 1000
"""SceneEval: at least 1000 surface samples per object."""
OOB_INSIDE = 0.99
"""SceneEval: an object is in bounds when at least 99 % of its samples land on the floor."""
OOB_EDGE_M = 0.001
"""Ours: a sample within 1 mm outside the floor's edge still lands on it. A TV hung flush on its
wall has its whole back face on the wall's plane, where float noise of 0.1 mm would otherwise
put half its samples out of bounds."""
NAV_GRID = WALK_GRID
"""Raster side of the navigability map (the method's 256 x 256)."""
NAV_ROBOT_RADIUS = ROBOT_RADIUS
"""Radius of the robot the free floor is eroded by, metres (the method's 0.2 m)."""
NAV_MAX_HEIGHT = WALK_MAX_HEIGHT
"""Objects whose bottom is below this height block the floor, metres (the method's 2 m)."""
DIV_GRID = 256
"""Raster side of the top-down occupancy maps compared by Div-IoU."""
RELATION_TOLERANCE_M = 0.02
"""How far a child may be from its support (or stick out of its container) and still count as on it."""


def _solid(scene: Scene) -> list[str]:
    return [o.id for o in scene.objects if not is_thin(o)]


def col(scene: Scene, base_dir: str | Path | None = None, *, hull_cache: HullCache | None = None) -> float:
    """COL: the fraction of (non-thin) objects in a colliding pair deeper than 5 mm."""
    solid = _solid(scene)
    if not solid:
        return 0.0
    report = check_collisions(scene, base_dir, hull_cache=hull_cache, tolerance_m=COL_SEPARATION_M)
    return len(report.object_ids() & set(solid)) / len(solid)


def oob(scene: Scene, base_dir: str | Path | None = None, *, seed: int = 0) -> float:
    """OOB: the fraction of objects with under 99 % of 1000 surface samples over the floor polygon."""
    if scene.room is None or not scene.objects:
        return 0.0
    floor = tuple(tuple(p) for p in scene.room.floor)
    edge: list[Polygon] = []  # made when an object is not known yet

    def outside(k: int, obj: SceneObject) -> bool:
        if not edge:
            edge.append(Polygon(floor).buffer(OOB_EDGE_M))
            prepare(edge[0])  # asked of every sample of every object
        folder = Path(base_dir) if base_dir is not None else None
        vertices, _ = object_world_arrays(obj, folder)
        corners = obj.corners()
        if len(vertices) and all(
            edge[0].contains_properly(box(*p.min(axis=0)[:2], *p.max(axis=0)[:2])) for p in (vertices, corners)
        ):  # every sample lies within the mesh's bounds (or its box's, for a mesh without area): all in
            return False
        mesh = object_world_mesh(obj, folder)
        if len(mesh.faces) == 0 or mesh.area <= 0:
            pts = corners
        else:
            rng = np.random.default_rng(seed + k)
            weights = mesh.area_faces / mesh.area_faces.sum()
            faces = rng.choice(len(mesh.faces), size=OOB_SAMPLES, p=weights)
            tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)[faces]]
            a, b = rng.random((2, OOB_SAMPLES, 1))
            flip = (a + b) > 1
            a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
            pts = tri[:, 0] + a * (tri[:, 1] - tri[:, 0]) + b * (tri[:, 2] - tri[:, 0])
        inside = contains_xy(edge[0], pts[:, 0], pts[:, 1])
        return float(inside.mean()) < OOB_INSIDE

    out = 0
    for k, obj in enumerate(scene.objects):
        p = obj.pose
        key = (seed + k, asset_fingerprint(obj, base_dir), p.position, p.quaternion, p.scale, floor)
        out += _OUTSIDE.get(key, functools.partial(outside, k, obj))
    return out / len(scene.objects)


_OUTSIDE: Memo[tuple[object, ...], bool] = Memo(1 << 14)
"""Whether an object is out of bounds (:func:`oob`), by what decides it: its sample seed, asset,
pose and the floor. A house's variants leave many objects where they were (fixtures, pictures,
whole rooms), and each is judged once."""


def _footprints(scene: Scene, below: float | None) -> list[np.ndarray]:
    """The 2D boxes of the non-thin objects (whose bottom is under ``below``, when given)."""
    return [
        convex_hull_2d(o.corners()[:, :2])
        for o in scene.objects
        if not is_thin(o) and (below is None or float(o.aabb()[0][2]) < below)
    ]


def occupancy(scene: Scene, grid: int = DIV_GRID) -> np.ndarray:
    """Top-down occupancy of non-thin objects: booleans over the floor's bounding box, ``grid``
    cells along its longer side."""
    if scene.room is None:
        raise ValueError("occupancy needs a room")
    floor = np.asarray(scene.room.floor, dtype=np.float64)
    raster = FloorRaster(floor, float(max(np.ptp(floor, axis=0))) / grid)
    return raster.blocked(_footprints(scene, None))


def nav(scene: Scene) -> float:
    """NAV: the largest connected piece of walkable floor over all walkable floor (1.0: one piece;
    ``scene.Walkable.share`` on the floor's raster)."""
    if scene.room is None:
        return 1.0
    floor = tuple(tuple(p) for p in scene.room.floor)
    raster = _NAV_RASTERS.get(floor, lambda: FloorRaster(np.asarray(floor, dtype=np.float64)))
    return raster.walkable(raster.blocked(_footprints(scene, NAV_MAX_HEIGHT)), NAV_ROBOT_RADIUS).share


_NAV_RASTERS: Memo[tuple[tuple[float, ...], ...], FloorRaster] = Memo(256)
"""NAV's raster by floor (never modified): a room's base and variants share their floor."""


def div_iou(scenes: Sequence[Scene], grid: int = DIV_GRID) -> float | None:
    """Div-IoU: the mean IoU of the top-down occupancy maps over every pair of ``scenes`` (all
    must share one room); ``None`` with fewer than two scenes."""
    if len(scenes) < 2:
        return None
    maps = [occupancy(s, grid) for s in scenes]
    ious = []
    for a, b in itertools.combinations(maps, 2):
        ious.append(mask_iou(a, b))
    return float(np.mean(ious))


def div_n(scenes: Sequence[Scene]) -> float | None:
    """Div-N: the mean novelty distance over every pair of ``scenes`` (same objects), the earlier
    scene of each pair the reference; ``None`` with fewer than two scenes."""
    if len(scenes) < 2:
        return None
    ids = [o.id for o in scenes[0].objects]
    arrs = [Arrangement.of(s, ids) for s in scenes]
    return float(np.mean([novelty_distance(a, b) for a, b in itertools.combinations(arrs, 2)]))


def house_occupancy(house: House, cell: float = HOUSE_CELL_M, *, bounds: FloatArray | None = None) -> np.ndarray:
    """Top-down occupancy of a whole house's non-thin objects on one raster of ``cell`` metres
    over ``bounds`` (a (2, 2) min/max corner pair; default: the house's floors)."""
    if bounds is None:
        pts = np.concatenate([np.asarray(s.room.floor, dtype=np.float64) for s in house.rooms if s.room is not None])
        bounds = np.stack([pts.min(axis=0), pts.max(axis=0)])
    (x0, y0), (x1, y1) = bounds
    raster = FloorRaster(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]), cell=cell)
    out = np.zeros(raster.shape, dtype=bool)
    for s in house.rooms:
        out |= raster.blocked(_footprints(s, None))
    return out


def house_diversity(houses: Sequence[House]) -> dict[str, float | int | None]:
    """Div-IoU and Div-N of whole-house variants: the mean IoU of their house-wide occupancy maps
    over every pair (:func:`house_occupancy`, one raster for all), and the mean novelty distance
    over every pair with all of the house's objects (the earlier house the reference)."""
    if len(houses) < 2:
        return {"Div-IoU": None, "Div-N": None, "pairs": 0}
    pts = np.concatenate([np.asarray(s.room.floor, dtype=np.float64) for s in houses[0].rooms if s.room is not None])
    bounds = np.stack([pts.min(axis=0), pts.max(axis=0)])
    maps = [house_occupancy(h, bounds=bounds) for h in houses]
    ious = []
    for a, b in itertools.combinations(maps, 2):
        ious.append(mask_iou(a, b))
    ids = [o.id for o in houses[0].objects]
    arrs = [Arrangement.of(Scene.of_objects(h.objects), ids) for h in houses]
    n = float(np.mean([novelty_distance(a, b) for a, b in itertools.combinations(arrs, 2)]))
    return {"Div-IoU": round(float(np.mean(ious)), 4), "Div-N": round(n, 4), "pairs": len(ious)}


def relation_holds(scene: Scene, rel: Relation, tolerance: float = RELATION_TOLERANCE_M) -> bool:
    """Whether a support relation holds geometrically: a child on the floor stands on it, on the
    ceiling touches it, on a wall is against it; on an object stands over its footprint at most
    ``tolerance`` above its top; inside an object stays inside its box (within ``tolerance``)."""
    child = scene.get(rel.child)
    lo, hi = child.aabb()
    if rel.parent == FLOOR:
        return abs(float(lo[2])) <= tolerance
    if rel.parent == CEILING:
        return scene.room is None or abs(float(hi[2]) - scene.room.ceiling_height) <= tolerance
    kind = scene.anchor_kind(rel.parent)
    if kind == "wall":
        assert scene.room is not None
        return scene.room.wall(rel.parent).gap(child.corners()) <= tolerance
    parent = scene.get(rel.parent)
    plo, phi = parent.aabb()
    if rel.kind == "contain":
        return bool(np.all(lo >= plo - tolerance) and np.all(hi <= phi + tolerance))
    foot = Polygon(convex_hull_2d(child.corners()[:, :2]))
    over = foot.intersection(Polygon(convex_hull_2d(parent.corners()[:, :2]))).area / max(foot.area, 1e-12)
    return bool(over >= 0.5 and float(plo[2]) - tolerance <= float(lo[2]) <= float(phi[2]) + tolerance)


def _kept_as(base: Scene, variant: Scene, rel: Relation) -> Relation:
    """The relation of ``variant`` that stands for ``base``'s ``rel``: a wall piece re-hung with
    its group (``scene.follow_leaders``) is supported by another wall, which the variant's own
    relation names; every other relation is checked as the base states it."""
    if rel.parent in (FLOOR, CEILING) or base.anchor_kind(rel.parent) != "wall":
        return rel
    now = variant.support_of(rel.child)
    if (
        now is not None
        and now.kind == rel.kind
        and now.parent != rel.parent
        and variant.anchor_kind(now.parent) == "wall"
    ):
        return now
    return rel


def relkeep(base: Scene, variant: Scene) -> float:
    """RelKeep: the fraction of ``base``'s attach/contain relations that hold in ``variant`` (a
    wall piece counts as kept on the wall its variant's relation names: ``docs/evolution.md``)."""
    rels = [r for r in base.relations if r.is_support and any(o.id == r.child for o in variant.objects)]
    if not rels:
        return 1.0
    return sum(1 for r in rels if relation_holds(variant, _kept_as(base, variant, r))) / len(rels)



def relkeep_by_kind(base: Scene, variant: Scene) -> dict[str, float | None]:
    """RelKeep per relation kind: ``support`` (:func:`relkeep`) and every functional kind, each
    the fraction of the base's relations of that kind still holding in ``variant`` (``None``
    when the base has none of that kind)."""
    supports = [r for r in base.relations if r.is_support and any(o.id == r.child for o in variant.objects)]
    out: dict[str, float | None] = {"support": round(relkeep(base, variant), 4) if supports else None}
    rels = functional_relations(base)
    for kind in FUNCTIONAL_KINDS:
        mine = [r for r in rels if r.kind == kind]
        out[kind] = round(sum(functional_holds(variant, r) for r in mine) / len(mine), 4) if mine else None
    return out


def relkeep_summary(rows: Sequence[dict[str, float | None]]) -> dict[str, float | None]:
    """The lowest RelKeep of each kind over the variants' ``relkeep_by_kind`` rows."""
    kinds = ("support", *FUNCTIONAL_KINDS)
    out: dict[str, float | None] = {}
    for k in kinds:
        vals = [v for r in rows if (v := r.get(k)) is not None]
        out[k] = min(vals) if vals else None
    return out


def blocked_parts(scene: Scene, base_dir: str | Path | None = None) -> dict[str, list[str]]:
    """The drawers, doors and lids of ``scene`` whose way open for use is not free, by
    ``<object id>/<part>``, each with what stops it (object ids, ``"wall"``): the free-space model
    of ``assets.short_parts`` (``docs/articulation.md``; ``physics.pull_parts`` measures the same in
    MuJoCo on a delivered world)."""
    out: dict[str, list[str]] = {}
    for oid, names in sorted(short_parts(scene, base_dir).items()):
        stoppers = part_blockers(scene, oid, base_dir)
        for name in names:
            out[f"{oid}/{name}"] = stoppers.get(name, [])
    return out


def parts_free(scene: Scene, base_dir: str | Path | None = None) -> float:
    """PARTS: the share of the scene's drawers, doors and lids whose way open for use is free
    (:func:`blocked_parts`); 1.0 for a scene with none."""
    total = sum(len(object_articulation(o, base_dir)) for o in scene.objects)
    return 1.0 if total == 0 else 1.0 - len(blocked_parts(scene, base_dir)) / total


def scene_metrics(scene: Scene, base_dir: str | Path | None = None, *, hull_cache: HullCache | None = None) -> dict[str, float]:
    """COL, OOB and NAV of one scene (fractions; NAV 1.0 is one connected walkable floor), PLAUS,
    the lowest of its plausibility figures (``metrics.plausibility``; 1.0: every rule met), and PARTS,
    the share of its parts free to open (:func:`parts_free`)."""
    return {
        "COL": round(col(scene, base_dir, hull_cache=hull_cache), 4),
        "OOB": round(oob(scene, base_dir), 4),
        "NAV": round(nav(scene), 4),
        "PLAUS": min(plausibility(scene).values()),
        "PARTS": round(parts_free(scene, base_dir), 4),
    }


def evaluate_scenes(base: Scene, variants: Sequence[Scene] = (), *, base_dir: str | Path | None = None,
             variant_dirs: Sequence[str | Path | None] = (), hull_cache: HullCache | None = None) -> dict[str, object]:
    """Every metric of a base scene and its variants, JSON-ready (:func:`~scenemosaic.metrics.evaluate`
    of a room's scene).

    The semantic judge (POS, ROT) needs a vision model and is reported as not measured here.
    """
    dirs = list(variant_dirs) or [None] * len(variants)
    out: dict[str, object] = {
        "base": {
            **scene_metrics(base, base_dir, hull_cache=hull_cache), "parts_blocked": blocked_parts(base, base_dir),
            "windows_blocked": blocked_windows(base), "screens_behind": [list(p) for p in screens_behind(base)],
        }
    }  # fmt: skip
    kinds = [relkeep_by_kind(base, v) for v in variants]
    out["variants"] = [
        {
            **scene_metrics(v, d, hull_cache=hull_cache), "RelKeep": round(relkeep(base, v), 4), "RelKeep_by_kind": k,
            "parts_blocked": blocked_parts(v, d), "windows_blocked": blocked_windows(v),
            "screens_behind": [list(p) for p in screens_behind(v)],
        }
        for v, d, k in zip(variants, dirs, kinds, strict=True)
    ]  # fmt: skip
    if variants:
        out["RelKeep_by_kind"] = relkeep_summary(kinds)
        iou, n = div_iou(list(variants)), div_n(list(variants))
        out["diversity"] = {
            "Div-IoU": None if iou is None else round(iou, 4),
            "Div-N": None if n is None else round(n, 4),
            "pairs": len(variants) * (len(variants) - 1) // 2,
        }
    out["semantic_judge"] = {"POS": None, "ROT": None, "note": "not measured: the judge needs a vision model"}
    return out

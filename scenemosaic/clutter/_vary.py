"""``vary``: a variant's small objects on other receptacles, in other numbers, sometimes other assets.

A scene's **small objects** are those a clutter pass added (its metadata's record) and the
source's own loose small things: an object whose type the clutter priors draw (a book, a mug, a
plate), resting on or in a standing piece of furniture the priors know as a receptacle, holding
nothing, not fixed.

:func:`vary_scene` takes them all off their receptacles and puts them back, seeded:

* each moves, with probability :data:`MOVE_SHARE`, to another receptacle of the room whose type
  ProcTHOR found its type on (``receptacles.json``), drawn with the priors' weights; else it stays
  on its own receptacle, at a new place;
* given the scenes of the same room already delivered (``shown``: the base and earlier variants),
  the places are planned instead, object by object, so that the new scene differs from each of them
  in the receptacle, then the surface (:func:`resting_place`), of as many small objects as it
  can: an object goes where it most raises the least of those counts, ties drawn with the priors'
  weights; see ``docs/clutter.md``;
* no receptacle takes more than the most the source holds on one receptacle (at least one): the
  counts per receptacle change within the source's range, and the total stays;
* with probability :data:`SWAP_SHARE` its asset is swapped for another database asset of the same
  type whose every side is within :data:`SWAP_SIZE_RATIO` of its own;
* it is placed with the fill's placement (``scene.pack_surface`` on the receptacle's surfaces,
  settled as a unit, the rest check); one that finds no place goes back where it was; one moved
  that does not rest is placed again on its own surface first, then on the new one, and one that
  still does not rest is dropped (reported).

:func:`carry_clutter` carries a base scene's added objects onto a variant whose furniture moved,
each rigidly with its receptacle. :func:`clutter_distance` says how differently two scenes place
their small objects, the term that joins the novelty distance when clutter varies.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
import structlog

from scenemosaic.assets import HullCache
from scenemosaic.clutter._fill import (
    CLUTTER_METADATA,
    DROP_GAP_M,
    ClutterReport,
    _asset_of,
    _keep_resting,
    _occupied,
    _receptacles,
    _seed,
    _settle,
    clutter_ids,
    place_on_surface,
    remove_objects,
)
from scenemosaic.clutter._priors import ClutterAsset, ClutterPriors
from scenemosaic.clutter._rest import rest_check
from scenemosaic.clutter._surfaces import Surface, receptacle_surfaces
from scenemosaic.physics import ObjectShape, object_shape
from scenemosaic.scene import (
    AssetRef,
    Pose,
    Scene,
    SimAttributes,
    build_structure,
    quat_from_matrix,
)

__all__ = [
    "MOVE_SHARE",
    "SWAP_SHARE",
    "SWAP_SIZE_RATIO",
    "carry_clutter",
    "clutter_distance",
    "resting_place",
    "small_objects",
    "vary_scene",
]

log = structlog.get_logger(__name__)

MOVE_SHARE = 0.7
"""Chance that a small object moves to another receptacle in a ``vary`` pass."""
SWAP_SHARE = 0.25
"""Chance that a small object's asset is swapped for a similar one of its type."""
SWAP_SIZE_RATIO = 0.25
"""A swap keeps every side of the box within this share of the old one (similar size)."""
PLAN_TRIES = 6
"""A planned pass (``shown`` given) tries an object's best this many surfaces, then its own
receptacle's, then the rest."""
CLUTTER_SPAN_M = 0.3
"""In :func:`clutter_distance`, a move on the same receptacle this long (metres) counts as much
as a move to another receptacle."""


def small_objects(scene: Scene, priors: ClutterPriors) -> list[str]:
    """The scene's small objects (see the module docstring), in scene order."""
    added = set(clutter_ids(scene))
    holders = {r.parent for r in scene.relations if r.is_support}
    homes = {r for r, _ in _receptacles(scene, priors)}  # receptacles that stand (not hung)
    out = []
    for obj in scene.objects:
        if obj.id in added:
            out.append(obj.id)
            continue
        rel = scene.support_of(obj.id)
        if rel is None or obj.sim.static or obj.id in holders or scene.anchor_kind(rel.parent) != "object":
            continue
        t = priors.object_type(obj.category)
        if t is not None and t in priors.assets and rel.parent in homes:
            out.append(obj.id)
    return out


SURFACE_STEP_M = 0.05
"""Resting heights closer than this count as one level of a receptacle (:func:`resting_place`)."""


def resting_place(scene: Scene, oid: str) -> tuple[str | None, str | None, int]:
    """Where an object rests: its receptacle, on or in it (the support relation's kind) and the
    level (its bottom's height in steps of :data:`SURFACE_STEP_M`): a counter's top and each of its
    shelves or drawer levels apart, as ProcTHOR counts a ``CounterTop`` and its ``Cabinet`` and
    ``Drawer`` receptacles apart. Two scenes place an object on another receptacle when this
    differs."""
    rel = scene.support_of(oid)
    z = float(scene.get(oid).pose.position[2])
    return (rel.parent if rel else None, rel.kind if rel else None, round(z / SURFACE_STEP_M))


def _place_of(surface: Surface) -> tuple[str, str, int]:
    """:func:`resting_place` of an object put on ``surface`` (as :func:`_relocate` puts it)."""
    kind = surface.support_relation("_").kind
    return (surface.receptacle, kind, round((surface.height + DROP_GAP_M) / SURFACE_STEP_M))


def _surface_of(scene: Scene, oid: str, found: Sequence[Surface]) -> Surface | None:
    """Which of ``found`` (its receptacle's surfaces) ``oid`` rests on: the one of its relation's
    kind whose height is nearest its bottom (``None`` when there is none)."""
    rel = scene.support_of(oid)
    z = float(scene.get(oid).pose.position[2])
    fits = [sf for sf in found if rel is not None and sf.support_relation(oid).kind == rel.kind]
    return min(fits, key=lambda sf: abs(sf.height - z)) if fits else None


def _swap(asset: ClutterAsset, priors: ClutterPriors, rng: np.random.Generator) -> ClutterAsset | None:
    similar = [
        a
        for a in priors.assets.get(asset.object_type, ())
        if a.asset_id != asset.asset_id
        and all(abs(x - y) <= SWAP_SIZE_RATIO * y for x, y in zip(a.size, asset.size, strict=True))
    ]
    return similar[int(rng.integers(0, len(similar)))] if similar else None


def _relocate(
    scene: Scene, oid: str, receptacle: str, surface: Surface, xy: tuple[float, float], yaw: float
) -> None:
    """Put ``oid`` on ``surface`` of ``receptacle``: its pose and its support relation (other
    relations naming it as a child of its old receptacle go)."""
    obj = scene.get(oid)
    obj.pose = Pose.from_yaw((xy[0], xy[1], surface.height + DROP_GAP_M), yaw, obj.pose.scale)
    _rehome(scene, oid, surface)


def _rehome(scene: Scene, oid: str, surface: Surface) -> None:
    """Make ``surface`` the support of ``oid`` (other relations naming it as a child of its old
    receptacle go)."""
    old = scene.support_of(oid)
    scene.relations = [
        r
        for r in scene.relations
        if not (r.child == oid and (r.is_support or (old is not None and r.parent == old.parent)))
    ]
    scene.relations.append(surface.support_relation(oid))


def _with_asset(scene: Scene, oid: str, asset: ClutterAsset) -> None:
    obj = scene.get(oid)
    obj.asset = AssetRef(kind="procedural", category=asset.category, extents=asset.size)
    obj.pose = obj.pose.model_copy(update={"scale": (1.0, 1.0, 1.0)})
    obj.description = f"{asset.category.replace('_', ' ')} (AI2-THOR asset {asset.asset_id})"
    obj.sim = SimAttributes(
        mass_kg=asset.mass_kg(), friction=asset.friction(), static=False,
        source=f"clutter: asset database {asset.asset_id}, attributes table",
    )  # fmt: skip


def vary_scene(
    scene: Scene,
    *,
    priors: ClutterPriors,
    seed: int,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
    shown: Sequence[Scene] = (),
) -> tuple[Scene, ClutterReport]:
    """A copy of ``scene`` with its small objects moved, recounted and swapped (module docstring);
    with ``shown`` (other scenes of the same room), planned to differ from each of them in where
    as many small objects rest as it can."""
    t0 = time.perf_counter()
    out = scene.model_copy(deep=True)
    report = ClutterReport(mode="vary")
    small = small_objects(out, priors)
    if not small:
        return out, report
    rng = np.random.default_rng(_seed(seed, "vary"))
    shapes: dict[str, ObjectShape] = {o.id: object_shape(o, base_dir, cache=hull_cache) for o in out.objects}
    # a small object is no receptacle here (a plate moved later would leave what it held in the air)
    receptacles = {r: t for r, t in _receptacles(out, priors) if r not in set(small)}
    home = {oid: out.support_of(oid).parent for oid in small}  # type: ignore[union-attr]
    counts: dict[str, int] = {}
    for parent in home.values():
        counts[parent] = counts.get(parent, 0) + 1
    most = max(counts.values(), default=1)
    gone: set[str] = set()
    surfaces = {r: receptacle_surfaces(out, r, shapes) for r in receptacles}
    taken: dict[str, list[np.ndarray]] = {}
    for found in surfaces.values():
        for surface in found:
            taken[surface.key] = _occupied(out, surface, skip=set(small))
    load = dict.fromkeys(receptacles, 0)
    record = out.metadata.setdefault(CLUTTER_METADATA, {"objects": {}})
    record.setdefault("objects", {})
    placed: dict[str, Surface] = {}
    # largest first (as the packing orders a surface), ties in a seeded order; a planned pass
    # first places the objects with the fewest receptacles their type may use (the most
    # constrained, before the others fill those receptacles)
    shuffled = [small[i] for i in rng.permutation(len(small))]

    def choices(oid: str) -> int:
        t = priors.object_type(out.get(oid).category)
        return sum(1 for rt in receptacles.values() if t is not None and priors.allows(t, rt)) if shown else 0

    order = sorted(shuffled, key=lambda oid: (choices(oid), -float(np.prod(out.get(oid).size[:2]))))
    # places held for the objects still to come back to their own receptacle: newcomers never
    # push a receptacle past the most the source holds on one
    pending = dict.fromkeys(receptacles, 0)
    for oid in small:
        pending[home[oid]] = pending.get(home[oid], 0) + 1

    def has_room(r: str) -> bool:
        return load.get(r, 0) + pending.get(r, 0) < most

    # where each small object rests in the scene given: a moved one that does not rest goes back
    resting_on = {oid: _surface_of(out, oid, surfaces.get(home[oid], ())) for oid in small}
    plan = _Plan(shown, small) if shown else None
    for oid in order:
        pending[home[oid]] -= 1
        asset = _asset_of(out, oid, priors)
        if asset is None:
            continue
        swapped = _swap(asset, priors, rng) if rng.random() < SWAP_SHARE else None
        use = swapped or asset
        allowed = [
            (r, priors.held[t].get(use.object_type, 0.0))
            for r, t in sorted(receptacles.items())
            if r != home[oid] and priors.allows(use.object_type, t) and has_room(r)
        ]
        if plan is not None:
            at_home = priors.held.get(receptacles.get(home[oid], ""), {}).get(use.object_type, 0.0)
            options = [(sf, w) for r, w in [(home[oid], at_home), *allowed] for sf in surfaces.get(r, ())]
            ranked = plan.order(oid, options, rng)
            # the best few, then its own receptacle's surfaces, then the others
            later = ranked[PLAN_TRIES:]
            tries: Iterable[Surface] = [
                *ranked[:PLAN_TRIES],
                *(sf for sf in later if sf.receptacle == home[oid]),
                *(sf for sf in later if sf.receptacle != home[oid]),
            ]
        else:
            targets = [home[oid]]
            if rng.random() < MOVE_SHARE and allowed:
                weights = np.array([w for _, w in allowed])
                targets = [allowed[int(rng.choice(len(allowed), p=weights / weights.sum()))][0], home[oid]]
            # drawn lazily, as each receptacle's surfaces are reached
            tries = (surfaces[r][int(k)] for r in targets if r in surfaces for k in rng.permutation(len(surfaces[r])))
        spot = None
        for surface in tries:
            spot = place_on_surface(out, surface, use, rng, taken[surface.key])
            if spot is not None:
                break
        if plan is not None and spot is not None:
            plan.placed(oid, surface)
        if spot is None:  # no free place, not even on its own receptacle: it goes (reported)
            gone.add(oid)
            report.dropped[oid] = "no free place on a receptacle its type may use"
            continue
        if swapped is not None:
            _with_asset(out, oid, swapped)
            shapes[oid] = object_shape(out.get(oid), base_dir, cache=hull_cache)
            report.swapped.append(oid)
        (xy, yaw) = spot
        _relocate(out, oid, surface.receptacle, surface, xy, yaw)
        load[surface.receptacle] += 1
        placed[oid] = surface
        if surface.receptacle != home[oid]:
            report.moved.append(oid)
        record["objects"][oid] = {
            "asset_id": use.asset_id,
            "receptacle": surface.receptacle,
            "placement": surface.placement,
        }
        report.added.setdefault(surface.receptacle, []).append(oid)
    remove_objects(out, gone)
    for r in sorted(report.added):
        _settle(out, r, report.added[r], shapes, _seed(seed, "vary-settle", r))

    def back_home(oid: str, surface: Surface) -> None:  # a moved object that did not rest, put back
        _rehome(out, oid, surface)
        record["objects"][oid].update(receptacle=surface.receptacle, placement=surface.placement)
        if oid in report.moved and surface.receptacle == home[oid]:
            report.moved.remove(oid)

    back = {
        oid: mine for oid, there in placed.items() if (mine := resting_on.get(oid)) is not None and mine.key != there.key
    }
    _keep_resting(out, report, placed, shapes, priors, seed, base_dir, hull_cache, back=back, moved=back_home)
    report.added = {}  # nothing was added: the objects moved
    record["mode"] = "vary"
    if out.structure is not None:
        out.structure = build_structure(out)
    report.moved.sort()
    report.swapped.sort()
    report.seconds = time.perf_counter() - t0
    log.info(
        "clutter_varied",
        scene=out.id,
        moved=len(report.moved),
        swapped=len(report.swapped),
        dropped=len(report.dropped),
    )
    return out, report


class _Plan:
    """Where a ``vary`` pass puts each small object so that the new scene differs from every scene
    already ``shown`` in where as many of them rest as it can.

    Two counts per shown scene ``u``: the objects placed so far on another receptacle than in ``u``
    (``differ[0, u]``), and those on another surface (``differ[1, u]``: another receptacle or
    another level of the same one, :func:`resting_place`). An object's surfaces are tried best
    first: the one that raises the sorted receptacle counts most (lexicographically, the least
    count first: a greedy max-min), then the sorted surface counts, then a draw weighted by the
    priors (how often ProcTHOR found the type on the receptacle's type)."""

    def __init__(self, shown: Sequence[Scene], small: Sequence[str]) -> None:
        ids = [{o.id for o in s.objects} for s in shown]
        self.before: dict[str, list[tuple[str | None, str | None, int] | None]] = {
            oid: [resting_place(s, oid) if oid in present else None for s, present in zip(shown, ids, strict=True)]
            for oid in small
        }
        self.differ = np.zeros((2, len(shown)), dtype=int)

    def _gains(self, oid: str, surface: Surface) -> np.ndarray:
        here = _place_of(surface)
        before = self.before[oid]
        return np.array(
            [[b is not None and b[0] != here[0] for b in before], [b is not None and b != here for b in before]],
            dtype=int,
        )

    def order(self, oid: str, options: Sequence[tuple[Surface, float]], rng: np.random.Generator) -> list[Surface]:
        """``options`` (surface, priors' weight) best first (class docstring)."""
        keyed = []
        for k, (surface, weight) in enumerate(options):
            after = np.sort(self.differ + self._gains(oid, surface), axis=1)
            # a draw weighted by the priors: the largest of u ** (1 / w) comes first
            draw = float(rng.random()) ** (1.0 / max(weight, 1e-6))
            keyed.append((tuple(after[0]), tuple(after[1]), draw, -k))
        ranked = sorted(range(len(options)), key=lambda k: keyed[k], reverse=True)
        return [options[k][0] for k in ranked]

    def placed(self, oid: str, surface: Surface) -> None:
        """Count ``oid`` put on ``surface``."""
        self.differ += self._gains(oid, surface)


def carry_clutter(
    base: Scene,
    variant: Scene,
    *,
    priors: ClutterPriors,
    seed: int,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
) -> tuple[Scene, ClutterReport]:
    """A copy of ``variant`` holding the objects ``base``'s clutter pass added, each moved rigidly
    with its receptacle (the receptacle's pose in the variant times its inverse in the base); one
    that then interpenetrates or does not rest is dropped (reported)."""
    t0 = time.perf_counter()
    out = variant.model_copy(deep=True)
    report = ClutterReport(mode="carry")
    record = base.metadata.get(CLUTTER_METADATA) or {}
    ids = clutter_ids(base)
    present = {o.id for o in out.objects}
    kept: list[str] = []
    entries = out.metadata.setdefault(CLUTTER_METADATA, {"objects": {}})
    entries.setdefault("objects", {})
    for oid in ids:
        if oid in present:
            continue  # the variant has it already (composed with its unit)
        entry = record["objects"][oid]
        receptacle = entry["receptacle"]
        if receptacle not in present:
            continue
        obj = base.get(oid).model_copy(deep=True)
        move = out.get(receptacle).pose.matrix(with_scale=False) @ np.linalg.inv(
            base.get(receptacle).pose.matrix(with_scale=False)
        )
        m = move @ obj.pose.matrix(with_scale=False)
        obj.pose = Pose(
            position=(float(m[0, 3]), float(m[1, 3]), float(m[2, 3])),
            quaternion=quat_from_matrix(m[:3, :3]),
            scale=obj.pose.scale,
        )
        out.objects.append(obj)
        out.relations.extend(r.model_copy() for r in base.relations if r.child == oid)
        entries["objects"][oid] = dict(entry)
        kept.append(oid)
    if kept:
        shapes = {o.id: object_shape(o, base_dir, cache=hull_cache) for o in out.objects}
        failed = rest_check(out, kept, shapes, base_dir=base_dir, hull_cache=hull_cache)
        report.dropped = {oid: "did not rest on the variant's furniture" for oid in sorted(failed)}
        remove_objects(out, failed)
        report.checked, report.stable = len(kept), len(kept) - len(failed)
    entries["mode"] = record.get("mode", "fill")
    if out.structure is not None:
        out.structure = build_structure(out)
    report.seconds = time.perf_counter() - t0
    del seed
    return out, report


def clutter_distance(a: Scene, b: Scene, ids: Sequence[str] | None = None) -> float:
    """How differently ``b`` places the small objects ``ids`` (default: those of ``a`` present in
    both) than ``a``, in [0, 1]: per object 1 when its receptacle differs, else its move in the
    receptacle's frame over :data:`CLUTTER_SPAN_M` (at most 1), plus a quarter for an asset swapped
    (at most 1 in all); the mean over the objects (0 when there are none)."""
    present = {o.id for o in b.objects}
    chosen = [
        i
        for i in (ids if ids is not None else clutter_ids(a))
        if i in present and any(o.id == i for o in a.objects)
    ]
    if not chosen:
        return 0.0
    total = 0.0
    for oid in chosen:
        ra, rb = a.support_of(oid), b.support_of(oid)
        if ra is None or rb is None or ra.parent != rb.parent:
            total += 1.0
            continue
        term = 0.0
        if a.anchor_kind(ra.parent) == "object":
            la = np.linalg.inv(a.get(ra.parent).pose.matrix(with_scale=False)) @ a.get(oid).pose.matrix(
                with_scale=False
            )
            lb = np.linalg.inv(b.get(rb.parent).pose.matrix(with_scale=False)) @ b.get(oid).pose.matrix(
                with_scale=False
            )
            term = min(1.0, float(np.linalg.norm(la[:2, 3] - lb[:2, 3])) / CLUTTER_SPAN_M)
        if a.get(oid).asset.extents != b.get(oid).asset.extents:
            term += 0.25
        total += min(1.0, term)
    return total / len(chosen)

"""Whole-scene variants from unit variants: local filtering, grafting, the pool, checks, selection.

* **Local filtering** — every evolved unit layout was validated alone after its final settle; a
  variant (not the refined original) with a collision, an object out of bounds or a broken rule
  is dropped and counted.
* **Groups** — each room-level unit (floor, wall, ceiling) with the object units below it. A
  group's variants are the product of its units' kept layouts, composed top-down in their
  anchors' frames (``with_unit_layout``: a table-top layout follows its table wherever the floor
  variant puts it).
* **Followers** — a lamp hanging over a group, a rug under one, a picture or wall TV above one
  (``scene.functional_relations``: ``over``/``under``) composes with that group: in each of the
  group's variants it moves as the group's leader moved (``scene.follow_leaders``), whatever its
  own unit's variants did; a variant it cannot follow into (its group turned away from its wall,
  or the moved piece would leave the room) is not valid.
* **Scene-level check** — a candidate is valid when every group variant it uses is free of
  interpenetration inside the group, and every pair of group variants it uses is free of it
  across the pair; each result is computed when the selection first reaches a candidate that
  needs it and cached, so candidates sharing group variants share the checks.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import structlog

from scenemosaic.compose._distance import Arrangement, novelty_distance
from scenemosaic.compose._pool import (
    ALPHA,
    MIN_NOVELTY,
    CandidatePool,
    GroupVariants,
    Selection,
    Veto,
    select_diverse,
)
from scenemosaic.evolve import EvolutionReport
from scenemosaic.physics import ObjectShape, collision_report_for
from scenemosaic.scene import (
    FloorRaster,
    Functional,
    LocalUnit,
    Pose,
    Scene,
    SceneObject,
    build_structure,
    convex_hull_2d,
    descendants,
    follow_leaders,
    functional_relations,
    is_thin,
    with_unit_layout,
)

__all__ = ["HOUSE_MAX_CANDIDATES", "OCCUPANCY_GRID", "CompositionReport", "UnitLayouts", "compose_house", "compose_variants", "kept_layouts"]

log = structlog.get_logger(__name__)

OCCUPANCY_GRID = 64
"""Cells along the floor's longer side of the occupancy raster of a room's selection."""
HOUSE_MAX_CANDIDATES = 200_000
"""Candidates a house's selection scores (a seeded uniform sample of its pool): six arrangements
in each of ten rooms make 6^10 (6 x 10^7) houses."""


@dataclass(frozen=True)
class UnitLayouts:
    """One unit's evolved layouts in its anchor's frame: the refined original first."""

    anchor_id: str
    layout_ids: tuple[str, ...]
    poses: tuple[Mapping[str, Pose], ...]


def kept_layouts(evolution: EvolutionReport) -> tuple[dict[str, UnitLayouts], list[str]]:
    """Local filtering: each unit's layouts that composition may use, and the dropped ones.

    A unit's refined original is always kept, first; its variants follow in layout-id order,
    except those that did not come out valid alone (an error, a collision or an object out of
    bounds after the final settle, a broken rule), which are listed as ``unit/layout: why``.
    """
    kept: dict[str, UnitLayouts] = {}
    dropped: list[str] = []
    for unit in sorted(evolution.units, key=lambda u: u.anchor_id):
        ids, poses = [unit.original.layout_id], [dict(unit.original.local_poses)]
        for lay in sorted(unit.variants, key=lambda v: v.layout_id):
            if lay.error or not lay.valid or lay.violations:
                why = lay.error or "; ".join(lay.violations) or "not valid"
                dropped.append(f"{unit.anchor_id}/{lay.layout_id}: {why[:120]}")
                continue
            ids.append(lay.layout_id)
            poses.append(dict(lay.local_poses))
        kept[unit.anchor_id] = UnitLayouts(unit.anchor_id, tuple(ids), tuple(poses))
    return kept, dropped


@dataclass
class CompositionReport:
    """What composition and selection did, for ``report.json``."""

    dropped: list[str] = field(default_factory=list)
    """Unit variants dropped by local filtering (``anchor/layout: why``)."""
    groups: dict[str, int] = field(default_factory=dict)
    """Variants per group."""
    pool_size: int = 0
    considered: int = 0
    sampled: bool = False
    picked: list[dict[str, str]] = field(default_factory=list)
    """Per selected variant: the layout chosen for each unit."""
    min_distances: list[float] = field(default_factory=list)
    rejected: int = 0
    """Candidates turned down when the selection reached them (interpenetration or ``accept``)."""
    not_accepted: int = 0
    """Of those, the ones ``accept`` turned down."""
    rooms_respread: int = 0
    """House variants in which a room took an arrangement no earlier variant had given it
    (``compose_house``'s spreading of each room's arrangements)."""
    pruned: int = 0
    near_copies: int = 0
    """Candidates never selected for lying within ``MIN_NOVELTY`` of a selected scene."""
    checks: int = 0
    """Scene-level interpenetration checks run (cached ones counted once)."""
    wall_s: float = 0.0

    def summary(self) -> dict[str, Any]:
        return {
            "dropped_unit_variants": self.dropped,
            "group_variants": self.groups,
            "pool_size": str(self.pool_size) if self.pool_size > 2**53 else self.pool_size,
            "considered": self.considered,
            "sampled": self.sampled,
            "selected": self.picked,
            "min_distances": [round(d, 4) for d in self.min_distances],
            "rejected_by_scene_check": self.rejected,
            "rejected_by_accept": self.not_accepted,
            "pruned": self.pruned,
            "near_copies": self.near_copies,
            "rooms_respread": self.rooms_respread,
            "scene_checks": self.checks,
            "wall_s": round(self.wall_s, 3),
        }


def _groups(scene: Scene, units: Sequence[LocalUnit]) -> list[tuple[str, list[LocalUnit], list[str]]]:
    """(name, units top-down, object ids) per room-level unit with its object units below."""
    out = []
    for root in (u for u in units if u.anchor_kind != "object"):
        objects = [*root.children, *(d for c in root.children for d in descendants(scene, c))]
        members = [root, *(u for u in units if u.anchor_kind == "object" and u.anchor_id in objects)]
        out.append((root.anchor_id, members, objects))
    return out


def _followers(scene: Scene, groups: Sequence[tuple[str, list[LocalUnit], list[str]]]) -> tuple[list[Functional], dict[str, int]]:
    """The pieces that hang over or lie under a group (``scene.functional_relations``: ``over``
    and ``under``), and the group index of every object. Each such piece composes with its
    leader's group: its pose follows the leader in every variant of that group."""
    owner = {oid: g for g, (_name, _members, objects) in enumerate(groups) for oid in objects}
    rels = [r for r in functional_relations(scene) if r.follows and r.subject in owner and r.leader in owner]
    return rels, owner


class _Composer:
    """One scene's groups, their variants and the cached scene-level checks of its candidates."""

    def __init__(
        self,
        scene: Scene,
        layouts: Mapping[str, UnitLayouts],
        shapes: Mapping[str, ObjectShape],
        report: CompositionReport,
        accept: Callable[[Scene], bool] | None,
    ) -> None:
        self.scene, self.layouts, self.shapes, self.report, self.accept = scene, layouts, shapes, report, accept
        self.groups: list[GroupVariants] = []
        self.group_scenes: list[list[Scene]] = []
        self.group_labels: list[list[dict[str, str]]] = []
        self.own_cache: dict[tuple[int, int], bool] = {}
        self.pair_cache: dict[tuple[int, int, int, int], bool] = {}
        self.verdicts: dict[tuple[int, ...], bool | Veto] = {}
        self.built: dict[tuple[tuple[str, int], ...], Scene] = {}
        """Scenes :meth:`build` made, by the unit layouts applied to the base in order (never modified)."""
        units = list((scene.structure or build_structure(scene)).units)
        groups = _groups(scene, units)
        self.followers, owner = _followers(scene, groups)
        self.failed: set[tuple[int, int]] = set()
        for g, (name, members, objects) in enumerate(groups):
            led = [r for r in self.followers if owner[r.leader] == g]
            objects = [o for o in objects if o not in {r.subject for r in self.followers}] + [r.subject for r in led]
            options = [layouts.get(u.anchor_id) for u in members]
            ranges = [range(len(o.layout_ids)) if o is not None else range(1) for o in options]
            scenes: list[Scene] = []
            labels: list[dict[str, str]] = []
            prefixes: dict[tuple[int, ...], Scene] = {(): scene}  # combinations share their first units' layouts
            for combo in itertools.product(*ranges):
                s = scene
                label: dict[str, str] = {}
                for i, (u, o, k) in enumerate(zip(members, options, combo, strict=True)):
                    if o is None:
                        continue
                    label[u.anchor_id] = o.layout_ids[k]
                    if k:  # the refined original is in place already
                        known = prefixes.get(combo[: i + 1])
                        if known is None:
                            known = prefixes[combo[: i + 1]] = with_unit_layout(s, u.anchor_id, o.poses[k])
                        s = known
                followed = follow_leaders(scene, s, led) if led else s
                if followed is None:  # a lamp, rug or picture that cannot follow its group here
                    self.failed.add((g, len(scenes)))
                    followed = s
                scenes.append(followed)
                labels.append(label)
            arrs = [Arrangement.of(s, objects) for s in scenes]
            self.groups.append(
                GroupVariants(
                    name, tuple(objects), np.stack([a.positions for a in arrs]), np.stack([a.rotations for a in arrs]),
                    np.stack([a.quaternions for a in arrs]), tuple(",".join(f"{k}:{v}" for k, v in lab.items()) for lab in labels),
                )
            )  # fmt: skip
            self.group_scenes.append(scenes)
            self.group_labels.append(labels)
        self.raster = FloorRaster(np.asarray(scene.room.floor), cell=max(np.ptp(np.asarray(scene.room.floor), axis=0)) / OCCUPANCY_GRID) if scene.room else None

    def occupancy(self) -> list[np.ndarray] | None:
        """Per group, each variant's packed top-down occupancy (its non-thin objects' boxes on
        an ``OCCUPANCY_GRID`` raster of the floor): the footprint term of the selection."""
        if self.raster is None:
            return None
        raster = self.raster
        # a group's variants combine its units' layouts: a piece takes the same pose in many of
        # them, and its cells are worked out once per pose
        cells: dict[tuple[object, ...], np.ndarray] = {}

        def footprint(o: SceneObject) -> np.ndarray:
            key = (o.id, o.pose.position, o.pose.quaternion, o.pose.scale)
            known = cells.get(key)
            if known is None:
                known = cells[key] = raster.mask(convex_hull_2d(o.corners()[:, :2]))
            return known

        out = []
        for g, scenes in enumerate(self.group_scenes):
            rows = []
            for s in scenes:
                mask = np.zeros(raster.shape, dtype=bool)
                for oid in self.groups[g].ids:
                    o = s.get(oid)
                    if not is_thin(o):
                        mask |= footprint(o)
                rows.append(np.packbits(mask.ravel()))
            out.append(np.stack(rows))
        return out

    def _clean(self, objs: list[Any], split: set[str] | None) -> bool:
        self.report.checks += 1
        world = Scene.of_objects(objs)
        return not collision_report_for(world, self.shapes, across=split).pairs

    def _group_objects(self, g: int, k: int) -> list[Any]:
        s = self.group_scenes[g][k]
        return [s.get(i) for i in self.groups[g].ids]

    def valid(self, choice: tuple[int, ...], offset: int = 0) -> bool | Veto:
        """Whether a candidate (one variant per group) is free of interpenetration and accepted;
        when not, the :data:`Veto` that condemns it (its groups numbered from ``offset``: this
        scene's place among a house's groups). Each answer is kept: candidates share arrangements."""
        known = self.verdicts.get(choice)
        if known is None:
            known = self.verdicts[choice] = self._valid(choice)
        if isinstance(known, bool) or not offset:
            return known
        return tuple((g + offset, k) for g, k in known)

    def _valid(self, choice: tuple[int, ...]) -> bool | Veto:
        for g, k in enumerate(choice):
            if (g, k) in self.failed:
                return ((g, k),)
            if (g, k) not in self.own_cache:
                self.own_cache[(g, k)] = self._clean(self._group_objects(g, k), None) if k else True  # the base is validated
            if not self.own_cache[(g, k)]:
                return ((g, k),)
        for g, h in itertools.combinations(range(len(choice)), 2):
            key = (g, choice[g], h, choice[h])
            if key not in self.pair_cache:
                if choice[g] == 0 and choice[h] == 0:
                    self.pair_cache[key] = True
                else:
                    a, b = self._group_objects(g, choice[g]), self._group_objects(h, choice[h])
                    self.pair_cache[key] = self._clean(a + b, {o.id for o in a})
            if not self.pair_cache[key]:
                return ((g, choice[g]), (h, choice[h]))
        if self.accept is not None and not self.accept(self.build(choice)[0]):
            self.report.not_accepted += 1
            return tuple(enumerate(choice))
        return True

    def build(self, choice: tuple[int, ...]) -> tuple[Scene, dict[str, str]]:
        """The candidate's scene and the layout it takes for each unit."""
        s = self.scene
        picked: dict[str, str] = {}
        applied: tuple[tuple[str, int], ...] = ()
        for g, k in enumerate(choice):
            picked.update(self.group_labels[g][k])
            for uid, lid in self.group_labels[g][k].items():
                o = self.layouts[uid]
                idx = o.layout_ids.index(lid)
                if idx:
                    # candidates share their first units' layouts: each such prefix is built once
                    applied += ((uid, idx),)
                    known = self.built.get(applied)
                    if known is None:
                        known = self.built[applied] = with_unit_layout(s, uid, o.poses[idx])
                    s = known
        if self.followers and s is not self.scene:
            s = follow_leaders(self.scene, s, self.followers) or s  # a failed follow was vetoed before
        return (s.model_copy(deep=True) if s is self.scene else s), picked  # never the base itself


def compose_variants(
    scene: Scene,
    layouts: Mapping[str, UnitLayouts],
    shapes: Mapping[str, ObjectShape],
    *,
    m: int = 5,
    alpha: float = ALPHA,
    max_candidates: int | None = None,
    seed: int = 0,
    accept: Callable[[Scene], bool] | None = None,
) -> tuple[list[Scene], CompositionReport]:
    """Select ``m`` diverse whole-scene variants of ``scene`` (the refined base, every unit's
    original in place) from the units' kept layouts; returns them in selection order and the report.

    ``accept`` is a last test of a whole candidate scene, run after the interpenetration checks on
    the candidates the selection reaches (the pipeline passes one that keeps the walkable floor
    connected and the doors clear); a candidate it turns down is skipped like one that
    interpenetrates.
    """
    t0 = time.perf_counter()
    report = CompositionReport()
    composer = _Composer(scene, layouts, shapes, report, accept)
    for g in composer.groups:
        report.groups[g.name] = g.count
    pool = CandidatePool(composer.groups, composer.occupancy())
    report.pool_size = pool.size
    sel: Selection = select_diverse(pool, m, alpha=alpha, valid=composer.valid, max_candidates=max_candidates, seed=seed)
    _selection_figures(report, sel)
    variants: list[Scene] = []
    for choice in sel.picked[1:]:
        s, picked = composer.build(choice)
        variants.append(s)
        report.picked.append(picked)
    report.wall_s = time.perf_counter() - t0
    log.info("variants_composed", pool=report.pool_size, selected=len(variants), checks=report.checks, wall_s=round(report.wall_s, 3))
    return variants, report


def _selection_figures(report: CompositionReport, sel: Selection) -> None:
    report.considered, report.sampled = sel.considered, sel.sampled
    report.rejected, report.pruned = len(sel.rejected) + sel.vetoed, sel.pruned
    report.near_copies = sel.near_copies
    report.min_distances = sel.min_distances[1:]


def _spread_rooms(
    pool: CandidatePool, picked: list[tuple[int, ...]], valid: Callable[[tuple[int, ...]], bool]
) -> list[tuple[int, ...]]:
    """The house variants with each room's arrangements spread over them: where a house variant
    gives a room an arrangement an earlier variant already gave it (the whole-house max-min may,
    when the other rooms make the houses differ), the room takes one no variant has used yet, the
    one farthest from those it has shown, as long as the house stays valid (``valid``: every room
    reachable) and no closer to a selected house than :data:`MIN_NOVELTY`. Every room then shows as
    many different arrangements as it has, and a room's own diversity follows the house's."""
    out = [picked[0]]
    used: list[set[int]] = [{0} for _ in pool.shape]
    for choice in picked[1:]:
        now = list(choice)
        for g, k in enumerate(choice):
            if k not in used[g]:
                continue
            grp = pool.groups[g]
            arr = [Arrangement(grp.positions[j], grp.rotations[j], grp.quaternions[j]) for j in range(grp.count)]
            free = [j for j in range(grp.count) if j not in used[g]]
            ranked = sorted(free, key=lambda j: (-min(novelty_distance(arr[u], arr[j]) for u in used[g]), j))
            others = np.array([*out, *picked[len(out) + 1 :]], dtype=np.int64)
            for j in ranked:
                trial = (*now[:g], j, *now[g + 1 :])
                if float(pool.distances(trial, others).min()) < MIN_NOVELTY:
                    continue
                if valid(trial):
                    now[g] = j
                    break
        for g, k in enumerate(now):
            used[g].add(k)
        out.append(tuple(now))
    return out


def compose_house(
    rooms: Sequence[Scene],
    room_variants: Sequence[Sequence[Scene]],
    *,
    m: int = 5,
    alpha: float = ALPHA,
    max_candidates: int | None = HOUSE_MAX_CANDIDATES,
    seed: int = 0,
    accept: Callable[[list[Scene]], bool] | None = None,
) -> tuple[list[list[Scene]], CompositionReport]:
    """Select ``m`` diverse whole-house variants from each room's valid variants.

    Each room is one group of the candidate pool: its refined base (variant 0) and its own
    variants (``room_variants[i]``, each already valid on its own: composed and checked in the
    room, doors clear), so a candidate is one arrangement per room and the pool, the product over
    the rooms, stays lazy. Rooms are walled apart, so no interpenetration check spans two rooms;
    ``accept`` tests what only the whole house can say (every room reachable from every other); it
    is handed the room scenes themselves (the base's too) and must not change them.
    The novelty distance and the max-min greedy run over all of the house's objects. Returns each
    variant as its room scenes (in ``rooms`` order) and the report (``picked``: the room variant
    each house took, ``"base"`` or ``"variant_<k>"``).
    """
    t0 = time.perf_counter()
    report = CompositionReport()
    groups: list[GroupVariants] = []
    options: list[list[Scene]] = []
    for base, extra in zip(rooms, room_variants, strict=True):
        scenes = [base, *extra]
        ids = [o.id for o in base.objects]
        arrs = [Arrangement.of(s, ids) for s in scenes]
        labels = ("base", *(f"variant_{k}" for k in range(1, len(scenes))))
        groups.append(
            GroupVariants(
                base.id, tuple(ids), np.stack([a.positions for a in arrs]), np.stack([a.rotations for a in arrs]),
                np.stack([a.quaternions for a in arrs]), labels,
            )
        )  # fmt: skip
        options.append(scenes)
        report.groups[base.id] = len(scenes)
    pool = CandidatePool(groups)
    report.pool_size = pool.size

    def build(choice: tuple[int, ...]) -> list[Scene]:
        return [opts[k] if k else opts[0].model_copy(deep=True) for opts, k in zip(options, choice, strict=True)]

    def valid(choice: tuple[int, ...]) -> bool:
        report.checks += 1
        # ``accept`` reads the rooms, it does not change them: no copies (the same room scenes
        # each time also let it keep what it worked out per room arrangement)
        if accept is None or accept([opts[k] for opts, k in zip(options, choice, strict=True)]):
            return True
        report.not_accepted += 1
        return False

    # the method's plain max-min on N: the tie band breaks near ties by footprint, which a house's pool has not
    sel: Selection = select_diverse(pool, m, alpha=alpha, tie_band=0.0, valid=valid, max_candidates=max_candidates, seed=seed)
    _selection_figures(report, sel)
    picked = _spread_rooms(pool, sel.picked, valid)
    report.rooms_respread = sum(a != b for a, b in zip(picked, sel.picked, strict=True))
    variants: list[list[Scene]] = []
    for choice in picked[1:]:
        house = build(choice)
        variants.append([s.model_copy(deep=True) if k else s for s, k in zip(house, choice, strict=True)])
        report.picked.append({g.name: g.labels[k] for g, k in zip(groups, choice, strict=True)})
    report.wall_s = time.perf_counter() - t0
    log.info("house_variants_composed", rooms=len(rooms), pool=report.pool_size, selected=len(variants), wall_s=round(report.wall_s, 3))
    return variants, report

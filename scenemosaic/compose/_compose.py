"""Whole-scene variants from unit variants: local filtering, grafting, the pool, checks, selection.

* **Local filtering** — every evolved unit layout was validated alone after its final settle; a
  variant (not the refined original) with a collision, an object out of bounds or a broken rule
  is dropped and counted.
* **Groups** — each room-level unit (floor, wall, ceiling) with the object units below it. A
  group's variants are the product of its units' kept layouts, composed top-down in their
  anchors' frames (``with_unit_layout``: a table-top layout follows its table wherever the floor
  variant puts it).
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

from scenemosaic.compose._distance import Arrangement
from scenemosaic.compose._pool import ALPHA, CandidatePool, GroupVariants, Selection, select_diverse
from scenemosaic.evolve import EvolutionReport
from scenemosaic.physics import ObjectShape, collision_report_for
from scenemosaic.scene import LocalUnit, Pose, Scene, build_structure, descendants, with_unit_layout

__all__ = ["CompositionReport", "UnitLayouts", "compose_variants", "kept_layouts"]

log = structlog.get_logger(__name__)


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
    pruned: int = 0
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
    connected); a candidate it turns down is skipped like one that interpenetrates.
    """
    t0 = time.perf_counter()
    report = CompositionReport()
    units = list((scene.structure or build_structure(scene)).units)
    groups: list[GroupVariants] = []
    group_scenes: list[list[Scene]] = []
    group_labels: list[list[dict[str, str]]] = []
    for name, members, objects in _groups(scene, units):
        options = [layouts.get(u.anchor_id) for u in members]
        ranges = [range(len(o.layout_ids)) if o is not None else range(1) for o in options]
        scenes: list[Scene] = []
        labels: list[dict[str, str]] = []
        for combo in itertools.product(*ranges):
            s = scene
            label: dict[str, str] = {}
            for u, o, k in zip(members, options, combo, strict=True):
                if o is None:
                    continue
                label[u.anchor_id] = o.layout_ids[k]
                if k:  # the refined original is in place already
                    s = with_unit_layout(s, u.anchor_id, o.poses[k])
            scenes.append(s)
            labels.append(label)
        arrs = [Arrangement.of(s, objects) for s in scenes]
        groups.append(
            GroupVariants(
                name, tuple(objects), np.stack([a.positions for a in arrs]), np.stack([a.rotations for a in arrs]),
                np.stack([a.quaternions for a in arrs]), tuple(",".join(f"{k}:{v}" for k, v in lab.items()) for lab in labels),
            )
        )
        group_scenes.append(scenes)
        group_labels.append(labels)
        report.groups[name] = len(scenes)
    pool = CandidatePool(groups)
    report.pool_size = pool.size

    own_cache: dict[tuple[int, int], bool] = {}
    pair_cache: dict[tuple[int, int, int, int], bool] = {}

    def clean(objs: list[Any], split: set[str] | None) -> bool:
        report.checks += 1
        world = Scene.model_construct(objects=objs)
        pairs = collision_report_for(world, shapes).pairs
        if split is None:
            return not pairs
        return not any((p.a in split) != (p.b in split) for p in pairs)

    def group_objects(g: int, k: int) -> list[Any]:
        s = group_scenes[g][k]
        return [s.get(i) for i in groups[g].ids]

    def valid(choice: tuple[int, ...]) -> bool:
        for g, k in enumerate(choice):
            if (g, k) not in own_cache:
                own_cache[(g, k)] = clean(group_objects(g, k), None) if k else True  # the base is validated
            if not own_cache[(g, k)]:
                return False
        for g, h in itertools.combinations(range(len(choice)), 2):
            key = (g, choice[g], h, choice[h])
            if key not in pair_cache:
                if choice[g] == 0 and choice[h] == 0:
                    pair_cache[key] = True
                else:
                    a, b = group_objects(g, choice[g]), group_objects(h, choice[h])
                    pair_cache[key] = clean(a + b, {o.id for o in a})
            if not pair_cache[key]:
                return False
        if accept is not None and not accept(build(choice)[0]):
            report.not_accepted += 1
            return False
        return True

    def build(choice: tuple[int, ...]) -> tuple[Scene, dict[str, str]]:
        s = scene
        picked: dict[str, str] = {}
        for g, k in enumerate(choice):
            picked.update(group_labels[g][k])
            for uid, lid in group_labels[g][k].items():
                o = layouts[uid]
                idx = o.layout_ids.index(lid)
                if idx:
                    s = with_unit_layout(s, uid, o.poses[idx])
        return s, picked

    sel: Selection = select_diverse(pool, m, alpha=alpha, valid=valid, max_candidates=max_candidates, seed=seed)
    report.considered, report.sampled = sel.considered, sel.sampled
    report.rejected, report.pruned = len(sel.rejected), sel.pruned
    report.min_distances = sel.min_distances[1:]
    variants: list[Scene] = []
    for choice in sel.picked[1:]:
        s, picked = build(choice)
        variants.append(s)
        report.picked.append(picked)
    report.wall_s = time.perf_counter() - t0
    log.info("variants_composed", pool=report.pool_size, selected=len(variants), checks=report.checks, wall_s=round(report.wall_s, 3))
    return variants, report

"""The ``clutter`` stage: small objects filled into the base and carried into, then varied in,
every variant (``--clutter fill|vary``, ``docs/clutter.md``).

It runs after ``compose`` and before ``validate``, and only when the run's ``clutter`` is not
``keep``: the run's plan (``pipeline/_plan.py``) is :data:`~scenemosaic.pipeline.STAGES` itself for ``keep``, so a
run that keeps its clutter runs, records and writes exactly what it did before the setting
existed.

Why there: the receptacles are final only once the variants are composed (a table's top moves
with the table's unit), and validation, the metrics and the export must see the small objects.
Why not earlier (before ``evolve``): every added object would become a child the critic and the
archetype agents reason about, multiplying the evolution's work for objects whose place the
priors, not a layout, decide.

For each variant, :data:`CANDIDATES` seeded ``vary`` passes are made, each planned to differ from
the scenes already chosen (the base and the earlier variants) in where as many small objects rest
as it can, and the one whose clutter differs most from them (the max-min of
``compose.novelty_with_clutter``) is kept, so the selection prefers variants whose small objects
differ.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import time
import zlib
from pathlib import Path
from typing import Any, Literal

from scenemosaic.assets import HullCache
from scenemosaic.clutter import (
    ClutterPriors,
    ClutterReport,
    carry_clutter,
    clutter_distance,
    fill_scene,
    load_clutter_priors,
    remove_objects,
    small_objects,
    vary_scene,
)
from scenemosaic.compose import novelty_with_clutter
from scenemosaic.pipeline._state import PipelineRun, Stage, StageRecord
from scenemosaic.scene import Scene

__all__ = [
    "CANDIDATES",
    "CLUTTER_STAGE",
    "clutter_scenes",
    "vary_house_repeats",
    "vary_repeated_rooms",
]

CANDIDATES = 1
"""Seeded ``vary`` passes made per variant, of which the most novel is kept. One: each pass is
planned against the scenes already chosen (``vary_scene(shown=...)``), which three independent
draws did less well, at three times the cost (``docs/clutter.md``)."""


def _seed(seed: int, *parts: object) -> int:
    return zlib.crc32(":".join(str(p) for p in (seed, *parts)).encode())


def clutter_scenes(
    base: Scene,
    variants: list[Scene],
    *,
    mode: Literal["vary", "fill"],
    density: float,
    priors: ClutterPriors,
    seed: int,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
    id_prefix: str = "",
) -> tuple[Scene, list[Scene], dict[str, Any]]:
    """The base and variants with their clutter filled (``fill``) and varied (both modes), and the
    stage's figures: per scene what was added, moved, swapped and dropped, the rest check's stable
    share, and the diversity of the small objects over the variants (mean pairwise
    ``clutter_distance`` and share of small objects on another receptacle)."""
    t0 = time.perf_counter()
    reports: dict[str, ClutterReport] = {}
    if mode == "fill":
        base, reports["base"] = fill_scene(
            base,
            density=density,
            priors=priors,
            seed=seed,
            base_dir=base_dir,
            hull_cache=hull_cache,
            id_prefix=id_prefix,
        )
    chosen: list[Scene] = [base]
    out: list[Scene] = []
    for i, variant in enumerate(variants, start=1):
        name = f"variant_{i}"
        carried = variant
        dropped: dict[str, str] = {}
        if mode == "fill":
            carried, carry = carry_clutter(
                base, variant, priors=priors, seed=seed, base_dir=base_dir, hull_cache=hull_cache
            )
            dropped = carry.dropped
        small = small_objects(carried, priors)
        best: tuple[float, Scene, ClutterReport] | None = None
        for k in range(CANDIDATES if small else 0):
            scene, report = vary_scene(
                carried, priors=priors, seed=_seed(seed, name, k), base_dir=base_dir, hull_cache=hull_cache,
                shown=chosen,
            )  # fmt: skip
            score = min(novelty_with_clutter(ref, scene, small) for ref in chosen)
            if best is None or score > best[0]:
                best = (score, scene, report)
        if best is None:
            report = ClutterReport(mode="vary")
            picked = carried
        else:
            _, picked, report = best
        report.dropped = {**dropped, **report.dropped}
        reports[name] = report
        chosen.append(picked)
        out.append(picked)
    _same_objects_everywhere(base, out, reports, priors)
    detail: dict[str, Any] = {"mode": mode, "scenes": {k: r.summary() for k, r in reports.items()}}
    detail["added"] = sum(r.added_count for r in reports.values())
    detail["dropped"] = sum(len(r.dropped) for r in reports.values())
    checked = sum(r.checked for r in reports.values())
    detail["stable_share"] = round(sum(r.stable for r in reports.values()) / checked, 4) if checked else 1.0
    detail["small_objects"] = {
        "base": len(small_objects(base, priors)),
        "variants": [len(small_objects(s, priors)) for s in out],
    }
    detail["div_small"] = _diversity(out, priors)
    detail["seconds"] = round(time.perf_counter() - t0, 3)
    return base, out, detail


def vary_repeated_rooms(
    rooms: list[Scene],
    variants: list[list[Scene]],
    picked: list[dict[str, str]],
    *,
    priors: ClutterPriors,
    seed: int,
    base_dir: str | Path | None = None,
    hull_cache: HullCache | None = None,
) -> dict[str, Any]:
    """Vary anew, in place, the small objects of each room a whole-house variant shows as an
    earlier house (the base or an earlier variant) already showed it.

    A house's selection (``compose.compose_house``) picks each room's arrangement among the
    room's base and its own variants, and a room with fewer arrangements than the house has
    variants shows one of them twice: its clutter would repeat with it. Such a repeat gets
    :data:`CANDIDATES` seeded ``vary`` passes and keeps the one that drops fewest small objects,
    then whose least ``compose.novelty_with_clutter`` to the room's scenes shown so far is largest.
    A small object the kept pass dropped leaves the room in the base and every house variant too
    (every scene of a run keeps the same small objects). ``picked`` is the selection's ``picked``
    (per house variant, the room id to ``base`` or ``variant_<k>``). Returns ``varied``: per house
    variant folder name (``variant_<i>``), the rooms varied anew; and ``dropped``: per room, the
    small objects so taken out."""
    varied: dict[str, list[str]] = {}
    dropped: dict[str, list[str]] = {}
    for k, base in enumerate(rooms):
        shown: list[Scene] = [base]
        labels = {"base"}
        for i, house in enumerate(variants, start=1):
            scene = house[k]
            label = picked[i - 1].get(base.id, "")
            small = small_objects(scene, priors)
            if label not in labels or not small:
                labels.add(label)
                shown.append(scene)
                continue
            best: tuple[tuple[int, float], Scene, set[str]] | None = None
            for c in range(CANDIDATES):
                candidate, report = vary_scene(
                    scene, priors=priors, seed=_seed(seed, "house", base.id, i, c), base_dir=base_dir, hull_cache=hull_cache,
                    shown=shown,
                )  # fmt: skip
                kept = [oid for oid in small if oid not in report.dropped]
                score = (-len(report.dropped), min(novelty_with_clutter(ref, candidate, kept) for ref in shown))
                if best is None or score > best[0]:
                    best = (score, candidate, set(report.dropped))
            assert best is not None
            _, chosen, gone = best
            house[k] = chosen
            shown.append(chosen)
            varied.setdefault(f"variant_{i}", []).append(base.id)
            if gone:  # out of the room everywhere: the base's and every house variant's
                for other in [base, *(v[k] for v in variants)]:
                    remove_objects(other, gone & {o.id for o in other.objects})
                dropped.setdefault(base.id, []).extend(sorted(gone))
    return {"varied": varied, "dropped": dropped}


async def vary_house_repeats(
    run: PipelineRun, rooms: list[Scene], variants: list[list[Scene]], picked: list[dict[str, str]]
) -> dict[str, Any]:
    """:func:`vary_repeated_rooms` with the run's settings, off the event loop, when the run's
    ``clutter`` is not ``keep`` (else nothing: a ``keep`` house is composed as before)."""
    cfg = run.config
    if cfg.clutter == "keep":
        return {}
    priors = await asyncio.to_thread(load_clutter_priors, cfg.priors_dir)
    work = functools.partial(
        vary_repeated_rooms, rooms, variants, picked, priors=priors, seed=cfg.seed, base_dir=run.base_dir,
        hull_cache=run.cache(),
    )  # fmt: skip
    return await asyncio.to_thread(work)


def _same_objects_everywhere(
    base: Scene, variants: list[Scene], reports: dict[str, ClutterReport], priors: ClutterPriors
) -> None:
    """A small object one scene dropped goes from every scene: the base and its variants stay
    arrangements of the same objects, as the metrics (RelKeep, Div-N) and the method assume."""
    if not variants:
        return
    scenes = {"base": base, **{f"variant_{i}": v for i, v in enumerate(variants, start=1)}}
    present = {name: {o.id for o in s.objects} for name, s in scenes.items()}
    small = set(small_objects(base, priors)).union(*(small_objects(v, priors) for v in variants))
    everywhere = set.intersection(*present.values())
    for name, scene in scenes.items():
        gone = sorted((small & present[name]) - everywhere)
        if not gone:
            continue
        remove_objects(scene, set(gone))
        report = reports.setdefault(name, ClutterReport(mode="vary"))
        for oid in gone:
            report.dropped.setdefault(
                oid, "dropped from another scene of the run (every scene keeps the same small objects)"
            )
            for ids in report.added.values():
                if oid in ids:
                    ids.remove(oid)
                    report.stable -= 1  # it rested here, but it is not delivered


def _parent(scene: Scene, oid: str) -> str | None:
    rel = scene.support_of(oid)
    return rel.parent if rel is not None else None


def _diversity(variants: list[Scene], priors: ClutterPriors) -> dict[str, float | None]:
    """Over every pair of variants: the mean ``clutter_distance`` of their shared small objects and
    the mean share of those on another receptacle (``None`` with fewer than two variants)."""
    distances, moved = [], []
    for a, b in itertools.combinations(variants, 2):
        shared = [oid for oid in small_objects(a, priors) if oid in {o.id for o in b.objects}]
        if not shared:
            continue
        distances.append(clutter_distance(a, b, shared))
        other = sum(1 for oid in shared if _parent(a, oid) != _parent(b, oid))
        moved.append(other / len(shared))
    if not distances:
        return {"clutter_distance": None, "receptacle_changed": None, "min_receptacle_changed": None}
    return {
        "clutter_distance": round(sum(distances) / len(distances), 4),
        "receptacle_changed": round(sum(moved) / len(moved), 4),
        "min_receptacle_changed": round(min(moved), 4),
    }


async def _stage_clutter(run: PipelineRun, rec: StageRecord) -> None:
    cfg = run.config
    if cfg.clutter == "keep":  # pragma: no cover - the plan leaves the stage out
        rec.status = "skipped"
        return
    scene = run.need_scene()
    priors = await asyncio.to_thread(load_clutter_priors, cfg.priors_dir)
    work = functools.partial(
        clutter_scenes, scene, list(run.variants), mode=cfg.clutter, density=float(cfg.clutter_density),
        priors=priors, seed=cfg.seed, base_dir=run.base_dir, hull_cache=run.cache(),
        id_prefix=f"{scene.id}_" if run.source is not None else "",  # a room of a house: ids unique house-wide
    )  # fmt: skip
    run.scene, run.variants, detail = await asyncio.to_thread(work)
    rec.detail.update(detail)
    if detail["dropped"]:
        run.notes.append(
            f"clutter: {detail['dropped']} small object(s) dropped (why: report.json, stage clutter)"
        )


CLUTTER_STAGE = Stage("clutter", _stage_clutter)
"""The clutter stage (module docstring)."""

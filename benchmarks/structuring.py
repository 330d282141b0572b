"""Structuring benchmark: how right the offline structuring is on the shipped rooms.

Figures (the last line is one JSON object):

* ``procthor_support_match`` — share of the ProcTHOR houses' objects whose support parent,
  inferred without reading the house's ``children`` nesting, matches the generator's nesting
  (``procthor_support_misses``: the objects that do not);
* ``physcene_wall_furniture``, ``physcene_flush`` — furniture that belongs against a wall on
  the seven PhyScene rooms, and how many of them end (after ``stabilize``) within 1 cm of a
  wall with their back to it; ``physcene_free_standing`` — those with no wall behind them;
* ``physcene_beds_head_to_wall`` — beds whose head end is flush against a wall;
* ``physcene_nested_after`` — pairs of floor furniture whose boxes stand inside each other
  after stabilization; ``physcene_parted`` — pairs the verification agent moved apart;
* ``physcene_box_overlaps_before`` / ``_after`` — objects whose box overlaps another object's
  box (parent and child excepted) in the imported and in the stabilized rooms, and
  ``_after_unexpected``, the same without a seat under its table or a table in an L-sofa's crook;
* ``physcene_constraints`` / ``physcene_within_unit`` — cross-unit constraints and relations
  inside one unit (``faces``/``beside``) found on the seven rooms;
* ``seconds`` — wall time of the whole benchmark.

Run: ``.venv/bin/python benchmarks/structuring.py``.
"""

from __future__ import annotations

import asyncio
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from shapely.geometry import Polygon

from scenemosaic.exchange import load_scene, load_scenes
from scenemosaic.physics import stabilize_scene
from scenemosaic.scene import Scene, may_share_floor, nested_pairs, traits
from scenemosaic.structure import structure_scene

REPO = Path(__file__).resolve().parents[1]
PHYSCENE = sorted((REPO / "data" / "layouts" / "physcene").glob("*.json"))
HOUSES = sorted((REPO / "data" / "houses" / "procthor").glob("procthor_*.json"))


async def procthor_support() -> tuple[float, list[str]]:
    total = matched = 0
    misses: list[str] = []
    for path in HOUSES:
        for scene in load_scenes(path):
            truth = {r.child: r.parent for r in scene.relations if r.is_support}
            out = await structure_scene(scene.model_copy(update={"relations": []}))
            got = {r.child: r.parent for r in out.relations if r.is_support}
            for child, parent in truth.items():
                total += 1
                if got.get(child) == parent:
                    matched += 1
                else:
                    misses.append(f"{path.stem}:{child} ({scene.get(child).category}) -> {got.get(child)}, listed {parent}")
    return round(matched / total, 4), misses


def box_overlaps(scene: Scene, *, expected_too: bool) -> int:
    """Objects whose box overlaps another's (parent and child excepted; 1 cm height slack)."""
    hit: set[str] = set()
    for i, a in enumerate(scene.objects):
        for b in scene.objects[i + 1 :]:
            if not expected_too and may_share_floor(a, b):
                continue
            ra, rb = scene.support_of(a.id), scene.support_of(b.id)
            if (ra and ra.parent == b.id) or (rb and rb.parent == a.id):
                continue
            (_, _, az0), (_, _, az1) = a.aabb()
            (_, _, bz0), (_, _, bz1) = b.aabb()
            if min(az1, bz1) - max(az0, bz0) <= 0.01:
                continue
            if Polygon(a.footprint()).intersection(Polygon(b.footprint())).area > 1e-3:
                hit |= {a.id, b.id}
    return len(hit)


def _back(yaw: float) -> np.ndarray[Any, Any]:
    return -np.array([math.sin(yaw), -math.cos(yaw)])


async def physcene() -> dict[str, Any]:
    figures = dict.fromkeys(
        ("wall_furniture", "flush", "free_standing", "beds", "beds_head_to_wall", "nested_after", "parted",
         "box_overlaps_before", "box_overlaps_after", "box_overlaps_after_unexpected", "constraints", "within_unit"),
        0,
    )
    for path in PHYSCENE:
        raw = load_scene(path)
        figures["box_overlaps_before"] += box_overlaps(raw, expected_too=True)
        structured = await structure_scene(raw)
        out, _ = await stabilize_scene(structured)
        assert out.room is not None
        walls = out.room.walls
        figures["box_overlaps_after"] += box_overlaps(out, expected_too=True)
        figures["box_overlaps_after_unexpected"] += box_overlaps(out, expected_too=False)
        figures["nested_after"] += len(nested_pairs(out))
        figures["parted"] += sum("moved out" in n for n in out.provenance.notes)
        figures["constraints"] += len(out.constraints)
        figures["within_unit"] += sum(r.kind in ("faces", "beside") for r in out.relations)
        for o in out.objects:
            if not traits(o.category).against_wall:
                continue
            figures["wall_furniture"] += 1
            behind = [w for w in walls if float(_back(o.pose.yaw) @ -np.asarray(w.inward_normal)) > 0.99]
            gaps = [w.gap(o.footprint()) for w in behind]
            if gaps and min(gaps) <= 0.01:
                figures["flush"] += 1
            else:
                figures["free_standing"] += 1
            if "bed" in o.category:
                figures["beds"] += 1
                head = np.asarray(o.pose.position[:2]) + _back(o.pose.yaw) * o.size[1] / 2
                figures["beds_head_to_wall"] += min(w.gap(head[None, :]) for w in walls) <= 0.01
    return {f"physcene_{k}": v for k, v in figures.items()}


def main() -> int:
    started = time.perf_counter()
    match, misses = asyncio.run(procthor_support())
    figures: dict[str, Any] = {"procthor_support_match": match, "procthor_support_misses": misses}
    figures.update(asyncio.run(physcene()))
    figures["seconds"] = round(time.perf_counter() - started, 1)
    print(json.dumps(figures, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())

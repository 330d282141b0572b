"""Every shipped PhyScene room, evolved offline with variants: every layout of every unit ends valid.

Judged here in world coordinates, independently of the evolution's own (u, v) checks: no
collisions above tolerance and nothing out of bounds (the physics checkers on the whole scene
with the layout in place), wall furniture backed against a wall within 5 cm and facing into the
room within 10 degrees, seats facing their table within 15 degrees, nightstands beside the head
of their bed; and the delivered base and variants as a person would judge them
(``tests/plausibility_checks.py``): seats square to their table side, lamps over their group, a
sofa and its TV facing each other, RelKeep of every kind at least 0.99.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import read_scene
from scenemosaic.physics import check_collisions, check_out_of_bounds
from scenemosaic.scene import Pose, Scene, front_vector, traits, with_unit_layout
from tests.plausibility_checks import delivered, lamp_problems, seat_problems, sofa_tv_problems

PHYSCENE = sorted((Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene").glob("*.json"))


def _layouts(out: Path) -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted((out / "evolve").glob("*/*.json"))]


def _with(scene: Scene, layout: dict[str, Any]) -> Scene:
    poses = {k: Pose.model_validate(v) for k, v in layout["local_poses"].items()}
    return with_unit_layout(scene, layout["anchor"], poses)


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    c = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _backed(scene: Scene, oid: str) -> bool:
    obj = scene.get(oid)
    assert scene.room is not None
    front = front_vector(obj.pose.quaternion)[:2]
    foot = obj.footprint()
    for w in scene.room.walls:
        if -0.01 <= w.gap(foot) <= 0.05 and _angle(front, w.inward_normal) <= 10.0:
            return True
    return False


def _faces(scene: Scene, seat: str, table: str) -> float:
    s, t = scene.get(seat), scene.get(table)
    c = s.pose.position[:2]
    poly = Polygon(t.footprint())
    if poly.contains(Point(c)):
        way = np.asarray(t.pose.position[:2]) - c
    else:
        q = nearest_points(poly, Point(c))[0]
        way = np.array([q.x, q.y]) - c
    return _angle(front_vector(s.pose.quaternion)[:2], way)


def _beside_head(scene: Scene, stand: str, bed: str) -> bool:
    b, n = scene.get(bed), scene.get(stand)
    f = front_vector(b.pose.quaternion)[:2]
    lat = np.array([f[1], -f[0]])
    depth, width = float(b.size[1]), float(b.size[0])
    rel = np.asarray(n.pose.position[:2]) - np.asarray(b.pose.position[:2])
    half = float(np.ptp((n.footprint() - np.asarray(n.pose.position[:2])) @ lat)) / 2
    gap = abs(float(rel @ lat)) - width / 2 - half
    return -0.02 <= gap <= 0.35 and float(rel @ -f) >= depth / 2 - 0.75


def _check_variants(report: dict[str, Any], out: Path) -> None:
    """The whole-scene variants the compose stage wrote: each valid, keeping the base's relations
    and one connected walkable floor. Every shipped room allows NAV 0.99 (the critic reopens
    passages the prior cut; without that, the refined base of LivingDiningRoom-13536 kept NAV
    0.73 and that of DiningRoom-19325 0.94), so the base and every variant must reach it."""
    metrics = report["metrics"]
    written = report["variants_written"]
    assert written == 5 and len(metrics["variants"]) == written
    assert (out / "contact_sheet.png").is_file()
    assert metrics["base"]["NAV"] >= 0.99, metrics["base"]
    for i, v in enumerate(metrics["variants"], start=1):
        assert (out / f"variant_{i}" / "scene.json").is_file()
        assert v["COL"] == 0.0 and v["OOB"] == 0.0 and v["RelKeep"] >= 0.99, (i, v)
        assert v["NAV"] >= 0.99, (i, v, metrics["base"])
    div = metrics["diversity"]
    assert div["Div-N"] >= 0.40 and div["Div-IoU"] <= 0.35, div  # issue 25: diverse in every shipped room
    kinds = metrics["RelKeep_by_kind"]
    assert all(v is None or v >= 0.99 for v in kinds.values()), kinds
    for v in metrics["variants"]:
        assert all(x is None or x >= 0.99 for x in v["RelKeep_by_kind"].values()), v
    base, variants = delivered(out)
    assert seat_problems(base, [base, *variants]) == []
    assert lamp_problems(base, variants) == []
    assert sofa_tv_problems(base, variants) == []
    print(f"{out.name}: {written} variants, Div-IoU {div['Div-IoU']}, Div-N {div['Div-N']}")


@pytest.mark.parametrize("room", PHYSCENE, ids=lambda p: p.stem)
def test_every_evolved_layout_of_every_unit_is_valid(room: Path, tmp_path: Path) -> None:
    result = generate(room, tmp_path, GenerateConfig(variants=5))
    assert result.status == "ok", result.report["warnings"]
    _check_variants(result.report, tmp_path)
    base = read_scene(tmp_path / "base")
    layouts = _layouts(tmp_path)
    floor = [lay for lay in layouts if lay["anchor"] == "floor"]
    assert floor and any(lay["layout_id"] != "original" for lay in floor), "the floor unit should get variants"
    faces = [(r.child, r.parent) for r in base.relations if r.kind == "faces"]
    beside = [(r.child, r.parent) for r in base.relations if r.kind == "beside"]
    for lay in layouts:
        where = f"{lay['anchor']}/{lay['layout_id']}"
        assert lay["valid"] and not lay["violations"] and lay["error"] is None, (where, lay)
        scene = _with(base, lay)
        kids = set(lay["local_poses"])
        pairs = [p for p in check_collisions(scene, tmp_path / "base").pairs if {p.a, p.b} & kids]
        assert pairs == [], (where, pairs)
        oob = [o.object_id for o in check_out_of_bounds(scene).objects if o.object_id in kids]
        assert oob == [], (where, oob)
        if lay["anchor"] != "floor":
            continue
        for oid in sorted(kids):
            t = traits(scene.get(oid).category)
            if t.against_wall and t.placement == "floor":
                assert _backed(scene, oid), (where, oid)
        for seat, table in faces:
            if seat in kids and not traits(scene.get(seat).category).against_wall:
                assert _faces(scene, seat, table) <= 15.0, (where, seat, table)
        for stand, bed in beside:
            if stand in kids and "bed" in scene.get(bed).category:
                assert _beside_head(scene, stand, bed), (where, stand, bed)


def test_the_refined_original_fixes_a_tv_stand_left_off_the_wall(tmp_path: Path) -> None:
    """In LivingDiningRoom-1344 the prior leaves the TV stand standing free, its back off every wall."""
    room = next(p for p in PHYSCENE if p.stem.startswith("LivingDiningRoom-1344"))
    before = generate(room, tmp_path / "stable", GenerateConfig(evolve=False)).scene
    after = generate(room, tmp_path / "evolved", GenerateConfig()).scene
    assert not _backed(before, "tv_stand_0")
    assert _backed(after, "tv_stand_0")

"""The 22-object bedroom of ``tests/fixtures/bedroom_22.json`` through ``generate`` on the rules model.

The scene (written by ``tests/fixtures/make_bedroom.py``) has what a learned prior hands over:
pillows a centimetre or two above the mattress and below the headboard's top, books on the
boards inside a bookshelf, a painting 3 cm off its wall, a pendant lamp, and an office chair
turned 133 degrees away from its desk.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.physics import TIPPED_TILT_DEG
from scenemosaic.scene import FLOOR, Scene, traits

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
BEDROOM = FIXTURES / "bedroom_22.json"

Generated = tuple[Scene, Scene, dict[str, Any]]
"""The input scene, the generated base scene and the run report."""

EXPECTED_PARENTS = {
    "pillow_0": "bed",
    "pillow_1": "bed",
    "table_lamp_0": "nightstand_0",
    "alarm_clock_0": "nightstand_1",
    "book_0": "bookshelf_0",
    "book_1": "bookshelf_0",
    "book_2": "bookshelf_0",
    "television_0": "tv_stand_0",
    "monitor_0": "desk_0",
    "mug_0": "desk_0",
    "painting_0": "wall_1",  # the east wall (x = 4.5)
    "pendant_lamp_0": "ceiling",
}


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    out = tmp_path_factory.mktemp("bedroom")
    result = generate(BEDROOM, out, GenerateConfig())
    before = Scene.model_validate_json(BEDROOM.read_text(encoding="utf-8"))
    return before, result.scene, result.report


def test_the_fixture_file_is_what_its_script_writes() -> None:
    sys.path.insert(0, str(FIXTURES))
    try:
        from make_bedroom import bedroom
    finally:
        sys.path.remove(str(FIXTURES))
    assert BEDROOM.read_text(encoding="utf-8") == bedroom().to_json(indent=1) + "\n"
    assert len(bedroom().objects) >= 20


def test_every_support_relation_is_right(generated: Generated) -> None:
    _, scene, _ = generated
    assert scene.room is not None
    east = min(scene.room.walls, key=lambda w: abs(w.start[0] - 4.5) + abs(w.end[0] - 4.5))
    assert EXPECTED_PARENTS["painting_0"] == east.id
    for obj in scene.objects:
        rel = scene.support_of(obj.id)
        assert rel is not None, obj.id
        assert rel.parent == EXPECTED_PARENTS.get(obj.id, FLOOR), (obj.id, rel.parent)
    for book in ("book_0", "book_1", "book_2"):
        assert scene.support_of(book).kind == "contain"  # type: ignore[union-attr]


def test_things_rest_on_the_surfaces_they_belong_on(generated: Generated) -> None:
    _, scene, report = generated
    gaps = report["validation"]["support_gaps_m"]
    assert max(abs(g) for g in gaps.values()) < 0.01, gaps
    mattress_top = 0.5 * scene.get("bed").size[2]  # the procedural bed's mattress: half its box height
    bed_box = scene.get("bed").aabb()
    for pillow in ("pillow_0", "pillow_1"):
        p = scene.get(pillow)
        assert abs(p.pose.position[2] - mattress_top) < 0.01, (
            pillow
        )  # on the mattress, below the headboard top
        lo, hi = p.aabb()
        assert np.all(lo[:2] >= bed_box[0][:2] - 1e-6) and np.all(hi[:2] <= bed_box[1][:2] + 1e-6), pillow
    # the books stand on the shelf boards (not on the shelf's top at 1.8 m, not on the floor)
    assert scene.get("book_0").pose.position[2] == pytest.approx(0.38, abs=0.01)
    assert scene.get("book_2").pose.position[2] == pytest.approx(0.735, abs=0.01)
    assert scene.get("table_lamp_0").pose.position[2] == pytest.approx(0.55, abs=0.01)
    assert scene.get("television_0").pose.position[2] == pytest.approx(0.5, abs=0.01)


def test_the_painting_settles_onto_its_wall_in_simulation(
    generated: Generated,
) -> None:
    before, scene, report = generated
    painting = scene.get("painting_0")
    assert not painting.sim.static  # dynamic in its unit: the wall's gravity holds it
    stages = {s["name"]: s for s in report["stages"]}
    [unit] = [u for u in stages["stabilize"]["detail"]["units"] if u["anchor_id"] == "wall_1"]
    assert unit["children"] == ["painting_0"] and unit["steps"] > 0 and unit["converged"]
    gap_before = 4.5 - before.get("painting_0").aabb()[1][0]
    gap_after = 4.5 - painting.aabb()[1][0]
    assert gap_before > 0.02 and -0.001 <= gap_after < 0.01  # 3 cm off, now on the wall (contact: < 1 mm in)
    assert painting.pose.position[2] == pytest.approx(1.3, abs=0.005)  # it hangs: it did not slide down
    assert report["validation"]["fell"] == []


def test_the_chair_faces_the_desk_and_a_constraint_spans_two_units(
    generated: Generated,
) -> None:
    _, scene, _ = generated
    chair, desk = scene.get("office_chair_0"), scene.get("desk_0")
    front = np.array([math.sin(chair.pose.yaw), -math.cos(chair.pose.yaw)])
    way = np.subtract(desk.pose.position[:2], chair.pose.position[:2])
    angle = math.degrees(math.acos(float(front @ way) / float(np.linalg.norm(way))))
    assert angle < 10.0, angle
    assert any("office_chair_0" in n and "turned" in n for n in scene.provenance.notes)
    [desk_constraint] = [c for c in scene.constraints if c.anchor_b.anchor_id == "desk_0"]
    assert desk_constraint.anchor_a.anchor_id == FLOOR
    assert set(desk_constraint.anchor_a.related_objects) == {"office_chair_0", "desk_0"}
    assert "monitor_0" in desk_constraint.anchor_b.related_objects  # the desk's own unit


def test_nothing_tipped_collides_or_nests_and_wall_furniture_is_flush(
    generated: Generated,
) -> None:
    _, scene, report = generated
    validation = report["validation"]
    assert validation["tipped"] == [] and validation["fell"] == []
    assert validation["collisions"]["pairs"] == [] and validation["out_of_bounds"]["objects"] == []
    assert validation["nested"] == []
    assert max(m["tilt_deg"] for m in validation["motions"]) < TIPPED_TILT_DEG
    assert scene.room is not None
    against = {r.child: r.parent for r in scene.relations if r.kind == "against"}
    walls = {w.id: w for w in scene.room.walls}
    for obj in scene.objects:
        if traits(obj.category).against_wall:
            wall = walls[against[obj.id]]
            gap = float(((obj.footprint() - np.asarray(wall.start)) @ np.asarray(wall.inward_normal)).min())
            assert 0.0 <= gap <= 0.01, (obj.id, gap)
    # the gaps the relations record are the ones after physics (``inspect`` prints them)
    recorded = [r.distance for r in scene.relations if r.distance is not None]
    assert len(recorded) == len(against) + 1 and all(d <= 0.01 for d in recorded), recorded  # + the painting
    assert json.loads(json.dumps(report))["status"] == "ok"

"""Wall furniture on the shipped PhyScene rooms: recovered walls behind it, ``against`` relations, flush."""

from __future__ import annotations

import numpy as np

from scenemosaic.physics import StabilizationReport, check_collisions
from scenemosaic.physics._stabilize import AGAINST_GAP_M
from scenemosaic.scene import Scene, traits


def test_wall_furniture_stands_flush_against_a_wall(physcene_stabilized: dict[str, tuple[Scene, StabilizationReport]]) -> None:
    flush = total = 0
    for name, (scene, report) in physcene_stabilized.items():
        assert scene.room is not None
        walls = {w.id: w for w in scene.room.walls}
        against = [r for r in scene.relations if r.kind == "against"]
        if any(traits(o.category).against_wall for o in scene.objects):
            assert against, f"{name}: wall furniture but no 'against' relation"
        for rel in against:
            obj, wall = scene.get(rel.child), walls[rel.parent]
            inward = np.asarray(wall.inward_normal)
            gap = float(((obj.footprint() - np.asarray(wall.start)) @ inward).min())
            assert gap > -1e-6, (name, obj.id)  # never through the wall
            assert float(np.dot(-np.asarray([np.sin(obj.pose.yaw), -np.cos(obj.pose.yaw)]), inward)) < 0  # back to wall
            total += 1
            if gap <= AGAINST_GAP_M + 0.01:
                flush += 1
                assert obj.id in report.against_snapped or gap <= 0.01, (name, obj.id)
    assert total >= 20 and flush / total >= 0.9, (flush, total)


def test_snapping_to_walls_leaves_no_collision(physcene_stabilized: dict[str, tuple[Scene, StabilizationReport]]) -> None:
    for name, (scene, _report) in physcene_stabilized.items():
        assert check_collisions(scene).pairs == [], name

"""Plugin rules of the critic (``GenerateConfig.layout_rules``): their findings reach the critic,
the rule actor applies their fixes, and a rule that returns something else is refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import scenemosaic as sm
from scenemosaic.evolve import (
    Finding,
    PhysicalCheck,
    Target,
    UnitContext,
    find_problems,
    unit_context,
    unit_obstacles,
)
from scenemosaic.exceptions import UsageError
from scenemosaic.scene import UnitLayout

ROOM = Path(__file__).resolve().parents[2] / "data/layouts/physcene/LivingDiningRoom-8714_livingroom.json"
GOAL_U = 2.2  # the armchair's centre along u, metres (it stands at about 1.7)


def armchair_to_goal(layout: UnitLayout, ctx: UnitContext) -> list[Finding]:
    if "armchair_0" not in layout.ids or abs(layout.center("armchair_0")[0] - GOAL_U) <= 0.02:
        return []
    v = layout.center("armchair_0")[1]
    return [Finding("armchair_goal", ("armchair_0",), "semantic", "Move (armchair_0) to its goal.", {"armchair_0": Target(GOAL_U, v)})]


def test_a_plugin_rule_moves_what_it_asks_for(tmp_path: Path) -> None:
    plain = sm.generate(ROOM, tmp_path / "plain", sm.GenerateConfig())
    ruled = sm.generate(ROOM, tmp_path / "ruled", sm.GenerateConfig(layout_rules=[armchair_to_goal]))
    assert plain.status == ruled.status == "ok"
    before = np.asarray(plain.scene.get("armchair_0").pose.position)
    after = np.asarray(ruled.scene.get("armchair_0").pose.position)
    assert float(np.linalg.norm(after - before)) > 0.3
    floor = next(lay for lay in ruled.report["stages"] if lay["name"] == "evolve")["detail"]["layouts"][0]
    assert floor["anchor"] == "floor" and floor["valid"]
    # the rule's note reached the critic and the actor acted on it
    layout_file = ruled.out_dir / "evolve" / "floor" / "original.json"
    memory = json.loads(layout_file.read_text(encoding="utf-8"))["memory"]
    assert any("Move (armchair_0) to its goal." in n for r in memory for n in r["notes"])


def test_a_rule_returning_something_else_is_refused(tmp_path: Path) -> None:
    scene = sm.generate(ROOM, tmp_path, sm.GenerateConfig(evolve=False)).scene
    assert scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    ctx = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), set())
    layout = UnitLayout.from_scene(scene, unit, ctx.surface)
    assert any(f.kind == "armchair_goal" for f in find_problems(layout, ctx, PhysicalCheck((), ()), rules=[armchair_to_goal]))

    def bad(layout: UnitLayout, ctx: UnitContext) -> list[str]:
        return ["not a finding"]

    with pytest.raises(UsageError, match="bad returned str"):
        find_problems(layout, ctx, PhysicalCheck((), ()), rules=[bad])  # type: ignore[list-item]

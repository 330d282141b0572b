"""The seating etiquette: seats in table slots, square to their side, long sides first and even.

Judged with ``scenemosaic.metrics``' seating judge, written apart from the critic's rules."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

import numpy as np
import pytest

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.evolve import (
    PhysicalCheck,
    UnitContext,
    find_problems,
    merged_fixes,
    seat_slots,
    seating_breaches,
    unit_context,
    unit_obstacles,
)
from scenemosaic.metrics import seat_checks, seat_pairs, table_balance
from scenemosaic.physics import is_thin
from scenemosaic.scene import Scene, UnitLayout, with_unit_layout

PHYSCENE = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene"
CLEAN = PhysicalCheck(collisions=(), out_of_bounds=())


def _floor(name: str, out: Path) -> tuple[Scene, UnitLayout, UnitContext]:
    scene = asyncio.run(agenerate(PHYSCENE / name, out, GenerateConfig(evolve=False))).scene
    assert isinstance(scene, Scene) and scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    ctx = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), {o.id for o in scene.objects if is_thin(o)})
    return scene, UnitLayout.from_scene(scene, unit, ctx.surface), ctx


@pytest.fixture(scope="module")
def dining(tmp_path_factory: pytest.TempPathFactory) -> tuple[Scene, UnitLayout, UnitContext]:
    """The 9-object living-dining room (a 2.5 m table, four chairs), stabilized, not evolved."""
    return _floor("LivingDiningRoom-8714_livingroom.json", tmp_path_factory.mktemp("dining"))


def _seats(ctx: UnitContext, table: str) -> list[str]:
    return sorted(s for s, t in ctx.seat_table.items() if t == table)


def _judged(scene: Scene, layout: UnitLayout) -> Scene:
    return with_unit_layout(scene, "floor", layout.poses())


def test_chairs_at_the_corners_turned_askew_are_seated_in_slots(dining: tuple[Scene, UnitLayout, UnitContext]) -> None:
    scene, layout, ctx = dining
    table = "dining_table_0"
    seats = _seats(ctx, table)
    assert len(seats) == 4
    # the chairs crowd one corner of the table, each turned 30 degrees: what a person would not do
    bad = layout.copy()
    c = np.asarray(layout.center(table))
    for i, k in enumerate(seats):
        bad.set_center(k, float(c[0]) + 1.45, float(c[1]) + 0.45 * (i - 1.5))
        bad.set_rotation(k, 60.0 + 30.0)
    assert seating_breaches(bad, ctx, table, seats)
    found = [f for f in find_problems(bad, ctx, CLEAN) if f.kind == "seating"]
    assert found and "squarely" in found[0].note and f"({table})" in found[0].note
    fixed = bad.copy()
    for k, t in merged_fixes(found).items():
        assert t.u is not None and t.v is not None and t.rotation is not None
        fixed.set_rotation(k, t.rotation)
        fixed.set_center(k, t.u, t.v)
    assert seating_breaches(fixed, ctx, table, seats) == []
    judged = _judged(scene, fixed)
    checks = seat_checks(judged, {k: table for k in seats})
    assert all(ch.square and ch.on_side for ch in checks), checks
    (balance,) = table_balance(judged, checks)
    assert balance.balanced is True and sorted(balance.counts.values()) == [0, 0, 2, 2], balance


def test_slots_fill_the_long_sides_evenly_before_the_ends(dining: tuple[Scene, UnitLayout, UnitContext]) -> None:
    _scene, layout, ctx = dining
    table = "dining_table_0"
    seats = _seats(ctx, table)
    plan = seat_slots(layout, ctx, table, seats)
    sides = sorted(sl.side for sl in plan.values())
    long_pair = {"front", "back"} if layout.object(table).size[0] > layout.object(table).size[1] else {"left", "right"}
    assert set(sides) == long_pair and sides.count(sides[0]) == 2, sides
    # along a side the two seats sit symmetrically about its middle
    c = np.asarray(layout.center(table))
    for side in long_pair:
        offs = sorted(float(np.dot(np.array([sl.u, sl.v]) - c, _along(layout, table))) for sl in plan.values() if sl.side == side)
        assert math.isclose(offs[0], -offs[1], abs_tol=1e-6)


def _along(layout: UnitLayout, table: str) -> np.ndarray:
    r = math.radians(layout.rotation(table))
    front = np.array([-math.sin(r), -math.cos(r)])
    return np.array([front[1], -front[0]])


def test_a_table_pushed_against_a_wall_leaves_that_side_empty(tmp_path: Path) -> None:
    _scene, layout, ctx = _floor("DiningRoom-19325_diningroom.json", tmp_path)  # a table, four chairs
    table = "dining_table_0"
    seats = _seats(ctx, table)
    region = np.asarray(ctx.surface.region)
    moved = layout.copy()
    # the table turned so a long side runs along the bottom wall of the view, 5 cm from it
    moved.set_rotation(table, layout.rotation(table) + 90.0)
    poly = moved.polygon(table)
    moved.set_center(table, float(moved.center(table)[0]), float(moved.center(table)[1]) - (float(poly[:, 1].min()) - float(region[:, 1].min()) - 0.05))
    plan = seat_slots(moved, ctx, table, seats)
    edge = float(moved.polygon(table)[:, 1].min())  # the table's side by the wall
    assert len(plan) == len(seats) and all(sl.v > edge for sl in plan.values()), plan
    counts = {side: sum(1 for sl in plan.values() if sl.side == side) for side in {sl.side for sl in plan.values()}}
    far = max(counts, key=lambda k: counts[k])
    assert counts[far] >= 2 and sum(counts.values()) - counts[far] <= 2, counts  # the far long side first, then the ends


def test_seat_pairs_come_from_the_base_geometry(dining: tuple[Scene, UnitLayout, UnitContext]) -> None:
    scene, _layout, ctx = dining
    assert seat_pairs(scene) == {k: t for k, t in ctx.seat_table.items() if t == "dining_table_0"}

"""The offline archetypes that move whole groups, and the critic's passage fix, on shipped rooms.

Each archetype is checked on its own placement (before any loop runs): groups travel rigidly,
land on the floor, and stay clear of what they do not bring along. The passage fix is checked
on the prior layout of LivingDiningRoom-13536, whose dining chair stands 0.3 m from the sofa and
cuts the walkable floor in two.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from shapely.geometry import Polygon

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.evolve import (
    BESIDE_GAP_MAX,
    SEAT_GAP_MAX,
    Archetype,
    PosePlacement,
    RuleArchetype,
    UnitContext,
    evolve_layout,
    find_problems,
    instantiate,
    physical_check,
    rule_archetypes,
    unit_context,
    unit_obstacles,
)
from scenemosaic.metrics import nav
from scenemosaic.models import parse_model
from scenemosaic.physics import is_thin, object_shape
from scenemosaic.scene import WALK_MIN_SHARE, FloorRaster, Scene, UnitLayout, with_unit_layout

PHYSCENE = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene"
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "evolve"


def _fixture(name: str) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((FIXTURES / name).read_text())
    return data


async def _floor(name: str, out: Path) -> tuple[Scene, UnitLayout, UnitContext]:
    scene = (await agenerate(PHYSCENE / name, out, GenerateConfig(evolve=False))).scene
    assert scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    ctx = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), {o.id for o in scene.objects if is_thin(o)})
    return scene, UnitLayout.from_scene(scene, unit, ctx.surface), ctx


def _placed(layout: UnitLayout, placement: dict[str, tuple[float, float, float]]) -> UnitLayout:
    out = layout.copy()
    for k, (u, v, r) in placement.items():
        out.set_rotation(k, r)
        out.set_center(k, u, v)
    return out


def _beside_head(layout: UnitLayout, stand: str, bed: str) -> bool:
    """Beside a long side of the bed (gap at most ``BESIDE_GAP_MAX``), in its head half, facing as it."""
    r = math.radians(layout.rotation(bed))
    front = np.array([-math.sin(r), -math.cos(r)])  # rotation 0 faces down the view
    side = np.array([front[1], -front[0]])
    rel = np.subtract(layout.center(stand), layout.center(bed))
    bed_half = float(np.ptp((layout.polygon(bed) - layout.center(bed)) @ side)) / 2
    stand_half = float(np.ptp((layout.polygon(stand) - layout.center(stand)) @ side)) / 2
    gap = abs(float(rel @ side)) - bed_half - stand_half
    turn = abs((layout.rotation(stand) - layout.rotation(bed) + 180) % 360 - 180)
    return -0.02 <= gap <= BESIDE_GAP_MAX and float(rel @ front) < 0 and turn < 1.0


def _new_overlaps(before: UnitLayout, after: UnitLayout, thin: set[str], tucked: dict[str, str] | None = None) -> list[tuple[str, str, float]]:
    """New footprint overlaps of solid pieces; a seat tucked in under its own table (``tucked``:
    seat -> table) is where a seat belongs, not an overlap."""
    solid = [k for k in after.ids if k not in thin]
    out = []
    for i, a in enumerate(solid):
        for b in solid[i + 1 :]:
            if tucked and (tucked.get(a) == b or tucked.get(b) == a):
                continue
            now = Polygon(after.polygon(a)).intersection(Polygon(after.polygon(b))).area
            was = Polygon(before.polygon(a)).intersection(Polygon(before.polygon(b))).area
            if now > 0.01 and was <= 0.01:
                out.append((a, b, round(now, 3)))
    return out


async def test_a_bed_swaps_walls_with_its_nightstands_tucked_beside_its_head(tmp_path: Path) -> None:
    _, layout, ctx = await _floor("Bedroom-33922_bedroom.json", tmp_path)
    offered = {a.layout_id: a for a in rule_archetypes(layout, ctx)}
    swaps = [k for k in offered if k.startswith("swapped_double_bed_0")]
    assert swaps, sorted(offered)
    region = Polygon(ctx.surface.region).buffer(0.05, join_style="mitre")
    for lid in swaps:
        after = _placed(layout, offered[lid].place(layout, ctx))
        turned = abs((after.rotation("double_bed_0") - layout.rotation("double_bed_0") + 180) % 360 - 180)
        assert turned > 45.0 or math.dist(after.center("double_bed_0"), layout.center("double_bed_0")) > 1.0, lid
        for stand in ("nightstand_0", "nightstand_1"):
            assert _beside_head(after, stand, "double_bed_0"), (lid, stand)
        assert all(region.covers(Polygon(after.polygon(k))) for k in after.ids), lid
        assert _new_overlaps(layout, after, ctx.thin) == [], lid


async def test_the_bed_goes_to_every_wall_it_fits_and_a_limit_takes_the_most_different(tmp_path: Path) -> None:
    """The bed of Bedroom-33922 (1.85 m wide with its nightstands 2.9 m, on walls of 3.0 and 4.1 m)
    is offered on each of the three other walls, flush against it with its nightstands at its head
    (the west wall was lost to a rounding of the flush gap). Asked for five, the agent offers five
    whose footprints differ from the original's and each other's at least as much as the first
    five in preference order do."""
    _, layout, ctx = await _floor("Bedroom-33922_bedroom.json", tmp_path)
    offered = rule_archetypes(layout, ctx)
    own = next(w for w in ctx.walls if w.gap(layout.polygon("double_bed_0")) < 0.02)
    landed = set()
    for a in offered:
        if not a.layout_id.startswith("displaced_double_bed_0_wall_"):
            continue
        after = _placed(layout, a.place(layout, ctx))
        walls = [w.id for w in ctx.walls if w.gap(after.polygon("double_bed_0")) < 0.02]
        landed.update(walls)
        assert all(_beside_head(after, k, "double_bed_0") for k in ("nightstand_0", "nightstand_1")), a.layout_id
    assert landed >= {w.id for w in ctx.walls} - {own.id}, sorted(landed)

    raster = FloorRaster(np.asarray(ctx.surface.region), 0.1)

    def cells(placement: dict[str, tuple[float, float, float]]) -> np.ndarray:
        lay = _placed(layout, placement)
        return raster.blocked([lay.polygon(k) for k in lay.ids if k not in ctx.thin])

    def closest(chosen: list[RuleArchetype]) -> float:
        maps = [cells({})] + [cells(a.place(layout, ctx)) for a in chosen]
        return min(1.0 - float((a & b).sum()) / float((a | b).sum()) for i, a in enumerate(maps) for b in maps[i + 1 :])

    spread = rule_archetypes(layout, ctx, 5)
    assert len(spread) == 5 and {a.layout_id for a in spread} <= {a.layout_id for a in offered}
    assert closest(spread) >= closest(offered[:5]), (closest(spread), closest(offered[:5]))


async def test_a_free_standing_table_slides_with_its_chairs_clear_of_the_rest(tmp_path: Path) -> None:
    """The prior scatters the dining room's chairs over the room: a slide gathers them around the
    table first, then carries the group at least 1 m toward one side."""
    _, layout, ctx = await _floor("DiningRoom-19325_diningroom.json", tmp_path)
    slides = [a for a in rule_archetypes(layout, ctx) if a.layout_id.startswith("slid_")]
    assert slides
    seats = sorted(s for s, t in ctx.seat_table.items() if t == "dining_table_0")
    assert len(seats) >= 4
    region = Polygon(ctx.surface.region)
    for a in slides:
        after = _placed(layout, a.place(layout, ctx))
        assert math.dist(after.center("dining_table_0"), layout.center("dining_table_0")) >= 1.0 - 1e-9, a.layout_id
        table = Polygon(after.polygon("dining_table_0"))
        for k in ["dining_table_0", *seats]:
            assert region.covers(Polygon(after.polygon(k))), (a.layout_id, k)
        for k in seats:
            assert Polygon(after.polygon(k)).distance(table) <= SEAT_GAP_MAX, (a.layout_id, k)
        assert _new_overlaps(layout, after, ctx.thin, ctx.seat_table) == [], a.layout_id


async def test_the_critic_reopens_a_floor_cut_in_two(tmp_path: Path) -> None:
    """The prior layout has other problems too: the cut is only remarked until they are fixed
    (the seats drawn up into their slots may reopen it; else one clean move does), and the evolved
    layout's floor is one piece."""
    scene, layout, ctx = await _floor("LivingDiningRoom-13536_livingroom.json", tmp_path)
    raster = FloorRaster(np.asarray(ctx.surface.region))

    def share(lay: UnitLayout) -> float:
        blocked = raster.blocked([lay.polygon(k) for k in lay.ids if k not in ctx.thin])
        return raster.walkable(blocked).share

    assert share(layout) < 0.9
    shapes = {o.id: object_shape(o, tmp_path / "base") for o in scene.objects}
    first = find_problems(layout, ctx, physical_check(layout, ctx, shapes))
    assert any(f.severity != "soft" for f in first)
    passage = [f for f in first if f.kind == "passage"]
    assert len(passage) == 1 and passage[0].severity == "soft" and not passage[0].fixes
    result = await evolve_layout(scene, ctx, layout, shapes, parse_model("rules"), layout_id="original")
    assert result.valid and result.violations == []
    assert nav(scene) < 0.9  # the whole scene's NAV, before and after
    assert nav(with_unit_layout(scene, "floor", result.local_poses)) >= WALK_MIN_SHARE


@pytest.mark.parametrize("name", ["LivingDiningRoom-8714_livingroom.json", "DiningRoom-19325_diningroom.json"])
async def test_every_offered_archetype_fits_the_agents_schema(name: str, tmp_path: Path) -> None:
    """Composite patterns join two names and two reasons: they still fit the pydantic models the
    archetype and pose agents answer with (ids, name and reason lengths)."""
    _, layout, ctx = await _floor(name, tmp_path)
    offered = rule_archetypes(layout, ctx)
    assert len(offered) >= 6 and any("_" in a.layout_id.split("_", 1)[1] for a in offered)
    for a in offered:
        Archetype(layout_id=a.layout_id, layout_style_name=a.style_name, layout_reasoning=a.reasoning)
        _, how = instantiate(layout, ctx, a)
        PosePlacement.model_validate({"object_id": layout.ids[0], "reasoning": how, "center_coordinates": {"u": 0.0, "v": 0.0}})


async def test_a_table_never_makes_way_for_its_own_chair(tmp_path: Path) -> None:
    """Recorded from a perturbed LivingDiningRoom-13536 (benchmarks/evolution.py): two chairs touch
    their table 3 cm deep; the layout memory saw both chairs oscillate, so fixes prefer to move
    something else. The fix used to carry the table 1.5 m clear of them, leaving its other seats
    behind; now each chair still takes the move, a short one."""
    fixture = _fixture("chairs_hemmed_in_13536.json")
    scene, layout, ctx = await _floor(fixture["room"], tmp_path)
    for k, (u, v, r) in fixture["poses"].items():
        layout.set_rotation(k, r)
        layout.set_center(k, u, v)
    shapes = {o.id: object_shape(o, tmp_path / "base") for o in scene.objects}
    check = physical_check(layout, ctx, shapes)
    with_table = [p for p in check.collisions if "dining_table_0" in (p.a, p.b) and {p.a, p.b} - {"dining_table_0"} <= set(ctx.seat_table)]
    assert with_table, check.collisions
    avoid = {"dining_chair_1", "dining_chair_3"}
    found = [f for f in find_problems(layout, ctx, check, avoid) if f.kind == "collision" and "dining_table_0" in f.objects]
    assert found
    for f in found:
        assert "dining_table_0" not in f.fixes, f.note
        for k, t in f.fixes.items():
            assert t.u is not None and t.v is not None
            assert math.dist((t.u, t.v), layout.center(k)) < 0.5, (k, f.note)

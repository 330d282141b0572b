"""The offline loop repairs a disturbed layout: everything moved and turned, then made valid again.

Seeded disturbances (up to 0.4 m along each axis, up to 25 degrees) of the stabilized floor units
of the dining room (chairs around a table) and the 22-object bedroom (a bed, its nightstands, a
desk and its chair, wall furniture); ``benchmarks/evolution.py`` runs the same over every room.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.evolve import evolve_layout, unit_context, unit_obstacles
from scenemosaic.models import parse_model
from scenemosaic.physics import is_thin, object_shape
from scenemosaic.scene import UnitLayout

REPO = Path(__file__).resolve().parents[2]
ROOMS = [
    REPO / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json",
    REPO / "tests" / "fixtures" / "bedroom_22.json",
]


@pytest.mark.parametrize("source", ROOMS, ids=lambda p: p.stem)
async def test_disturbed_floor_units_end_valid(source: Path, tmp_path: Path) -> None:
    scene = (await agenerate(source, tmp_path, GenerateConfig(evolve=False))).scene
    assert scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    others = unit_obstacles(scene, unit, scene.structure.units)
    ctx = unit_context(scene, unit, others, {o.id for o in scene.objects if is_thin(o)})
    shapes = {o.id: object_shape(o, tmp_path / "base") for o in scene.objects}
    rng = random.Random(11)
    for trial in range(3):
        layout = UnitLayout.from_scene(scene, unit)
        for k in layout.ids:
            u, v = layout.center(k)
            layout.set_center(k, u + rng.uniform(-0.4, 0.4), v + rng.uniform(-0.4, 0.4))
            layout.set_rotation(k, layout.rotation(k) + rng.uniform(-25, 25))
        result = await evolve_layout(scene, ctx, layout, shapes, parse_model("rules"), layout_id=f"disturbed_{trial}")
        assert result.valid and result.violations == [], (trial, result.violations, result.stop_reason)
        assert len(result.rounds) >= 2  # it did have work to do

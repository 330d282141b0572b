"""Acceptance of the structuring stage on every PhyScene room of the shared data (rules model)."""

from __future__ import annotations

from pathlib import Path

from shapely.geometry import Polygon

from scenemosaic.scene import CEILING, FLOOR, Scene
from scenemosaic.scene._categories import traits
from scenemosaic.structure import structure_scene

CEILING_LAMPS = {"pendant_lamp", "ceiling_lamp"}


async def test_every_room_is_fully_parented(physcene_scenes: dict[str, Scene], procthor_dir: Path) -> None:
    assert len(physcene_scenes) == 7
    for name, scene in physcene_scenes.items():
        out = await structure_scene(scene, priors_dir=procthor_dir)
        assert out.structure is not None and out.structure.units, name
        for o in out.objects:
            rel = out.support_of(o.id)
            assert rel is not None, f"{name}: {o.id} has no parent"
            if o.category in CEILING_LAMPS:
                assert rel.parent == CEILING, f"{name}: lamp {o.id} -> {rel.parent}"
            else:
                # nothing in these rooms is stacked: every other object stands on the floor
                assert rel.parent == FLOOR, f"{name}: {o.id} ({o.category}) -> {rel.parent}"
        # the room boundary contains every footprint of the imported scene
        assert out.room is not None and len(out.room.walls) == 4
        floor = Polygon(out.room.floor).buffer(1e-6)
        for o in scene.objects:
            assert floor.contains(Polygon(o.footprint())), f"{name}: {o.id} outside the room"
        # the floor unit lists every floor object, the ceiling unit every lamp
        units = {u.anchor_id: u for u in out.structure.units}
        assert set(units[FLOOR].children) == {o.id for o in out.objects if o.category not in CEILING_LAMPS}
        lamps = {o.id for o in out.objects if o.category in CEILING_LAMPS}
        if lamps:
            assert set(units[CEILING].children) == lamps
            assert units[CEILING].projection == "bottom_up"
        # the input is untouched
        assert all(scene.support_of(o.id) is None for o in scene.objects)


async def test_generator_errors_are_repaired(physcene_scenes: dict[str, Scene], procthor_dir: Path) -> None:
    """Sunk / floating floor furniture goes to the floor, the lamp standing on the floor to the ceiling."""
    checked_sunk = checked_lamp = 0
    for name, scene in physcene_scenes.items():
        out = await structure_scene(scene, priors_dir=procthor_dir)
        for o in scene.objects:
            bottom = float(o.aabb()[0][2])
            parent = out.support_of(o.id)
            assert parent is not None
            if traits(o.category).placement == "floor" and abs(bottom) > 0.15:
                checked_sunk += 1
                assert parent.parent == FLOOR, f"{name}: {o.id} at z={bottom:.2f} -> {parent.parent}"
            if o.category in CEILING_LAMPS and bottom < 0.5:
                checked_lamp += 1
                assert parent.parent == CEILING
    assert checked_sunk >= 5  # the data README: about a quarter of the floor objects are off
    assert checked_lamp == 1  # one pendant lamp stands on the floor


async def test_functional_constraints(physcene_scenes: dict[str, Scene], procthor_dir: Path) -> None:
    """Seats face their table, nightstands stand by the bed: as a cross-unit constraint when the two
    sides live in different units, as a relation inside the floor unit when they do not (PhyScene's
    tables and beds carry nothing, so here every pair lives in the floor unit)."""
    for name, scene in physcene_scenes.items():
        out = await structure_scene(scene, priors_dir=procthor_dir)
        cats = {o.id: o.category for o in out.objects}
        parent = {r.child: r.parent for r in out.relations if r.is_support}
        carriers = set(parent.values())
        faces = [(r.child, r.parent) for r in out.relations if r.kind == "faces"]
        beside = [(r.child, r.parent) for r in out.relations if r.kind == "beside"]
        if "dining_table" in cats.values():
            assert any(cats[c] == "dining_chair" and cats[t] == "dining_table" for c, t in faces), name
        if name.startswith("Bedroom"):
            assert any(cats[n] == "nightstand" and "bed" in cats[b] for n, b in beside), name
        for child, ref in faces + beside:
            assert parent[child] == parent[ref], f"{name}: {child} and {ref} are in different units"
            assert ref not in carriers, f"{name}: {ref} carries objects; this pair spans units"
        for c in out.constraints:
            a, b = c.anchor_a.anchor_id, c.anchor_b.anchor_id
            assert a != b and a in carriers and b in carriers, f"{name}: {c.id} is not cross-unit"
        # every clause lands in a unit
        assert out.structure is not None
        placed = [cl for u in out.structure.units for cl in u.clauses]
        assert len(placed) == 2 * len(out.constraints)

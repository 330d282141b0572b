"""What opens can open (issue 53): the pull test in plain MuJoCo finds a fridge flush to the wall on
its hinge side blocked by the wall, and the repair slides it the least way that lets its doors open."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

import pytest

from scenemosaic.exchange import export_mjcf
from scenemosaic.physics import free_part_paths, object_shape, pull_parts, stabilize_scene
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject


def _room(*objects: SceneObject) -> Scene:
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    return Scene(id="kitchen", room=Room.rectangle(0, 0, 4.0, 4.0), objects=list(objects), relations=relations)


def _fridge(x: float) -> SceneObject:
    """A fridge facing into the room (front -Y) whose left side, where its doors hang, is ``x``
    metres from the wall at x = 0."""
    return SceneObject(
        id="fridge", category="fridge", asset=AssetRef(kind="procedural", extents=(0.7, 0.7, 1.8)),
        pose=Pose.from_yaw((0.35 + x, 3.6, 0.0), 0.0),
    )  # fmt: skip


def _pulled(scene: Scene, out: Path) -> dict[str, tuple[bool, float, str | None]]:
    xml = export_mjcf(scene, out)
    return {p.joint: (p.passed, p.reached, p.blocked_by) for p in pull_parts(xml)}


def test_a_fridge_flush_to_the_wall_on_its_hinge_side_cannot_open(tmp_path: Path) -> None:
    pulled = _pulled(_room(_fridge(0.0)), tmp_path / "flush")
    assert set(pulled) == {"fridge/door_fridge", "fridge/door_freezer"}
    for joint, (passed, reached, blocker) in pulled.items():
        assert not passed and reached < math.radians(90), joint
        assert blocker is not None and "wall" in blocker, (joint, blocker)


def test_a_fridge_away_from_the_wall_opens_in_plain_mujoco(tmp_path: Path) -> None:
    pulled = _pulled(_room(_fridge(0.1)), tmp_path / "free")
    assert all(passed for passed, _, _ in pulled.values()), pulled


def test_the_repair_slides_the_fridge_off_the_wall_the_least_way_and_its_doors_open(tmp_path: Path) -> None:
    scene = _room(_fridge(0.0))
    before = scene.model_dump_json()
    shapes = {o.id: object_shape(o) for o in scene.objects}
    repaired, repair = free_part_paths(scene, shapes)
    assert scene.model_dump_json() == before  # the input is kept, its provenance notes too
    assert set(repair.moved) == {"fridge"} and 0.0 < repair.moved["fridge"] <= 0.05
    assert repaired.get("fridge").pose.position[0] > scene.get("fridge").pose.position[0]  # away from the wall
    assert any("parts: moved fridge" in n for n in repaired.provenance.notes)
    pulled = _pulled(repaired, tmp_path / "repaired")
    assert all(passed for passed, _, _ in pulled.values()), pulled
    again, nothing = free_part_paths(repaired, shapes)  # nothing left to do
    assert not nothing.moved and not nothing.stuck and again is repaired


def test_a_piece_with_no_room_to_move_is_reported_not_moved() -> None:
    """A fridge in a niche exactly its width: no sideways move frees its doors."""
    fridge = _fridge(0.0)
    niche = SceneObject(
        id="tall_cabinet", category="cabinet", asset=AssetRef(kind="box", extents=(0.6, 0.6, 2.0)),
        pose=Pose.from_yaw((1.0, 3.6, 0.0), 0.0),
    )  # fmt: skip
    scene = _room(fridge, niche)
    shapes = {o.id: object_shape(o) for o in scene.objects}
    _, repair = free_part_paths(scene, shapes)
    assert "fridge" not in repair.moved and repair.stuck.get("fridge") == ["door_freezer", "door_fridge"]


def test_a_nightstand_in_a_wardrobe_doors_way_moves_aside_and_stays_beside_its_bed() -> None:
    """PhyScene Bedroom-11659: the wardrobe's door meets the nightstand placed beside it and the
    wardrobe has no room to move, so the nightstand slides along its width (staying beside the
    bed's head) until the door opens."""
    from scenemosaic.assets import part_blockers, short_parts
    from scenemosaic.exchange import load_scene
    from scenemosaic.scene import functional_holds, functional_relations
    from tests.conftest import PHYSCENE_DIR

    scene = load_scene(PHYSCENE_DIR / "Bedroom-11659_bedroom.json")
    assert isinstance(scene, Scene)
    assert part_blockers(scene, "wardrobe_0") == {"door_3": ["nightstand_1"]}
    shapes = {o.id: object_shape(o) for o in scene.objects}
    repaired, repair = free_part_paths(scene, shapes)
    assert list(repair.moved) == ["nightstand_1"] and repair.moved["nightstand_1"] <= 0.3
    assert repair.freed == {"nightstand_1": "wardrobe_0"}
    assert any("moved nightstand_1" in n and "wardrobe_0's parts open" in n for n in repaired.provenance.notes)
    assert "wardrobe_0" not in short_parts(repaired)
    kept = [r for r in functional_relations(scene) if r.subject == "nightstand_1" or "nightstand_1" in r.group]
    assert kept and all(functional_holds(repaired, r) for r in kept)


def test_a_small_object_beside_a_microwave_moves_along_the_counter_so_its_door_opens() -> None:
    """The shipped 4-room house's kitchen: the object beside the microwave on the counter stops the
    microwave's door at about 35 degrees; it moves along the counter (staying on it) instead."""
    from scenemosaic.assets import part_blockers, short_parts
    from scenemosaic.exchange import load_scene
    from scenemosaic.scene import House
    from tests.conftest import DATA

    house = load_scene(DATA / "houses" / "procthor" / "procthor_4room.json")
    assert isinstance(house, House)
    kitchen = next(r for r in house.rooms if any(o.id == "small_6_23" for o in r.objects))
    assert part_blockers(kitchen, "small_6_23") == {"door": ["small_6_16"]}
    shapes = {o.id: object_shape(o) for o in kitchen.objects}
    repaired, repair = free_part_paths(kitchen, shapes)
    assert "small_6_16" in repair.moved and "small_6_23" not in short_parts(repaired)
    counter = kitchen.support_of("small_6_16")
    assert counter is not None and repaired.support_of("small_6_16") == counter
    assert repaired.get("small_6_16").pose.position[2] == kitchen.get("small_6_16").pose.position[2]


@pytest.mark.house
def test_the_delivered_4_room_house_opens_its_fridge_and_microwave_in_plain_mujoco(tmp_path: Path) -> None:
    """A house folder, pulled as a user loads it (``base/scene.xml`` of the whole house): the fridge
    the source puts flush to a wall and the microwave the source boxes in both open; each failure
    names what blocks it, and every room-door leaf swings."""
    from scenemosaic.pipeline import GenerateConfig, generate
    from tests.conftest import DATA

    out = tmp_path / "house"
    generate(DATA / "houses" / "procthor" / "procthor_4room.json", out, GenerateConfig(variants=0, room_workers=1))
    pulled = {p.joint: p for p in pull_parts(out / "base" / "scene.xml")}
    for joint in ("6_0/door_fridge", "6_0/door_freezer", "small_6_23/door"):
        assert pulled[joint].passed, (joint, pulled[joint])
    leaves = [p for p in pulled.values() if p.room_door]
    assert leaves and all(p.passed for p in leaves)
    assert all(p.blocked_by for p in pulled.values() if not p.passed)


def test_a_toilet_lid_under_clutter_is_freed_and_opens_in_plain_mujoco(tmp_path: Path) -> None:
    """The shipped 4-room house's bathroom, stabilized: a sponge the source holds over the toilet's lid
    lies on it, soap and paper stand on the cistern's front edge, where the lid leans at its stop
    (95 degrees); pulled in MuJoCo the lid throws or knocks them. The repair moves each the least way out of the lid's path, onto the
    cistern, and the lid then opens through its range without moving anything."""
    from scenemosaic.assets import kept_free, object_articulation, short_parts
    from scenemosaic.exchange import load_scene
    from scenemosaic.scene import House
    from tests.conftest import DATA

    house = load_scene(DATA / "houses" / "procthor" / "procthor_4room.json")
    assert isinstance(house, House)
    source = next(r for r in house.rooms if any(o.category == "toilet" for o in r.objects))
    toilet = next(o for o in source.objects if o.category == "toilet")
    keep = {
        toilet.id,
        *(o.id for o in source.objects if (rel := source.support_of(o.id)) and rel.parent == toilet.id),
    }
    alone = source.model_copy(update={  # the toilet and what the source stands on it, in its room
        "objects": [o for o in source.objects if o.id in keep],
        "relations": [r for r in source.relations if r.child in keep and r.parent in (keep | {"floor"})],
        "structure": None,
    })  # fmt: skip
    bathroom, _ = asyncio.run(
        stabilize_scene(alone, base_dir=None, seed=0)
    )  # at rest, as the pipeline has it
    (lid,) = object_articulation(toilet)
    assert kept_free(lid) == pytest.approx(math.radians(95))  # a lid's whole range, not 90 degrees
    before = _pulled(bathroom, tmp_path / "before")[f"{toilet.id}/lid"]
    assert not before[0] and before[2] is not None and before[2].startswith("small_")
    shapes = {o.id: object_shape(o) for o in bathroom.objects}
    repaired, repair = free_part_paths(bathroom, shapes)
    assert toilet.id not in short_parts(repaired) and not repair.stuck
    assert repair.moved and all(oid.startswith("small_") and d <= 0.3 for oid, d in repair.moved.items())
    for oid in repair.moved:
        assert repaired.support_of(oid) == bathroom.support_of(oid)  # still on the toilet
    after = _pulled(repaired, tmp_path / "after")[f"{toilet.id}/lid"]
    assert after[0], after

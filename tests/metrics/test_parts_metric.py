"""``evaluate`` reports what cannot open (issue 53): PARTS, the share of drawers, doors and lids whose
way open for use is free, and per scene what blocks each that is not, for a room and for a house."""

from __future__ import annotations

from scenemosaic.metrics import blocked_parts, evaluate, parts_free
from scenemosaic.scene import (
    AssetRef,
    House,
    Opening,
    Pose,
    Relation,
    Room,
    Scene,
    SceneObject,
    blocked_windows,
)


def _kitchen(gap: float, room_id: str = "kitchen") -> Scene:
    """A fridge (two doors hinged on its left) ``gap`` metres from the wall at x = 0, and a dresser
    with its drawers facing into the room."""
    fridge = SceneObject(
        id=f"{room_id}_fridge", category="fridge", asset=AssetRef(kind="procedural", extents=(0.7, 0.7, 1.8)),
        pose=Pose.from_yaw((0.35 + gap, 3.6, 0.0), 0.0),
    )  # fmt: skip
    dresser = SceneObject(
        id=f"{room_id}_dresser", category="dresser", asset=AssetRef(kind="procedural", extents=(1.2, 0.5, 0.9)),
        pose=Pose.from_yaw((2.5, 3.7, 0.0), 0.0),
    )  # fmt: skip
    objects = [fridge, dresser]
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    return Scene(id=room_id, room=Room.rectangle(0, 0, 4.0, 4.0), objects=objects, relations=relations)


def test_a_fridge_flush_to_its_wall_is_reported_blocked_by_the_wall() -> None:
    flush, free = _kitchen(0.0), _kitchen(0.1)
    assert blocked_parts(flush) == {"kitchen_fridge/door_freezer": ["wall"], "kitchen_fridge/door_fridge": ["wall"]}
    assert blocked_parts(free) == {}
    assert parts_free(free) == 1.0 and 0.0 < parts_free(flush) < 1.0
    report = evaluate(free, [flush])
    assert report["base"]["PARTS"] == 1.0 and report["base"]["parts_blocked"] == {}
    (variant,) = report["variants"]
    assert variant["PARTS"] == round(parts_free(flush), 4) and sorted(variant["parts_blocked"]) == sorted(blocked_parts(flush))


def test_a_house_counts_its_rooms_blocked_parts_as_numbers_for_base_and_variants() -> None:
    base = House(id="flat", rooms=[_kitchen(0.1, "a"), _kitchen(0.1, "b")])
    variant = House(id="flat", rooms=[_kitchen(0.0, "a"), _kitchen(0.1, "b")])
    report = evaluate(base, [variant])
    assert report["house"]["base"]["parts_blocked"] == 0
    assert report["house"]["variants"][0]["parts_blocked"] == 2  # the fridge's two doors in room a
    assert report["rooms"]["a"]["variants"][0]["parts_blocked"] == blocked_parts(variant.rooms[0])
    assert report["rooms"]["b"]["base"]["PARTS"] == 1.0


def _with_window(under: str) -> Scene:
    """A 4 x 4 m room with a 1.2 m window (sill 0.9 m) in its north wall, a wardrobe (2 m tall) and a
    bench (0.45 m); ``under`` is the one backed against the north wall beneath the window, the other
    stands against the south wall."""
    room = Room.rectangle(0, 0, 4.0, 4.0)
    walls = list(room.walls)
    k = next(i for i, w in enumerate(walls) if abs(w.start[1] - 4.0) < 1e-9 and abs(w.end[1] - 4.0) < 1e-9)
    window = Opening(kind="window", center=2.0, width=1.2, bottom=0.9, height=1.2)
    walls[k] = walls[k].model_copy(update={"openings": [window]})
    objects = []
    for oid, category, extents in (("wardrobe", "wardrobe", (1.0, 0.6, 2.0)), ("bench", "ottoman", (1.0, 0.4, 0.45))):
        y, yaw = (4.0 - extents[1] / 2 - 0.01, 0.0) if oid == under else (extents[1] / 2 + 0.01, 3.141592653589793)
        objects.append(SceneObject(
            id=oid, category=category, asset=AssetRef(kind="procedural", extents=extents), pose=Pose.from_yaw((2.0, y, 0.0), yaw),
        ))  # fmt: skip
    relations = [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    return Scene(id="room", room=room.model_copy(update={"walls": walls}), objects=objects, relations=relations)


def test_a_tall_piece_before_a_window_blocks_it_and_a_low_one_does_not() -> None:
    tall, low = _with_window("wardrobe"), _with_window("bench")
    (window,) = [f"{w.id}/window_0" for w in tall.room.walls if w.openings]  # type: ignore[union-attr]
    assert blocked_windows(tall) == {window: ["wardrobe"]}
    assert blocked_windows(low) == {}
    report = evaluate(low, [tall])
    assert report["base"]["windows_blocked"] == {} and report["variants"][0]["windows_blocked"] == {window: ["wardrobe"]}
    house = evaluate(House(id="h", rooms=[low]), [House(id="h", rooms=[tall])])
    assert house["house"]["base"]["windows_blocked"] == 0 and house["house"]["variants"][0]["windows_blocked"] == 1


def test_a_low_table_carrying_a_tall_plant_before_a_window_blocks_it() -> None:
    """SceneEval's window clearance sees what stands on furniture too: a table below the sill with a
    plant rising above it, 0.4 m from the window, blocks it (by the table, the piece a layout moves)."""
    room = Room.rectangle(0, 0, 4.0, 4.0)
    north = room.walls[2].model_copy(update={"openings": [Opening(kind="window", center=2.0, width=1.2, bottom=1.0, height=1.0)]})
    room = room.model_copy(update={"walls": [*room.walls[:2], north, *room.walls[3:]]})
    table = SceneObject(
        id="table", category="side_table", asset=AssetRef(kind="procedural", extents=(0.6, 0.5, 0.75)),
        pose=Pose.from_yaw((2.0, 4.0 - 0.25 - 0.4, 0.0), 0.0),
    )  # fmt: skip
    plant = SceneObject(
        id="plant", category="plant", asset=AssetRef(kind="procedural", extents=(0.3, 0.3, 0.5)),
        pose=Pose.from_yaw((2.0, 4.0 - 0.25 - 0.4, 0.75), 0.0),
    )  # fmt: skip
    bare = Scene(id="r", room=room, objects=[table], relations=[Relation(kind="attach", child="table", parent="floor")])
    assert blocked_windows(bare) == {}
    dressed = bare.model_copy(update={
        "objects": [table, plant],
        "relations": [*bare.relations, Relation(kind="attach", child="plant", parent="table")],
    })  # fmt: skip
    assert blocked_windows(dressed) == {"wall_2/window_0": ["table"]}

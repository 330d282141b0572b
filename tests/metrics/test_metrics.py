"""The scene metrics on scenes built by hand, where the right answer is known."""

from __future__ import annotations

import pytest

from scenemosaic.metrics import col, div_iou, div_n, nav, oob, relkeep
from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject


def _box(oid: str, xy: tuple[float, float], size: tuple[float, float, float], z: float = 0.0, category: str = "cabinet") -> SceneObject:
    return SceneObject(
        id=oid, category=category, asset=AssetRef(kind="box", extents=size), pose=Pose.from_yaw((xy[0], xy[1], z), 0.0)
    )


def _scene(objects: list[SceneObject], relations: list[Relation] | None = None) -> Scene:
    rels = relations or [Relation(kind="attach", child=o.id, parent="floor") for o in objects]
    return Scene(room=Room.rectangle(0.0, 0.0, 4.0, 4.0), objects=objects, relations=rels)


def test_col_counts_pairs_deeper_than_5mm() -> None:
    deep = _scene([_box("a", (1.0, 1.0), (1, 1, 1)), _box("b", (1.9, 1.0), (1, 1, 1)), _box("c", (3.0, 3.0), (0.5, 0.5, 0.5))])
    assert col(deep) == pytest.approx(2 / 3)  # a and b overlap 10 cm
    touching = _scene([_box("a", (1.0, 1.0), (1, 1, 1)), _box("b", (1.997, 1.0), (1, 1, 1))])
    assert col(touching) == 0.0  # 3 mm: apart after the 5 mm separation


def test_oob_counts_objects_with_samples_off_the_floor() -> None:
    scene = _scene([_box("in", (2.0, 2.0), (1, 1, 1)), _box("half", (3.9, 2.0), (1, 1, 1)), _box("edge", (3.49, 2.0), (1, 1, 1))])
    assert oob(scene) == pytest.approx(1 / 3)  # "edge" reaches 3.99 < 4.0: in


def test_oob_of_a_box_slid_across_the_floor_edge_turns_once_and_is_asked_again_the_same() -> None:
    """A 1 m box slid in 1 cm steps past the wall x = 4: in while it stays inside (its bounds
    judged at once), out from where over 1 % of its surface samples cross, and a scene asked
    again (a house's variants share objects) gets the answer it got."""
    answers = [oob(_scene([_box("slid", (3.40 + 0.01 * i, 2.0), (1, 1, 1))])) for i in range(21)]
    assert set(answers) == {0.0, 1.0}
    first_out = answers.index(1.0)
    assert all(a == 0.0 for a in answers[:first_out]) and all(a == 1.0 for a in answers[first_out:])
    assert 3.40 + 0.01 * first_out > 3.5  # reaching past x = 4.0 at all is not enough on its own: 1 % must cross
    assert [oob(_scene([_box("slid", (3.40 + 0.01 * i, 2.0), (1, 1, 1))])) for i in range(21)] == answers


def test_oob_lets_a_back_flush_on_the_wall_be_in_and_one_through_it_out() -> None:
    # a flat TV 4 cm deep hung on the wall x = 4: its back face lies on the wall's plane
    flush = _box("flush", (3.98 + 5e-5, 2.0), (0.04, 1.0, 0.6), z=1.0, category="television")
    through = _box("through", (3.98 + 0.004, 2.0), (0.04, 1.0, 0.6), z=1.0, category="television")
    assert oob(_scene([flush])) == 0.0  # 0.05 mm past the edge: float noise, in
    assert oob(_scene([through])) == 1.0  # 4 mm through the wall: its back face is out


def test_nav_is_one_for_an_open_room_and_drops_when_furniture_cuts_it() -> None:
    assert nav(_scene([_box("a", (1.0, 1.0), (0.5, 0.5, 0.5))])) == pytest.approx(1.0)
    wall_of_shelves = _scene([_box("s", (1.0, 2.0), (0.3, 4.0, 2.0))])  # splits the room 1 m / 2.7 m
    share = nav(wall_of_shelves)
    assert 0.2 < share < 0.9
    high = _scene([_box("lamp", (1.0, 2.0), (0.3, 4.0, 0.3), z=2.2, category="pendant_lamp")], [Relation(kind="attach", child="lamp", parent="ceiling")])
    assert nav(high) == pytest.approx(1.0)  # above 2 m: walked under


def test_div_iou_and_div_n_on_known_pairs() -> None:
    a = _scene([_box("x", (1.0, 1.0), (1, 1, 1)), _box("y", (3.0, 3.0), (1, 1, 1))])
    b = _scene([_box("x", (3.0, 1.0), (1, 1, 1)), _box("y", (1.0, 3.0), (1, 1, 1))])
    assert div_iou([a, a]) == pytest.approx(1.0) and div_iou([a, b]) == pytest.approx(0.0)
    assert div_n([a, a]) == pytest.approx(0.0, abs=1e-8) and div_n([a, b]) > 0.3
    assert div_iou([a]) is None and div_n([a]) is None


def test_relkeep_is_the_share_of_support_relations_that_still_hold() -> None:
    table = _box("table", (2.0, 2.0), (1.2, 0.8, 0.75), category="dining_table")
    mug = _box("mug", (2.0, 2.0), (0.1, 0.1, 0.1), z=0.75, category="mug")
    rels = [Relation(kind="attach", child="table", parent="floor"), Relation(kind="attach", child="mug", parent="table")]
    base = _scene([table, mug], rels)
    assert relkeep(base, base) == 1.0
    moved = _scene([table, mug.model_copy(update={"pose": Pose.from_yaw((3.5, 3.5, 0.75), 0.0)})], rels)
    assert relkeep(base, moved) == pytest.approx(0.5)  # the mug floats off the table's footprint

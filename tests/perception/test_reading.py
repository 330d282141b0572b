"""A photograph read the way a person reads it (issue 27): headings from the evidence, the camera's
pitch from vertical lines, hanging objects held to the ceiling, and the varied renders
(``data/images/v_*``) that measure it where it is hard.

The per-render checks hold each render to what the box lifter reaches on it today (see the table
in ``docs/perception.md``), so a regression shows; the pooled acceptance figures of the issue are
reported by ``benchmarks/perception.py``.
"""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenemosaic.models import RulesModel
from scenemosaic.perception import (
    BoxLifter,
    LiftedObject,
    Reconstruction,
    heading_symmetry,
    load_image,
    perceive,
    score_against_truth,
)
from scenemosaic.perception._headings import HeadingItem, choose_headings
from scenemosaic.perception._lift import CameraPose, _top_edge_support, _vertical_pitch

DATA = Path(__file__).resolve().parents[2] / "data" / "images"
VARIED = sorted(p.name for p in DATA.iterdir() if p.name.startswith("v_") and (p / "truth.json").is_file()) if DATA.is_dir() else []
TILT_LIMIT_DEG = 2.0
"""The issue's bar for the recovered floor's tilt, in every view."""
PITCH_FROM_LINES_DEG = 1.0
"""How close the pitch read from vertical lines alone lands to the true pitch."""


def _truth(name: str) -> dict[str, Any]:
    return json.loads((DATA / name / "truth.json").read_text())


def _read(name: str, out_dir: Path | None = None) -> Any:
    folder = DATA / name
    return asyncio.run(
        perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="box", reconstructor=BoxLifter(), out_dir=out_dir)
    )


def test_varied_renders_cover_heights_lenses_aspects_headings_and_lamps() -> None:
    truths = {name: _truth(name) for name in VARIED}
    assert len(truths) >= 12
    assert len({t["scene"] for t in truths.values()}) >= 4
    heights = [t["camera"]["position"][2] for t in truths.values()]
    lenses = [t["camera"]["hfov_deg"] for t in truths.values()]
    assert min(heights) <= 1.35 and max(heights) >= 1.75
    assert min(lenses) <= 52 and max(lenses) >= 78
    assert len({round(t["image"]["width"] / t["image"]["height"], 2) for t in truths.values()}) >= 4
    assert sum(1 for t in truths.values() if t["camera"]["yaw_deg"] % 90 == 45) >= 4
    lamps_in = [n for n, t in truths.items() if any(o["placement"] == "ceiling" and o["in_boxes"] for o in t["objects"])]
    lamps_out = [n for n, t in truths.items() if any(o["placement"] == "ceiling" and not o["in_boxes"] for o in t["objects"])]
    assert len(lamps_in) >= 3 and len(lamps_out) >= 3
    for name in VARIED:  # the lens travels in the file's EXIF, where a camera writes it
        camera = load_image(DATA / name / "photo.png").camera()
        assert camera.source == "exif" and abs(camera.hfov_deg - truths[name]["camera"]["hfov_deg"]) < 0.01


def test_pitch_from_vertical_lines() -> None:
    """The vertical edges alone give the pitch within a degree wherever they give one, in at least
    nine views of ten (a view with under two usable edges gives none: the room's horizontal edges
    then carry it)."""
    measured = 0
    for name in VARIED:
        image = load_image(DATA / name / "photo.png")
        found = _vertical_pitch(image, image.camera())
        if found is not None:
            measured += 1
            assert abs(math.degrees(found[0]) - _truth(name)["camera"]["pitch_deg"]) < PITCH_FROM_LINES_DEG, name
    assert measured >= 0.9 * len(VARIED)


@pytest.mark.parametrize("name", VARIED)
def test_varied_render_camera_and_floor(name: str) -> None:
    """Tilt within the issue's 2 degrees, the fit's uncertainty recorded and honest (the true
    height within three of its standard deviations), every floor object placed."""
    truth = _truth(name)
    result = _read(name)
    boxes = {o.id: o.box for o in result.inventory}
    score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]), boxes)
    assert score.tilt_deg < TILT_LIMIT_DEG, score.tilt_deg
    assert abs(result.report["camera_pitch_deg"] - truth["camera"]["pitch_deg"]) < TILT_LIMIT_DEG
    sd = result.report["camera_height_sd_m"]
    assert 0.0 < sd < 0.5
    assert abs(score.camera_height_error_m) < 3 * sd + 0.05, (score.camera_height_error_m, sd)
    assert {o.id for o in result.reconstruction.objects} == {o["id"] for o in truth["objects"] if o["in_boxes"]}
    floor = [o for o in score.objects if o.placement == "floor"]
    assert floor and float(np.median([o.position_error_m for o in floor])) < 1.0


def test_demo_bedroom_headings_and_their_reasons(tmp_path: Path) -> None:
    """The issue's own example: bed, desk, nightstand and chair face where the truth says, and
    perception.json says why."""
    truth = _truth("demo_bedroom")
    result = _read("demo_bedroom", tmp_path / "perception")
    score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]))
    heading = {o.id: o.heading_error_deg for o in score.objects}
    for oid in ("bed", "desk", "nightstand_left", "chair"):
        assert heading[oid] is not None and heading[oid] < 20.0, (oid, heading[oid])
    written = json.loads((tmp_path / "perception" / "perception" / "perception.json").read_text())
    reasons = written["headings"]
    assert {"bed", "desk", "nightstand_left", "chair", "bookshelf"} <= set(reasons)
    assert "faces desk" in reasons["chair"]
    assert "flanks bed" in reasons["nightstand_left"] and reasons["bed"]
    assert written["camera_height_sd_m"] > 0 and "vertical_lines_pitch_deg" in written


def test_ceiling_lamp_hangs_from_the_ceiling() -> None:
    """A pendant lamp whose box is cut by the top of the picture is held to the ceiling (the
    documented default height) at the place its box's other edges say."""
    truth = _truth("v_demo_diag_lamp")
    result = _read("v_demo_diag_lamp")
    score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]))
    lamp = next(o for o in score.objects if o.id == "pendant_lamp")
    assert lamp.placement == "ceiling" and lamp.position_error_m < 0.5
    assert result.report["ceiling_height_m"]["source"] == "default"


# -- headings from the evidence, on hand-made rooms ------------------------------------------------


def _flat_box(n: int) -> Any:
    """A box fit with no preference between the four directions (a box cut by the border)."""
    return lambda items: (lambda i, k: (0.0, items[i].centre, items[i].size))


def _items(*rows: tuple[str, str, tuple[float, float], tuple[float, float, float]]) -> list[HeadingItem]:
    return [HeadingItem(i, c, np.array([x, y, 0.0]), np.array(s)) for i, c, (x, y), s in rows]


def _front(yaw: float) -> tuple[int, int]:
    return round(math.sin(yaw)), round(-math.cos(yaw))


def test_chairs_face_their_table_and_nightstands_flank_the_bed() -> None:
    # floor frame: the camera at the origin looking along +Y
    items = _items(
        ("table", "dining_table", (0.0, 4.0), (1.6, 0.9, 0.75)),
        ("chair_near", "dining_chair", (0.0, 3.2), (0.46, 0.53, 0.95)),
        ("chair_far", "dining_chair", (0.0, 4.8), (0.46, 0.53, 0.95)),
        ("chair_end", "dining_chair", (1.2, 4.0), (0.46, 0.53, 0.95)),
    )
    got = choose_headings(items, 0.0, _flat_box(len(items))(items))
    assert _front(got["chair_near"].yaw) == (0, 1)  # toward +Y, its back to the camera
    assert _front(got["chair_far"].yaw) == (0, -1)
    assert _front(got["chair_end"].yaw) == (-1, 0)
    assert got["chair_near"].reason == "faces table"
    assert got["chair_end"].reason == "faces table"
    beds = _items(
        ("bed", "double_bed", (0.0, 4.0), (1.6, 2.1, 0.9)),
        ("stand_l", "nightstand", (-1.05, 4.85), (0.45, 0.4, 0.55)),
        ("stand_r", "nightstand", (1.05, 4.85), (0.45, 0.4, 0.55)),
    )
    got = choose_headings(beds, 0.0, _flat_box(len(beds))(beds))
    assert _front(got["bed"].yaw) == (0, -1)  # head at the far end, by the nightstands
    assert _front(got["stand_l"].yaw) == (0, -1) and _front(got["stand_r"].yaw) == (0, -1)


def test_wall_furniture_backs_onto_the_wall() -> None:
    # a wardrobe at the room's right edge, seen side-on: its back to that wall, not to the room
    # beyond it (the sofa stands further away) nor to the camera's side
    items = _items(
        ("wardrobe", "wardrobe", (2.0, 3.0), (1.2, 0.6, 2.0)),
        ("table", "coffee_table", (0.0, 3.0), (1.0, 0.6, 0.45)),
        ("sofa", "multi_seat_sofa", (0.0, 5.0), (2.0, 0.9, 0.8)),
    )
    got = choose_headings(items, 0.0, lambda i, k: (0.0, items[i].centre, items[i].size))
    assert _front(got["wardrobe"].yaw) == (-1, 0)
    assert got["wardrobe"].reason == "backs onto the wall"


def test_a_strong_box_fit_decides_the_axis() -> None:
    items = _items(("desk", "desk", (0.0, 3.0), (1.2, 0.6, 0.75)))
    got = choose_headings(items, 0.0, lambda i, k: (0.0 if k % 2 == 1 else 400.0, items[i].centre, items[i].size))
    assert got["desk"].quarter % 2 == 1


# -- scoring against the truth ----------------------------------------------------------------------


def test_score_against_truth_compares_in_the_camera_frame_modulo_symmetry() -> None:
    truth = _truth("demo_bedroom")
    pose = np.array(truth["camera"]["world_from_camera"]).reshape(4, 4)
    rot, origin = pose[:3, :3], pose[:3, 3]
    objects = []
    for o in truth["objects"]:
        if o["id"] not in ("bed", "rug", "plant"):
            continue
        yaw = math.radians(o["yaw_deg"] + (90.0 if o["id"] == "bed" else 180.0))
        c, s = math.cos(yaw), math.sin(yaw)
        world_rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        shift = np.array([0.3, 0.0, 0.0]) if o["id"] == "bed" else np.zeros(3)
        objects.append(
            LiftedObject(
                o["id"], o["category"], "floor", rot.T @ (np.array(o["position"]) + shift - origin), rot.T @ world_rot, tuple(o["extents"])
            )
        )
    up = rot.T @ np.array([0.0, 0.0, 1.0])
    score = score_against_truth(Reconstruction(objects, floor_up=up, camera_height=1.6), truth, 1.62)
    by_id = {o.id: o for o in score.objects}
    assert abs(by_id["bed"].position_error_m - 0.3) < 1e-6 and abs(by_id["bed"].heading_error_deg - 90.0) < 1e-6  # type: ignore[operator]
    assert by_id["rug"].heading_error_deg is not None and by_id["rug"].heading_error_deg < 1e-6  # a half turn of a rug is no error
    assert by_id["plant"].heading_error_deg is None
    assert score.tilt_deg < 1e-6 and abs(score.camera_height_error_m - 0.02) < 1e-9
    assert heading_symmetry("dining_table", (1.6, 0.9, 0.75)) == 2 and heading_symmetry("coffee_table", (0.8, 0.8, 0.4)) == 4
    assert heading_symmetry("double_bed") == 1 and heading_symmetry("pendant_lamp") == 0


def test_wall_object_hangs_on_the_wall_behind_wall_furniture() -> None:
    """The television of the demo's second view hangs on the wall the desk backs onto."""
    truth = _truth("demo_bedroom_b")
    result = _read("demo_bedroom_b")
    assert result.report["on_walls"] == {"tv": "desk"}
    score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]))
    tv = next(o for o in score.objects if o.id == "tv")
    assert tv.position_error_m < 0.3 and tv.heading_error_deg is not None and tv.heading_error_deg < 20.0


def test_cut_ceiling_lamp_hangs_over_the_bed() -> None:
    """A ceiling lamp cut by the top and the right of the picture: its box leaves its depth
    free, and it hangs over the bed in view."""
    truth = _truth("v_11659_lamp")
    result = _read("v_11659_lamp")
    assert result.report["hangs_over"] == {"ceiling_lamp_0": "double_bed_0"}
    boxes = {o.id: o.box for o in result.inventory}
    score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]), boxes)
    lamp = next(o for o in score.objects if o.id == "ceiling_lamp_0")
    assert lamp.cut and lamp.position_error_m < 0.5


# -- the picture's furniture scale and the outline of a table's top ---------------------------------


def test_shared_furniture_scale_follows_larger_furniture() -> None:
    """The 8714 room's furniture runs larger than the catalogue (a 2.5 m table, 1.08 m chairs):
    the floor fit's shared scale says so, and the camera height and the places follow it. With
    every piece's scale drawn on its own, the height came out 0.19 m low and one object of seven
    landed within 0.5 m."""
    truth = _truth("livingdining_8714")
    result = _read("livingdining_8714")
    assert result.report["furniture_scale"] > 1.03  # exactly 1 with no shared scale
    boxes = {o.id: o.box for o in result.inventory}
    score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]), boxes)
    assert abs(score.camera_height_error_m) < 0.15, score.camera_height_error_m
    assert score.figures()["position_within_0_5m"] >= 0.7


def test_top_edges_tell_a_tables_long_axis() -> None:
    """A table top's outline traced by the picture's segments supports its own yaw, not the
    quarter turn that fills the same box."""
    camera = load_image(DATA / "demo_bedroom" / "photo.png").camera()
    pose = CameraPose(1.6, math.radians(20.0))
    centre, size = np.array([0.2, 3.0, 0.0]), np.array([1.6, 0.9, 0.75])
    half = np.array([[-0.8, -0.45], [0.8, -0.45], [0.8, 0.45], [-0.8, 0.45]])
    cam = pose.to_camera(np.column_stack([half + centre[:2], np.full(4, 0.75)]))
    uv = np.column_stack([camera.fx * cam[:, 0] / cam[:, 2] + camera.cx, camera.fy * cam[:, 1] / cam[:, 2] + camera.cy])
    segments = np.array([[*uv[k], *uv[(k + 1) % 4]] for k in range(4)])
    assert _top_edge_support(segments, camera, pose, centre, size, 0.0) > 0.95
    assert _top_edge_support(segments, camera, pose, centre, size, math.pi / 2) < 0.5
    assert _top_edge_support(np.zeros((0, 4)), camera, pose, centre, size, 0.0) == 0.0


# -- dining groups: the rows chairs stand in, the table they share --------------------------------


def test_a_tables_long_axis_follows_its_chairs_rows() -> None:
    """A table whose box fits its quarter turn a little better (a grazing view) still lies along
    the two rows of chairs that stand at its long sides, and the chairs face it across them."""
    items = _items(
        ("table", "dining_table", (0.0, 4.0), (1.6, 0.9, 0.75)),
        ("chair_a", "dining_chair", (-0.35, 3.3), (0.46, 0.53, 0.95)),
        ("chair_b", "dining_chair", (0.35, 3.3), (0.46, 0.53, 0.95)),
        ("chair_c", "dining_chair", (-0.35, 4.7), (0.46, 0.53, 0.95)),
        ("chair_d", "dining_chair", (0.35, 4.7), (0.46, 0.53, 0.95)),
    )
    box_prefers_across = lambda i, k: (8.0 if (i == 0 and k % 2 == 0) else 0.0, items[i].centre, items[i].size)  # noqa: E731
    got = choose_headings(items, 0.0, box_prefers_across)
    assert got["table"].quarter % 2 == 0
    assert _front(got["chair_a"].yaw) == (0, 1) and _front(got["chair_d"].yaw) == (0, -1)
    without = choose_headings(items[:1], 0.0, box_prefers_across)  # the same table alone turns
    assert without["table"].quarter % 2 == 1


def test_chairs_round_a_table_out_of_view_face_across_their_row() -> None:
    """Two chairs side by side, their table out of view: they face across their row (not each
    other), and the same way; with a second row in view, toward it."""
    one_row = _items(
        ("chair_a", "dining_chair", (-0.3, 3.0), (0.46, 0.53, 0.95)),
        ("chair_b", "dining_chair", (0.3, 3.0), (0.46, 0.53, 0.95)),
    )
    got = choose_headings(one_row, 0.0, _flat_box(2)(one_row))
    assert _front(got["chair_a"].yaw)[0] == 0 and _front(got["chair_a"].yaw) == _front(got["chair_b"].yaw)
    two_rows = _items(
        ("chair_a", "dining_chair", (-0.3, 3.0), (0.46, 0.53, 0.95)),
        ("chair_b", "dining_chair", (0.3, 3.0), (0.46, 0.53, 0.95)),
        ("chair_c", "dining_chair", (0.0, 4.4), (0.46, 0.53, 0.95)),
    )
    got = choose_headings(two_rows, 0.0, _flat_box(3)(two_rows))
    assert _front(got["chair_a"].yaw) == (0, 1) and _front(got["chair_b"].yaw) == (0, 1)  # their backs to the camera
    assert _front(got["chair_c"].yaw) == (0, -1)
    assert "faces its dining group" in got["chair_a"].reason


@pytest.mark.parametrize(("name", "chairs"), [("v_19325_lamp", ("dining_chair_1", "dining_chair_2")), ("v_19325_table", ("dining_chair_1", "dining_chair_2"))])
def test_chairs_of_a_table_out_of_view_read_from_their_rows(name: str, chairs: tuple[str, ...]) -> None:
    """The 19325 chairs stand round a table the boxes leave out: two side by side in a row face
    across it (they came out 90 degrees off when they faced the middle of their group)."""
    result = _read(name)
    score = score_against_truth(result.reconstruction, _truth(name), float(result.report["camera_height_m"]))
    heading = {o.id: o.heading_error_deg for o in score.objects}
    for oid in chairs:
        assert heading[oid] is not None and heading[oid] < 20.0, (oid, heading[oid])


def test_dining_chairs_in_rows_face_their_table() -> None:
    """The 8714 chairs stand in two rows along a 2.5 m table; their places, 0.5 m off, put two of
    them past its ends, where facing the nearest edge turned them a quarter turn. Their rows
    keep all four square to the table."""
    for name in ("livingdining_8714", "v_8714_tall"):
        result = _read(name)
        score = score_against_truth(result.reconstruction, _truth(name), float(result.report["camera_height_m"]))
        chairs = [o for o in score.objects if o.category == "dining_chair"]
        assert len(chairs) == 4
        assert all(o.heading_error_deg is not None and o.heading_error_deg < 20.0 for o in chairs), [(o.id, o.heading_error_deg) for o in chairs]


def test_lamp_hangs_over_the_table_its_chairs_point_at() -> None:
    """The 19325 linear pendant, cut by the top and the left of the picture, over a table out of
    view: the chairs in view point at where that table stands, and the lamp hangs there (it
    landed 1.6 m off hanging free)."""
    result = _read("v_19325_lamp")
    assert result.report["hangs_over"] == {"pendant_lamp_0": "the table of dining_chair_1 (out of view)"}
    boxes = {o.id: o.box for o in result.inventory}
    score = score_against_truth(result.reconstruction, _truth("v_19325_lamp"), float(result.report["camera_height_m"]), boxes)
    lamp = next(o for o in score.objects if o.id == "pendant_lamp_0")
    assert lamp.cut and lamp.position_error_m < 0.5, lamp.position_error_m


def test_a_cut_bed_turns_with_its_nightstands_box() -> None:
    """The 11659 portrait view: the bed cut by two borders fits its box turned any way, and its
    one nightstand, placed behind it, says nothing of its head's side; the nightstand's own box
    tells their shared axis (both came out 90 degrees off)."""
    result = _read("v_11659_portrait")
    score = score_against_truth(result.reconstruction, _truth("v_11659_portrait"), float(result.report["camera_height_m"]))
    heading = {o.id: o.heading_error_deg for o in score.objects}
    for oid in ("double_bed_0", "nightstand_0"):
        assert heading[oid] is not None and heading[oid] < 20.0, (oid, heading[oid])
    assert "nightstand_0's box" in result.report["headings"]["double_bed_0"]
    items = _items(  # a hand-made check: the nightstand's box decides between two equal readings
        ("bed", "double_bed", (0.0, 3.0), (1.6, 2.1, 0.9)),
        ("stand", "nightstand", (0.0, 5.0), (0.45, 0.4, 0.55)),
    )
    for axis in (0, 1):
        got = choose_headings(items, 0.0, lambda i, k, axis=axis: (40.0 if (i == 1 and k % 2 != axis) else 0.0, items[i].centre, items[i].size))
        assert got["bed"].quarter % 2 == axis and got["stand"].quarter % 2 == axis


# -- what holds what in place ---------------------------------------------------------------------
def _errors(name: str) -> tuple[Any, dict[str, Any]]:
    result = _read(name)
    boxes = {o.id: o.box for o in result.inventory}
    score = score_against_truth(
        result.reconstruction, _truth(name), float(result.report["camera_height_m"]), boxes
    )
    return result, {o.id: o for o in score.objects}


def test_a_vase_on_a_shelf_stands_inside_the_bookshelf() -> None:
    """The low wide demo view: the vase stands on a shelf of the open bookshelf, 0.35 m below its
    top. Held to the top, the fit carried it 0.6 m off; a shelf inside is now a hypothesis of its
    own, the vase's footprint held over the bookshelf's either way."""
    result, scored = _errors("v_demo_low_wide")
    assert result.report["resting"]["vase"] == "in"
    assert scored["vase"].position_error_m < 0.25, scored["vase"].position_error_m
    shelf = next(o for o in result.reconstruction.objects if o.id == "bookshelf")
    vase = next(o for o in result.reconstruction.objects if o.id == "vase")
    # in the camera frame (y down): the vase's bottom lies between the bookshelf's bottom and top
    assert shelf.position[1] - shelf.extents[2] < vase.position[1] < shelf.position[1]


def test_what_rests_on_nothing_seen_stands_on_the_floor_when_a_support_would_show() -> None:
    """The second demo view's plant (0.9 m, larger than the catalogue's): its lower edge is well
    inside the picture and nothing is boxed below it, so a table holding it would show; it stands
    on the floor (it was set on furniture out of view, 1.2 m off)."""
    result, scored = _errors("demo_bedroom_b")
    assert result.report["resting"]["plant"] == "floor"
    assert scored["plant"].position_error_m < 0.2, scored["plant"].position_error_m


def test_support_may_hide_only_at_the_border_or_behind_another_object() -> None:
    from scenemosaic.perception import DetectedObject, ObjectMask, SeenObject
    from scenemosaic.perception._image import Camera
    from scenemosaic.perception._lift import _support_may_hide

    camera = Camera(width=640, height=480, fx=500.0, fy=500.0, cx=320.0, cy=240.0)

    def seen(oid: str, box: tuple[float, float, float, float]) -> SeenObject:
        mask = ObjectMask((0, 0), np.zeros((0, 0), dtype=bool))
        return SeenObject(DetectedObject(id=oid, label="vase", box=box), mask, "surface")

    vase = seen("vase", (100, 100, 140, 200))
    assert not _support_may_hide(vase, [vase], camera)
    cut = seen("cut", (100, 400, 140, 480))
    assert _support_may_hide(cut, [cut], camera)
    sofa = seen("sofa", (60, 190, 300, 400))  # its box covers the rows under the vase
    assert _support_may_hide(vase, [vase, sofa], camera)
    aside = seen("aside", (300, 190, 500, 400))  # beside it: covers nothing under the vase
    assert not _support_may_hide(vase, [vase, aside], camera)


@pytest.mark.parametrize("name", ["v_11659_wide", "v_11659_lamp", "v_11659_portrait"])
def test_a_cut_bed_is_held_at_its_head_by_its_nightstands(name: str) -> None:
    """The 11659 bed (2.42 m, longer than the catalogue's) is cut by the picture's borders in every
    view, and its fit alone set its head 0.7-0.9 m short of the wall its nightstands back onto.
    Its head and their backs now stand on one line, and it lands within 0.5 m."""
    result, scored = _errors(name)
    assert "nightstand_0" in result.report["held_by"]["double_bed_0"]
    assert scored["double_bed_0"].position_error_m < 0.5, scored["double_bed_0"].position_error_m


@pytest.mark.parametrize("name", ["livingdining_8714", "v_13536_diag"])
def test_a_cut_table_is_held_by_the_chairs_facing_it(name: str) -> None:
    """A dining table cut by two borders (8714: 2.5 m against the catalogue's 1.6; 13536: 0.63 m
    high against 0.75) landed 0.7 m off, in among its own chairs. The chairs facing it, whose
    boxes are whole, now hold it before them, and it lands within 0.5 m."""
    result, scored = _errors(name)
    assert "dining_chair_0" in result.report["held_by"]["dining_table_0"]
    assert scored["dining_table_0"].position_error_m < 0.5, scored["dining_table_0"].position_error_m


def test_a_known_camera_height_sets_the_rooms_scale(tmp_path: Path) -> None:
    """A single view fixes the room only up to one scale. The 1.8 m view of room 8714, whose
    furniture runs larger than the catalogue, comes out 0.2 m low and its dining group 0.6 m
    off; given the camera's height (``--camera-height``), the scene stands at that height, every
    floor piece's place and size scaled by one factor, and the whole group lands within 0.3 m."""
    name = "v_8714_tall"
    truth = _truth(name)
    height = float(truth["camera"]["position"][2])
    folder = DATA / name
    plain = _read(name)
    given = asyncio.run(
        perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="box", reconstructor=BoxLifter(), camera_height_m=height)
    )
    assert given.report["camera_height_m"] == height and given.report["camera_height_fit_m"] == plain.report["camera_height_m"]
    factor = given.report["scale_from_camera_height"]
    assert factor == pytest.approx(height / plain.report["camera_height_m"], rel=1e-3) and factor > 1.05
    before = {o.id: o for o in plain.reconstruction.objects}
    for o in given.reconstruction.objects:  # one factor for every floor piece's place and size (the refits after it converge within 1 %)
        assert o.placement == "floor"
        assert np.allclose(o.position, before[o.id].position * factor, rtol=0.01, atol=0.01), o.id
        assert np.allclose(o.extents, np.array(before[o.id].extents) * factor, rtol=0.01), o.id
    scene_height = np.array(given.scene.metadata["camera"]["world_from_camera"]).reshape(4, 4)[2, 3]
    assert scene_height == pytest.approx(height, abs=1e-6)
    for result, limit in ((plain, None), (given, 0.3)):
        score = score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]))
        group = [o.position_error_m for o in score.objects if o.category in ("dining_chair", "dining_table")]
        if limit is None:
            assert max(group) > 0.5  # what the catalogue's scale alone gives
        else:
            assert max(group) < limit, group
    from scenemosaic.exceptions import UsageError
    from scenemosaic.perception._frame import at_camera_height

    with pytest.raises(UsageError, match="positive number of metres"):
        at_camera_height(plain.reconstruction, -1.0)
    with pytest.raises(UsageError, match="positive number of metres"):  # refused before any work
        asyncio.run(perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="box", camera_height_m=float("nan")))


def test_generate_takes_the_camera_height(tmp_path: Path) -> None:
    """``generate photo.png --camera-height 1.6``: the import stage's record and the scene's camera
    say the given height, and the fit's own reading is kept beside it."""
    from scenemosaic.exchange import read_scene
    from scenemosaic.pipeline import GenerateConfig, generate

    folder = DATA / "demo_bedroom"
    config = GenerateConfig(detections=folder / "boxes.json", segmenter="box", reconstructor="box-lifter", evolve=False, camera_height_m=1.6)
    result = generate(folder / "photo.png", tmp_path / "run", config)
    perception = result.report["stages"][0]["detail"]["perception"]
    assert perception["camera_height_m"] == 1.6 and perception["camera_height_given_m"] == 1.6
    assert perception["camera_height_fit_m"] != 1.6 and perception["scale_from_camera_height"] > 0
    scene = read_scene(tmp_path / "run" / "base")
    assert np.array(scene.metadata["camera"]["world_from_camera"]).reshape(4, 4)[2, 3] == pytest.approx(1.6, abs=1e-6)


def test_at_camera_height_scales_any_reconstruction_about_the_camera() -> None:
    """The path for reconstructors that do not take the height themselves (SAM 3D, a server):
    the camera height of the result, from its floor plane or else from its floor objects'
    bottoms, is brought to the given one by a single factor."""
    from scenemosaic.perception._frame import at_camera_height

    upright = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # the object's Z along the camera's up (-y)
    chair = LiftedObject("chair", "dining_chair", "floor", np.array([0.5, 1.2, 3.0]), upright, (0.5, 0.5, 0.9))
    vase = LiftedObject("vase", "vase", "surface", np.array([0.1, 0.4, 2.0]), upright, (0.1, 0.1, 0.3))
    with_plane = Reconstruction([chair, vase], floor_up=np.array([0.0, -1.0, 0.0]), camera_height=1.2)
    scaled, k = at_camera_height(with_plane, 1.5)
    assert k == pytest.approx(1.25) and scaled.camera_height == pytest.approx(1.5)
    assert np.allclose(scaled.objects[1].position, [0.125, 0.5, 2.5]) and np.allclose(scaled.objects[1].extents, [0.125, 0.125, 0.375])
    from_objects, k2 = at_camera_height(Reconstruction([chair, vase]), 1.8)  # the chair's bottom, 1.2 m below the camera
    assert k2 == pytest.approx(1.5) and from_objects.camera_height is None
    assert np.allclose(from_objects.objects[0].position, [0.75, 1.8, 4.5])


def test_only_a_chair_close_to_its_table_is_refitted_with_it() -> None:
    """A chair facing its table from 0.3 m is held before it; one set back 1.3 m (against a wall,
    say) is not, nor one that turns its back to the table; a bed holds the nightstands turned
    as it is, not one turned away."""
    from scenemosaic.perception import DetectedObject, ObjectMask, SeenObject
    from scenemosaic.perception._headings import HeadingChoice
    from scenemosaic.perception._lift import _held_together

    rows = (
        ("table", "dining_table", (0.0, 4.0), (1.6, 0.9, 0.75)),
        ("near", "dining_chair", (0.0, 3.25), (0.46, 0.53, 0.95)),  # 0.3 m before the near edge
        ("far", "dining_chair", (0.6, 5.75), (0.46, 0.53, 0.95)),  # 1.3 m beyond the far edge, facing it
        ("away", "dining_chair", (-0.6, 3.25), (0.46, 0.53, 0.95)),  # before the edge, its back to it
        ("bed", "double_bed", (4.0, 3.0), (1.6, 2.1, 0.9)),
        ("stand", "nightstand", (5.1, 3.8), (0.45, 0.4, 0.55)),
        ("odd", "nightstand", (2.9, 3.8), (0.45, 0.4, 0.55)),
    )
    items = _items(*rows)
    # yaw 0 faces -Y (toward the camera); pi faces +Y
    yaws = {"table": 0.0, "near": math.pi, "far": 0.0, "away": 0.0, "bed": 0.0, "stand": 0.0, "odd": math.pi / 2}
    headings = {k: HeadingChoice(v, 0, "") for k, v in yaws.items()}
    mask = ObjectMask((0, 0), np.zeros((0, 0), dtype=bool))
    floor = [SeenObject(DetectedObject(id=i, label=c, box=(0, 0, 10, 10)), mask, "floor") for i, c, _xy, _s in rows]
    flush, seats = _held_together(floor, items, headings)
    assert seats == [(1, 0)]
    assert flush == [(4, 5)]

"""The image front end on renders of known scenes (``data/images/``): the offline path end to end,
and how close the box lifter lands to the truth.

``pytest -s`` prints each fixture's error distribution (the figures of the closing note).
"""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenemosaic.exchange import read_scene
from scenemosaic.models import RulesModel
from scenemosaic.perception import perceive
from scenemosaic.pipeline import GenerateConfig, generate

DATA = Path(__file__).resolve().parents[2] / "data" / "images"
FIXTURES = sorted(p.name for p in DATA.iterdir() if (p / "truth.json").is_file() and not p.name.startswith("v_")) if DATA.is_dir() else []
"""The original renders (1.6 m, 60 degrees); the varied ones (``v_*``) are read in test_reading.py."""
LIFT_TOLERANCE_M = 0.5
"""The issue's bar: objects within the lifter's reach land this close to the truth (bottom centre, XY)."""
OUTSIDE_REACH_M = 1.5
"""A regression bound for the rest: objects resting on nothing in view, or cut by the image's border."""
DEMO_VIEWS = ("demo_bedroom", "demo_bedroom_b")


def _truth(name: str) -> dict[str, Any]:
    return json.loads((DATA / name / "truth.json").read_text())


def test_fixtures_are_shipped() -> None:
    assert {*DEMO_VIEWS, "livingdining_8714"} <= set(FIXTURES)


def _within_reach(placements: dict[str, str], boxes: dict[str, tuple[float, ...]], width: int, height: int) -> set[str]:
    """Objects the box lifter can place from their box: standing on the floor, or on furniture
    in view, with neither box cut by the image's border."""

    def whole(oid: str) -> bool:
        x0, y0, x1, y1 = boxes[oid]
        return x0 > 1 and y0 > 1 and x1 < width - 1 and y1 < height - 1

    out = set()
    for oid, where in placements.items():
        support = where[3:] if where.startswith("on ") else None
        if (where == "floor" or support) and whole(oid) and (support is None or whole(support)):
            out.add(oid)
    return out


@pytest.mark.parametrize("name", FIXTURES)
def test_box_lifter_lands_near_the_truth(name: str) -> None:
    folder = DATA / name
    truth = _truth(name)
    result = asyncio.run(
        perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="grabcut", reconstructor="box-lifter")
    )
    world_from_camera = np.array(truth["camera"]["world_from_camera"], dtype=np.float64).reshape(4, 4)
    true_pos = {o["id"]: np.array(o["position"]) for o in truth["objects"]}
    boxed = {o["id"] for o in truth["objects"] if o["in_boxes"]}
    assert {o.id for o in result.reconstruction.objects} == boxed
    errors: dict[str, float] = {}
    for o in result.reconstruction.objects:
        world = world_from_camera[:3, :3] @ o.position + world_from_camera[:3, 3]
        errors[o.id] = float(np.linalg.norm(world[:2] - true_pos[o.id][:2]))
    boxes = {o.id: o.box for o in result.inventory}
    reach = _within_reach(result.report["placements"], boxes, truth["image"]["width"], truth["image"]["height"])
    values = np.array(sorted(errors.values()))
    fit = result.report
    cam = truth["camera"]
    print(
        f"\n{name}: {len(values)} objects ({len(reach)} within reach), lift error (m) median {np.median(values):.3f}, "
        f"p90 {np.quantile(values, 0.9):.3f}, max {values.max():.3f}; camera height {fit['camera_height_m']:.3f} "
        f"(true {cam['position'][2]:.3f}), pitch {fit['camera_pitch_deg']:.1f} deg (true {cam['pitch_deg']:.1f}); "
        f"room direction {fit.get('room_direction_deg')} deg (camera yaw {cam['yaw_deg']:.0f} deg)"
    )
    for oid, err in sorted(errors.items(), key=lambda kv: -kv[1]):
        print(f"  {oid:28s} {err:.3f} {'within reach' if oid in reach else result.report['placements'][oid]}")
    assert abs(fit["camera_height_m"] - cam["position"][2]) < 0.25
    # the room's direction: the camera's yaw against the walls, modulo 90 degrees
    measured = fit.get("room_direction_deg")
    expected = (cam["yaw_deg"] + 45.0) % 90.0 - 45.0
    assert measured is not None and abs((measured - expected + 45.0) % 90.0 - 45.0) < 3.0
    assert values.max() < OUTSIDE_REACH_M, errors
    # frame recovery: the scene's world differs from the truth's by a turn about Z of a multiple of
    # 90 degrees (gravity from the floor, the room's axes from its edges) and a shift
    recovered = np.array(result.scene.metadata["camera"]["world_from_camera"]).reshape(4, 4)[:3, :3]
    turn = world_from_camera[:3, :3] @ recovered.T
    tilt = math.degrees(math.acos(min(1.0, float(turn[2, 2]))))
    spin = math.degrees(math.atan2(turn[1, 0], turn[0, 0]))
    print(f"  frame: tilt {tilt:.2f} deg, turn {spin:.2f} deg (a multiple of 90 expected)")
    assert tilt < 3.0
    assert abs((spin + 45.0) % 90.0 - 45.0) < 3.0
    if name in DEMO_VIEWS:
        far = {k: round(v, 3) for k, v in errors.items() if k in reach and v >= LIFT_TOLERANCE_M}
        assert len(reach) >= 4 and not far, far
    else:  # 3D-FRONT furniture runs 10-25 % larger than the catalogue sizes: depth errors grow with it
        assert float(np.median(values)) < 0.75


@pytest.mark.parametrize("name", FIXTURES[:1])
def test_offline_photo_to_scene_end_to_end(name: str, tmp_path: Path) -> None:
    """`generate photo.png --detections boxes.json --segmenter grabcut --reconstructor box-lifter`:
    every detected object is in the scene, floor objects on the floor, nothing out of the room,
    nothing colliding or falling."""
    folder = DATA / name
    out = tmp_path / "run"
    config = GenerateConfig(detections=folder / "boxes.json", segmenter="grabcut", reconstructor="box-lifter", variants=2)
    result = generate(folder / "photo.png", out, config)
    coco = json.loads((folder / "boxes.json").read_text())
    detected = {a["attributes"]["object_id"] for a in coco["annotations"]}
    scene = read_scene(out / "base")
    assert {o.id for o in scene.objects} == detected
    placements = result.report["stages"][0]["detail"]["perception"]["placements"]
    for o in scene.objects:
        if placements[o.id] == "floor":
            assert abs(o.pose.position[2]) < 0.02, (o.id, o.pose.position)
    validation = result.report["validation"]
    assert validation["collisions"]["pairs"] == []
    assert validation["fell"] == []
    metrics = result.metrics
    assert metrics is not None and metrics["base"]["OOB"] == 0 and metrics["base"]["COL"] == 0
    assert result.report["variants_written"] >= 1
    assert (out / "perception" / "inventory.json").is_file()
    assert scene.provenance.source_format == "image"

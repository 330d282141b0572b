"""3D-FRONT / PhyScene layouts from the shared data."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from scenemosaic.exchange import detect_format, load_scene, load_scenes
from scenemosaic.scene import (
    CEILING_LAMP_CATEGORIES,
    ROOM_MARGIN,
    TOP_CLEARANCE,
    WALL_SNAP_GAP,
    Pose,
    Room,
    SceneObject,
    dominant_orientation,
    front_vector,
    traits,
)


def _raw_objects(path: Path) -> list[dict[str, Any]]:
    data = json.loads(path.read_text())
    return [obj for entries in data["ThreedFront"].values() for obj in entries]


def test_every_physcene_layout_imports_with_its_object_count(physcene_files: list[Path]) -> None:
    assert len(physcene_files) == 7
    for path in physcene_files:
        assert detect_format(path) == "front3d"
        scene = load_scene(path)
        raw = _raw_objects(path)
        assert len(scene.objects) == len(raw) > 0, path.name
        assert [o.category for o in scene.objects] == [o["label"] for o in raw]
        assert len({o.id for o in scene.objects}) == len(scene.objects)
        assert scene.provenance.source_format == "front3d"
        assert scene.provenance.source_path == path.as_posix()
        assert scene.provenance.importer == "scenemosaic.exchange.front3d"
        assert scene.room is not None and len(scene.room.walls) == 4
        assert all(o.asset.kind == "procedural" and o.asset.category == o.category for o in scene.objects)


def test_ids_are_label_and_count_and_stable(physcene_files: list[Path]) -> None:
    path = next(p for p in physcene_files if p.name.startswith("DiningRoom-19325"))
    a, b = load_scene(path), load_scene(path)
    assert a.to_json() == b.to_json()
    assert [o.id for o in a.objects] == [
        "dining_chair_0",
        "dining_chair_1",
        "dining_chair_2",
        "dining_chair_3",
        "dining_table_0",
        "pendant_lamp_0",
    ]
    assert a.get("dining_chair_2").description == "dining chair"


def test_known_object_size_and_z_up_placement(physcene_files: list[Path]) -> None:
    path = next(p for p in physcene_files if p.name.startswith("DiningRoom-19325"))
    raw = next(o for o in _raw_objects(path) if o["label"] == "dining_table")
    sx, sy, sz = (float(v) for v in raw["size"])
    px, py, pz = (float(v) for v in raw["position"])
    table = load_scene(path).get("dining_table_0")
    fp = table.footprint()
    edges = sorted(float(np.linalg.norm(fp[(i + 1) % 4] - fp[i])) for i in range(4))
    assert edges[0] == pytest.approx(2 * min(sx, sz), abs=1e-6)
    assert edges[-1] == pytest.approx(2 * max(sx, sz), abs=1e-6)
    lo, hi = table.aabb()
    assert lo[2] == pytest.approx(py, abs=1e-9)  # Y-up height became Z
    assert hi[2] - lo[2] == pytest.approx(2 * sy, abs=1e-6)
    assert table.pose.position[:2] == pytest.approx((px, -pz), abs=1e-12)  # (x, y, z) -> (x, -z, y)
    assert table.pose.yaw == pytest.approx(raw["theta"], abs=1e-9)


def test_dining_chair_faces_the_table(physcene_files: list[Path]) -> None:
    """Proves the theta convention: yaw = +theta makes the chair face the table, -theta would not."""
    path = next(p for p in physcene_files if p.name.startswith("DiningRoom-19325"))
    scene = load_scene(path)
    table = np.asarray(scene.get("dining_table_0").pose.position[:2])
    chair = scene.get("dining_chair_1")
    to_table = table - np.asarray(chair.pose.position[:2])
    to_table /= np.linalg.norm(to_table)

    def angle(yaw: float) -> float:
        front = front_vector(Pose.from_yaw((0, 0, 0), yaw).quaternion)[:2]
        return math.degrees(math.acos(float(np.clip(front @ to_table, -1, 1))))

    assert angle(chair.pose.yaw) < 45
    assert angle(-chair.pose.yaw) > 90  # the opposite sign convention would face away


def test_recovered_room_contains_every_footprint_with_margin_or_a_backing_wall(physcene_files: list[Path]) -> None:
    """Every footprint inside; each side either keeps the margin or is the wall that furniture backs onto."""
    snapped_sides = 0
    for path in physcene_files:
        scene = load_scene(path)
        assert scene.room is not None
        floor = Polygon(scene.room.floor)
        for obj in scene.objects:
            assert floor.covers(Polygon(obj.corners()[:, :2]).convex_hull), (path.name, obj.id)
            top = float(obj.corners()[:, 2].max())
            clearance = 0.0 if obj.category in CEILING_LAMP_CATEGORIES else TOP_CLEARANCE
            assert scene.room.ceiling_height >= top + clearance - 1e-9, (path.name, obj.id)
        assert scene.room.ceiling_height >= 2.6
        for wall in scene.room.walls:
            edge = LineString([wall.start, wall.end])
            gaps = {o.id: edge.distance(Polygon(o.corners()[:, :2]).convex_hull) for o in scene.objects}
            gap = min(gaps.values())
            outermost = [o for o in scene.objects if gaps[o.id] < gap + 0.05]
            if gap < ROOM_MARGIN - 1e-6:  # closer than the margin: a wall that furniture backs onto, 2 cm behind
                assert any(traits(o.category).against_wall for o in outermost), (path.name, wall.id)
                assert gap == pytest.approx(WALL_SNAP_GAP, abs=1e-6), (path.name, wall.id)
                snapped_sides += 1
            else:
                assert gap == pytest.approx(ROOM_MARGIN, abs=1e-6), (path.name, wall.id)
    assert snapped_sides >= 6  # wardrobes, beds and sofas imply their walls


def test_raw_generator_errors_are_kept(physcene_files: list[Path]) -> None:
    """Sunk and floating objects are the refinement's job: the importer leaves them alone."""
    bottoms = []
    for path in physcene_files:
        raw = _raw_objects(path)
        scene = load_scene(path)
        for r, o in zip(raw, scene.objects, strict=True):
            assert o.pose.position[2] == pytest.approx(r["position"][1], abs=1e-12)
            bottoms.append(o.pose.position[2])
    assert min(bottoms) < -0.1  # some objects are sunk into the floor ...
    assert max(b for b in bottoms if b < 1.0) > 0.1  # ... and some float


def test_dominant_orientation_follows_the_largest_objects() -> None:
    def box(i: int, yaw: float, w: float, d: float) -> SceneObject:
        return SceneObject.model_validate(
            {
                "id": f"o{i}",
                "category": "box",
                "asset": {"kind": "box", "extents": (w, d, 1.0)},
                "pose": Pose.from_yaw((i * 3.0, 0.0, 0.0), yaw),
            }
        )

    tilt = math.radians(20)
    objs = [box(0, tilt, 2.0, 1.5), box(1, tilt + math.pi / 2, 1.8, 1.0), box(2, 0.0, 0.3, 0.3)]
    assert dominant_orientation(objs) == pytest.approx(tilt, abs=math.radians(0.5))
    assert dominant_orientation([box(0, math.radians(0.4), 1.0, 1.0)]) == 0.0  # snapped to the axes


def test_room_argument_replaces_the_recovered_room(physcene_files: list[Path]) -> None:
    room = Room.rectangle(-5, -5, 5, 5, ceiling_height=3.0)
    scene = load_scene(physcene_files[0], room=room)
    assert scene.room == room
    assert scene.metadata["front3d"]["room_recovered"] is False


def test_folder_of_layouts_gives_one_scene_per_file(physcene_files: list[Path]) -> None:
    scenes = load_scenes(physcene_files[0].parent)
    assert [s.provenance.source_path for s in scenes] == [p.as_posix() for p in physcene_files]

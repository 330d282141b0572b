"""SAM3D-style object sets over the real shared meshes."""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation
from shapely.geometry import Polygon

import scenemosaic.assets
from scenemosaic.exchange import (
    detect_format,
    load_scene,
    read_scene,
    read_sdf_sim,
    save_scene,
    write_sam3d_example,
)
from scenemosaic.scene import Scene, front_vector


@pytest.fixture(scope="module")
def scene(sam3d_example: Path) -> Scene:
    return load_scene(sam3d_example)


def test_example_imports_five_mesh_objects(scene: Scene, sam3d_example: Path) -> None:
    assert detect_format(sam3d_example) == "sam3d"
    assert [o.id for o in scene.objects] == ["bed", "work_desk", "office_chair", "printer", "coffee_mug"]
    for obj in scene.objects:
        assert obj.asset.kind == "mesh"
        assert (
            obj.asset.uri is not None and Path(obj.asset.uri).is_absolute() and Path(obj.asset.uri).is_file()
        )
        assert obj.asset.sha256 is not None and re.fullmatch(r"[0-9a-f]{64}", obj.asset.sha256)
        assert obj.asset.source_transform is not None and len(obj.asset.source_transform) == 16
    assert scene.provenance.source_format == "sam3d"
    assert scene.provenance.source_path == (sam3d_example / "poses.json").as_posix()


def test_extents_are_sensible(scene: Scene) -> None:
    bed = scene.get("bed").size
    assert bed[0] > bed[2] and bed[1] > bed[2]  # a bed is wider and longer than tall
    assert 1.5 < bed[0] < 2.5 and 0.5 < bed[2] < 1.5
    mug = scene.get("coffee_mug").size
    assert max(mug) < 0.2
    desk = scene.get("work_desk").size
    assert desk[0] > desk[1] and 0.6 < desk[2] < 0.9  # a desk is wider than deep, about 0.75 m tall


def test_layout_of_the_example(scene: Scene) -> None:
    desk_top = float(scene.get("work_desk").aabb()[1][2])
    for oid in ("printer", "coffee_mug"):
        assert scene.get(oid).aabb()[0][2] == pytest.approx(desk_top, abs=1e-6), oid
        desk_fp = Polygon(scene.get("work_desk").footprint())
        assert desk_fp.buffer(1e-6).covers(Polygon(scene.get(oid).footprint())), oid
    for oid in ("bed", "work_desk", "office_chair"):
        assert scene.get(oid).aabb()[0][2] == pytest.approx(0.0, abs=1e-6), oid
    chair, desk = scene.get("office_chair"), scene.get("work_desk")
    to_desk = np.asarray(desk.pose.position[:2]) - np.asarray(chair.pose.position[:2])
    assert np.linalg.norm(to_desk) < 1.2
    assert front_vector(chair.pose.quaternion)[:2] @ to_desk / np.linalg.norm(to_desk) > 0.95
    assert scene.room is not None
    floor = Polygon(scene.room.floor)
    assert floor.area == pytest.approx(25.0)
    for obj in scene.objects:
        assert floor.covers(Polygon(obj.footprint())), obj.id
        assert obj.aabb()[1][2] < scene.room.ceiling_height


def test_sim_attributes_come_from_the_sdf_files(scene: Scene, sam3d_dir: Path) -> None:
    sdf = next(sam3d_dir.glob("generated_assets/sdf/king_bed_*/king_bed.sdf"))
    text = sdf.read_text()
    mass = float(re.search(r"<mass>\s*([0-9.]+)\s*</mass>", text).group(1))  # type: ignore[union-attr]
    mu = float(re.search(r"<mu>\s*([0-9.]+)\s*</mu>", text).group(1))  # type: ignore[union-attr]
    assert scene.get("bed").sim.mass_kg == pytest.approx(mass)
    assert scene.get("bed").sim.friction == pytest.approx(mu)
    assert read_sdf_sim(sdf).mass_kg == pytest.approx(mass)
    masses = {o.id: o.sim.mass_kg for o in scene.objects}
    assert all(m is not None and m > 0 for m in masses.values())
    assert masses["coffee_mug"] < masses["office_chair"] < masses["bed"]  # type: ignore[operator]


def test_world_placement_of_the_source_mesh_is_preserved(scene: Scene, sam3d_example: Path) -> None:
    """The canonical box equals the source mesh moved by the file's own pose."""
    doc = json.loads((sam3d_example / "poses.json").read_text())
    for entry in doc["objects"]:
        mesh = trimesh.load(sam3d_example / entry["mesh"], force="mesh")
        assert isinstance(mesh, trimesh.Trimesh)
        w, x, y, z = entry["quaternion"]
        rot = Rotation.from_quat([x, y, z, w]).as_matrix()
        world = (np.asarray(mesh.vertices) * entry["scale"]) @ rot.T + entry["position"]
        lo, hi = scene.get(entry["id"]).aabb()
        assert world.min(axis=0) == pytest.approx(lo, abs=1e-5), entry["id"]
        assert world.max(axis=0) == pytest.approx(hi, abs=1e-5), entry["id"]


def test_backs_are_behind_the_front(scene: Scene, sam3d_example: Path) -> None:
    """The bed's headboard and the chair's backrest lie opposite the object's front vector."""
    doc = json.loads((sam3d_example / "poses.json").read_text())
    for entry in doc["objects"]:
        if entry["id"] not in ("bed", "office_chair"):
            continue
        mesh = trimesh.load(sam3d_example / entry["mesh"], force="mesh")
        assert isinstance(mesh, trimesh.Trimesh)
        w, x, y, z = entry["quaternion"]
        world = np.asarray(mesh.vertices) @ Rotation.from_quat([x, y, z, w]).as_matrix().T + entry["position"]
        tall = world[world[:, 2] > 0.85 * world[:, 2].max()]
        obj = scene.get(entry["id"])
        to_back = tall[:, :2].mean(axis=0) - np.asarray(obj.pose.position[:2])
        assert float(front_vector(obj.pose.quaternion)[:2] @ to_back) < -0.15, entry["id"]


def test_y_up_poses_give_the_same_scene(scene: Scene, sam3d_dir: Path, tmp_path: Path) -> None:
    write_sam3d_example(tmp_path, sam3d_dir, frame="y_up")
    doc = json.loads((tmp_path / "poses.json").read_text())
    assert doc["frame"] == "y_up"
    other = load_scene(tmp_path)
    assert other.room is not None and scene.room is not None
    assert Polygon(other.room.floor).equals_exact(Polygon(scene.room.floor), 1e-9) or Polygon(
        other.room.floor
    ).symmetric_difference(Polygon(scene.room.floor)).area == pytest.approx(0.0, abs=1e-9)
    for a, b in zip(scene.objects, other.objects, strict=True):
        assert a.pose.position == pytest.approx(b.pose.position, abs=1e-7)
        assert abs(float(np.dot(a.pose.quaternion, b.pose.quaternion))) == pytest.approx(1.0, abs=1e-9)
        assert a.pose.scale == pytest.approx(b.pose.scale, abs=1e-9)


def test_round_trip_through_a_native_folder(scene: Scene, tmp_path: Path) -> None:
    first = save_scene(scene, tmp_path / "a")
    back = read_scene(first)
    assert all(o.asset.uri is not None and o.asset.uri.startswith("assets/") for o in back.objects)
    assert [o.asset.sha256 for o in back.objects] == [o.asset.sha256 for o in scene.objects]
    for obj in back.objects:
        assert (tmp_path / "a" / str(obj.asset.uri)).is_file()
    second = save_scene(back, tmp_path / "b", base_dir=tmp_path / "a")
    assert first.read_bytes() == second.read_bytes()
    assert read_scene(second) == back


@dataclass
class _FakeCanonical:
    mesh: Any
    transform: np.ndarray
    sha256: str
    extents: tuple[float, float, float]


def test_pose_composition_with_a_known_canonical_transform(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Independent of the real mesh loader: a Y-up file in centimetres, canonicalized by a known C."""
    (tmp_path / "box.obj").write_text("v 0 0 0\n")
    unit = 0.01
    c = np.eye(4)  # source (cm, Y-up, origin at the box's corner) -> canonical (m, Z-up, bottom centre)
    c[:3, :3] = unit * np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    c[:3, 3] = [-0.5, 0.25, 0.0]

    def fake_load_mesh(path: Path, *, up_axis: str = "auto", unit_scale: float = 1.0) -> _FakeCanonical:
        assert unit_scale == unit
        return _FakeCanonical(mesh=None, transform=c, sha256="0" * 64, extents=(1.0, 0.5, 0.8))

    monkeypatch.setattr(scenemosaic.assets, "load_mesh", fake_load_mesh, raising=False)
    monkeypatch.setattr(scenemosaic.assets, "mesh_hash", lambda mesh: "1" * 64, raising=False)
    yaw = math.radians(30)
    # a pose in a Y-up world in cm: rotate the source by yaw about +Y, put it at (200, 0, -100)
    q = Rotation.from_euler("y", yaw).as_quat()
    doc = {
        "units": "cm",
        "frame": "y_up",
        "objects": [
            {
                "label": "Crate",
                "mesh": "box.obj",
                "position": [200.0, 0.0, -100.0],
                "quaternion": [q[3], q[0], q[1], q[2]],
                "scale": [2.0, 2.0, 2.0],
            }
        ],
    }
    (tmp_path / "poses.json").write_text(json.dumps(doc))
    scene = load_scene(tmp_path / "poses.json")
    obj = scene.objects[0]
    assert obj.id == "crate_0" and obj.category == "crate"
    # the canonical origin is the source point C^-1 (0, 0, 0) = (50, 0, 25) cm; scaled by 2, turned, moved
    src = np.array([50.0, 0.0, 25.0]) * 2.0
    world_y_up = Rotation.from_euler("y", yaw).as_matrix() @ src + [200.0, 0.0, -100.0]
    expected = unit * np.array([world_y_up[0], -world_y_up[2], world_y_up[1]])
    assert obj.pose.position == pytest.approx(tuple(expected), abs=1e-9)
    assert obj.pose.scale == pytest.approx((2.0, 2.0, 2.0))
    assert obj.pose.yaw == pytest.approx(yaw, abs=1e-9)  # a turn about +Y is the same turn about +Z
    assert obj.asset.extents == (1.0, 0.5, 0.8)
    assert scene.room is not None  # recovered from the single object
    assert "room recovered" in " ".join(scene.provenance.notes)


def test_front_axis_turns_the_canonical_frame(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    (tmp_path / "box.obj").write_text("v 0 0 0\n")
    mesh = trimesh.creation.box(extents=(1.0, 0.5, 0.8))
    mesh.apply_translation((0, 0, 0.4))

    def fake_load_mesh(path: Path, *, up_axis: str = "auto", unit_scale: float = 1.0) -> _FakeCanonical:
        return _FakeCanonical(mesh=mesh, transform=np.eye(4), sha256="0" * 64, extents=(1.0, 0.5, 0.8))

    monkeypatch.setattr(scenemosaic.assets, "load_mesh", fake_load_mesh, raising=False)
    monkeypatch.setattr(
        scenemosaic.assets, "mesh_hash", lambda m: f"{m.extents[0]:.1f}".ljust(64, "0"), raising=False
    )
    objects = [
        {
            "id": "o_" + ("p" if front[0] == "+" else "m") + front[1],
            "label": "box",
            "mesh": "box.obj",
            "position": [i * 2.0, 0, 0],
            "front": front,
        }
        for i, front in enumerate(["-y", "+y", "+x", "-x"])
    ]
    (tmp_path / "poses.json").write_text(json.dumps({"objects": objects}))
    scene = load_scene(tmp_path)
    fronts = {o.id: front_vector(o.pose.quaternion)[:2] for o in scene.objects}
    # the mesh never moves; only which of its sides counts as the front changes
    assert fronts["o_my"] == pytest.approx((0, -1), abs=1e-9)
    assert fronts["o_py"] == pytest.approx((0, 1), abs=1e-9)
    assert fronts["o_px"] == pytest.approx((1, 0), abs=1e-9)
    assert fronts["o_mx"] == pytest.approx((-1, 0), abs=1e-9)
    assert scene.get("o_px").asset.extents == (0.5, 1.0, 0.8)
    assert scene.get("o_py").asset.extents == (1.0, 0.5, 0.8)
    assert scene.get("o_my").asset.sha256 == "0" * 64  # untouched canonical mesh keeps its hash
    assert scene.get("o_px").asset.sha256 == "0.5".ljust(64, "0")  # the turned mesh is re-hashed
    for obj in scene.objects:  # the world box is the same for every choice
        lo, hi = obj.aabb()
        assert (hi - lo) == pytest.approx((1.0, 0.5, 0.8), abs=1e-9)

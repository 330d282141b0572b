"""Fixtures for the structuring-agent tests: real PhyScene rooms and a SAM3D-like desk scene."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import pytest

from scenemosaic.exchange import load_scene
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, AssetRef, Pose, Scene, SceneObject

DATA = Path(__file__).resolve().parents[2] / "data"
PROCTHOR = PROCTHOR_PRIORS_DIR
SAM3D = DATA / "sam3d_objects" / "generated_assets"


@pytest.fixture(scope="session")
def procthor_dir() -> Path:
    assert (PROCTHOR / "receptacles.json").is_file(), f"ProcTHOR priors missing at {PROCTHOR}"
    return PROCTHOR


@pytest.fixture(scope="session")
def physcene_scenes(physcene_files: list[Path]) -> dict[str, Scene]:
    return {p.stem: load_scene(p) for p in physcene_files}


def _gltf_extents(path: Path) -> tuple[float, float, float]:
    """Bounds of a Y-up glTF's positions, returned as Z-up (width, depth, height)."""
    g = json.loads(path.read_text(encoding="utf-8"))
    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for mesh in g["meshes"]:
        for prim in mesh["primitives"]:
            acc = g["accessors"][prim["attributes"]["POSITION"]]
            lo = [min(a, b) for a, b in zip(lo, acc["min"], strict=True)]
            hi = [max(a, b) for a, b in zip(hi, acc["max"], strict=True)]
    w, h, d = (hi[i] - lo[i] for i in range(3))
    return (round(w, 4), round(d, 4), round(h, 4))


def sam3d_sizes() -> dict[str, tuple[float, float, float]]:
    """Real sizes of the SAM3D desk, printer, mug, chair and bed."""
    found = {
        "work_desk": next(SAM3D.glob("sdf/work_desk_*/work_desk.gltf")),
        "printer": next(SAM3D.glob("sdf/printer_*/printer.gltf")),
        "office_chair": next(SAM3D.glob("sdf/office_chair_*/office_chair.gltf")),
        "king_bed": next(SAM3D.glob("sdf/king_bed_*/king_bed.gltf")),
        "coffee_mug": next(SAM3D.glob("manipulands/sdf/coffee_mug_*/coffee_mug.gltf")),
    }
    return {k: _gltf_extents(v) for k, v in found.items()}


def build_sam3d_scene() -> Scene:
    """A desk against the back wall with a printer and a mug on it, an office chair in front, a bed."""
    s = sam3d_sizes()
    desk_h = s["work_desk"][2]

    def obj(oid: str, cat: str, pos: tuple[float, float, float], yaw: float) -> SceneObject:
        return SceneObject(
            id=oid, category=cat, asset=AssetRef(kind="box", extents=s[cat]), pose=Pose.from_yaw(pos, yaw)
        )

    return Scene(
        id="sam3d_office",
        objects=[
            # desk faces -Y... its back toward +Y (the wall side); yaw 0 = front to -Y
            obj("desk", "work_desk", (0.0, 2.0, 0.0), 0.0),
            obj("printer", "printer", (-0.3, 2.0, desk_h), 0.0),
            obj("mug", "coffee_mug", (0.45, 1.85, desk_h + 0.004), 0.3),
            obj("chair", "office_chair", (0.05, 1.2, 0.0), math.pi),  # faces +Y, toward the desk
            obj("bed", "king_bed", (1.8, -0.5, 0.0), math.pi / 2),
        ],
    )


@pytest.fixture()
def sam3d_scene() -> Scene:
    return build_sam3d_scene()


@pytest.fixture(scope="session")
def scene_builder() -> Callable[[], Scene]:
    return build_sam3d_scene

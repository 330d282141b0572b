"""Fixtures for the physics tests: real PhyScene rooms and a perturbed SAM3D office, stabilized once."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from physics_scene_builders import assign_supports, load_physcene_scene, sam3d_scene

from scenemosaic.physics import StabilizationReport, stabilize_scene_sync
from scenemosaic.scene import Scene

PHYSCENE_DIR = (
    Path(__file__).resolve().parents[2].parent / "shared" / "data" / "layouts" / "physcene"
).resolve()
ROOM_FILES = sorted(PHYSCENE_DIR.glob("*.json"))


@pytest.fixture(scope="session")
def physcene_raw() -> dict[str, Scene]:
    """Every PhyScene room, imported with procedural assets and test-rule supports."""
    assert ROOM_FILES, f"no layouts in {PHYSCENE_DIR}"
    return {f.stem: assign_supports(load_physcene_scene(f)) for f in ROOM_FILES}


@pytest.fixture(scope="session")
def physcene_stabilized(physcene_raw: dict[str, Scene]) -> dict[str, tuple[Scene, StabilizationReport]]:
    """Each room after ``stabilize_scene`` (seed 0)."""
    return {name: stabilize_scene_sync(scene, seed=0) for name, scene in physcene_raw.items()}


@pytest.fixture(scope="session")
def sam3d_raw() -> tuple[Scene, dict[str, list[np.ndarray]]]:
    """The perturbed SAM3D office and its convex pieces (CoACD, cached under .scenemosaic-cache/)."""
    return sam3d_scene(seed=0)


@pytest.fixture(scope="session")
def sam3d_stabilized(
    sam3d_raw: tuple[Scene, dict[str, list[np.ndarray]]],
) -> tuple[Scene, StabilizationReport]:
    scene, hulls = sam3d_raw
    return stabilize_scene_sync(scene, seed=0, hulls=hulls)

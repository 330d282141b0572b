"""Shared test fixtures: the real data beside the repo, a real room, and the network guard."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.importers import load_scene
from scenemosaic.scene import Scene

# Any socket connect to a non-loopback address fails in tests (integration tests use 127.0.0.1 only).
pytest_plugins = ["scenemosaic.models._testing"]

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = (REPO_ROOT.parent / "shared" / "data").resolve()
PHYSCENE_DIR = SHARED_DATA / "layouts" / "physcene"
SAM3D_DIR = SHARED_DATA / "sam3d_objects"
PROCTHOR_DIR = SHARED_DATA / "priors" / "procthor"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the repository (CI has it too)."""
    assert SHARED_DATA.is_dir(), f"shared data not found at {SHARED_DATA}"
    return SHARED_DATA


@pytest.fixture(scope="session")
def dining_scene() -> Scene:
    """The real PhyScene dining room (6 objects), imported with ``load_scene`` (room recovered from the furniture)."""
    return load_scene(PHYSCENE_DIR / "DiningRoom-19325_diningroom.json")


@pytest.fixture(scope="session")
def physcene_files() -> list[Path]:
    """Every 3D-FRONT/PhyScene layout JSON in the shared data."""
    files = sorted(PHYSCENE_DIR.glob("*.json"))
    assert files, f"no layouts in {PHYSCENE_DIR}"
    return files

"""Shared test fixtures: the real data shipped in ``data/``, a real room, and the network guard."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.exchange import load_scene
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, Scene

# Any socket connect to a non-loopback address fails in tests (integration tests use 127.0.0.1 only).
pytest_plugins = ["scenemosaic.models._testing"]

REPO_ROOT = Path(__file__).resolve().parents[1]
DATA = REPO_ROOT / "data"
PHYSCENE_DIR = DATA / "layouts" / "physcene"
SAM3D_DIR = DATA / "sam3d_objects"
PROCTHOR_DIR = PROCTHOR_PRIORS_DIR


@pytest.fixture(scope="session")
def repo_data() -> Path:
    """The real inputs shipped with the repository (``data/``, licences beside each set)."""
    assert DATA.is_dir(), f"data not found at {DATA}"
    return DATA


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

"""Fixtures for the assets tests: the SAM3D example office and the repository's hull cache.

The real-mesh decompositions use ``CoacdParams.fast()`` in ``<repo>/.scenemosaic-cache/hulls``
(gitignored), on the same objects the physics tests build with ``write_sam3d_example``, so each
mesh is decomposed once for the whole suite and not at all on a warm checkout.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.assets import CoacdParams, HullCache
from scenemosaic.exchange import load_scene, write_sam3d_example
from scenemosaic.scene import Scene

REPO_ROOT = Path(__file__).resolve().parents[2]
HULL_CACHE_DIR = REPO_ROOT / ".scenemosaic-cache" / "hulls"
SHARED_PARAMS = CoacdParams.fast()


@pytest.fixture(scope="session")
def shared_hull_cache_dir() -> Path:
    """Root of the hull cache shared with the physics tests."""
    return HULL_CACHE_DIR


@pytest.fixture(scope="session")
def shared_params() -> CoacdParams:
    """The CoACD settings every real-mesh test of the suite uses."""
    return SHARED_PARAMS


@pytest.fixture(scope="session")
def sam3d_office(tmp_path_factory: pytest.TempPathFactory, repo_data: Path) -> Scene:
    """The five shared SAM3D meshes as ``write_sam3d_example`` lays them out, imported."""
    folder = tmp_path_factory.mktemp("sam3d") / "sam3d_office"
    return load_scene(write_sam3d_example(folder, repo_data / "sam3d_objects"))


@pytest.fixture
def shared_hull_cache(shared_hull_cache_dir: Path) -> HullCache:
    """A fresh :class:`HullCache` instance (counters at zero) over the shared folder."""
    return HullCache(shared_hull_cache_dir)

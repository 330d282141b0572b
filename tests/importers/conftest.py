"""Fixtures for the importer tests: the ProcTHOR house fixture, its asset database, the SAM3D example."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


@pytest.fixture(scope="session")
def procthor_house() -> Path:
    """The hand-written two-room ProcTHOR house in ``tests/fixtures``."""
    return FIXTURES / "procthor_house.json"


@pytest.fixture(scope="session")
def procthor_db(shared_data: Path) -> Path:
    """ProcTHOR's published asset database in the shared data."""
    path = shared_data / "priors" / "procthor" / "asset-database.json"
    assert path.is_file(), path
    return path


@pytest.fixture(scope="session")
def procthor_boxes(procthor_db: Path) -> dict[str, dict[str, float]]:
    """assetId -> boundingBox, read independently of the importer."""
    data: dict[str, list[dict[str, Any]]] = json.loads(procthor_db.read_text())
    return {entry["assetId"]: entry["boundingBox"] for entries in data.values() for entry in entries}


@pytest.fixture(scope="session")
def sam3d_dir(shared_data: Path) -> Path:
    path = shared_data / "sam3d_objects"
    assert path.is_dir(), path
    return path


@pytest.fixture(scope="session")
def sam3d_example(tmp_path_factory: pytest.TempPathFactory, sam3d_dir: Path) -> Path:
    """A folder with a ``poses.json`` over the five shared SAM3D meshes (written once per session)."""
    from scenemosaic.importers import write_sam3d_example

    folder = tmp_path_factory.mktemp("sam3d_example")
    write_sam3d_example(folder, sam3d_dir)
    return folder

"""Fixtures for the exchange tests: the ProcTHOR house fixture, its asset database, the SAM3D example,
and a small hand-built scene for the exporters."""

from __future__ import annotations

import json
import math
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from export_reference import ReferenceRoom, build_reference_room

from scenemosaic.scene import (
    PROCTHOR_PRIORS_DIR,
    AssetRef,
    Opening,
    Pose,
    Relation,
    Room,
    Scene,
    SceneObject,
    quat_multiply,
)

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


@pytest.fixture(scope="session")
def procthor_house() -> Path:
    """The hand-written two-room ProcTHOR house in ``tests/fixtures``."""
    return FIXTURES / "procthor_house.json"


@pytest.fixture(scope="session")
def procthor_db(repo_data: Path) -> Path:
    """ProcTHOR's published asset database in the shared data."""
    path = PROCTHOR_PRIORS_DIR / "asset-database.json"
    assert path.is_file(), path
    return path


@pytest.fixture(scope="session")
def procthor_boxes(procthor_db: Path) -> dict[str, dict[str, float]]:
    """assetId -> boundingBox, read independently of the importer."""
    data: dict[str, list[dict[str, Any]]] = json.loads(procthor_db.read_text())
    return {entry["assetId"]: entry["boundingBox"] for entries in data.values() for entry in entries}


@pytest.fixture(scope="session")
def sam3d_dir(repo_data: Path) -> Path:
    path = repo_data / "sam3d_objects"
    assert path.is_dir(), path
    return path


@pytest.fixture(scope="session")
def sam3d_example(tmp_path_factory: pytest.TempPathFactory, sam3d_dir: Path) -> Path:
    """A folder with a ``poses.json`` over the five shared SAM3D meshes (written once per session)."""
    from scenemosaic.exchange import write_sam3d_example

    folder = tmp_path_factory.mktemp("sam3d_example")
    write_sam3d_example(folder, sam3d_dir)
    return folder


@pytest.fixture(scope="session")
def link_sam3d_example(sam3d_example: Path) -> Callable[[Path], dict[str, Any]]:
    """``link(folder)`` gives ``folder`` the example's meshes (hard links, or copies across file
    systems) and returns the example's poses (mesh paths relative, so they resolve inside it).

    A pose file may only use meshes inside its own folder, so an edited copy of ``poses.json``
    needs the meshes beside it, not a path back to the example.
    """

    def copy_file(src: str, dst: str) -> None:
        try:
            os.link(src, dst)
        except OSError:
            shutil.copy2(src, dst)

    def link(folder: Path) -> dict[str, Any]:
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copytree(sam3d_example / "meshes", folder / "meshes", copy_function=copy_file, dirs_exist_ok=True)
        data: dict[str, Any] = json.loads((sam3d_example / "poses.json").read_text())
        return data

    return link


@pytest.fixture()
def small_scene() -> Scene:
    """See :func:`build_small_scene`."""
    return build_small_scene()


def build_small_scene() -> Scene:
    """A 4 x 3 m room with a door and a window, and objects on every kind of support.

    Includes a rotated box table, a non-uniformly scaled procedural chair, a ceiling lamp,
    a wall TV, a mug on the table and a book lying on its side (a non-upright pose).
    """
    room = Room.rectangle(0.0, 0.0, 4.0, 3.0, ceiling_height=2.7)
    room.walls[0].openings = [Opening(kind="door", center=1.0, width=0.9, height=2.1)]
    room.walls[1].openings = [Opening(kind="window", center=1.5, width=1.2, bottom=0.9, height=1.1)]
    lying = quat_multiply(
        (math.cos(math.pi / 6), 0.0, 0.0, math.sin(math.pi / 6)),
        (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0),
    )
    objects = [
        SceneObject(
            id="table",
            category="dining_table",
            asset=AssetRef(kind="box", extents=(1.4, 0.8, 0.75)),
            pose=Pose.from_yaw((2.0, 1.5, 0.0), math.radians(30)),
        ),
        SceneObject(
            id="chair",
            category="dining_chair",
            asset=AssetRef(kind="procedural", category="dining_chair", extents=(0.45, 0.5, 0.9)),
            pose=Pose.from_yaw((0.9, 1.2, 0.0), math.pi / 2, scale=(1.1, 1.0, 1.2)),
        ),
        SceneObject(
            id="lamp",
            category="pendant_lamp",
            asset=AssetRef(kind="box", extents=(0.4, 0.4, 0.5)),
            pose=Pose.from_yaw((2.0, 1.5, 2.2), 0.0),
        ),
        SceneObject(
            id="tv",
            category="tv",
            asset=AssetRef(kind="box", extents=(1.0, 0.06, 0.6)),
            pose=Pose.from_yaw((2.0, 2.97, 1.2), 0.0),  # faces the room (-Y)
        ),
        SceneObject(
            id="mug",
            category="mug",
            asset=AssetRef(kind="box", extents=(0.08, 0.08, 0.1)),
            pose=Pose.from_yaw((2.1, 1.6, 0.75), 0.3),
        ),
        SceneObject(
            id="book",
            category="book",
            asset=AssetRef(kind="box", extents=(0.15, 0.22, 0.03)),
            pose=Pose(position=(1.8, 1.4, 0.86), quaternion=lying),
        ),
    ]
    relations = [
        Relation(kind="attach", child="table", parent="floor"),
        Relation(kind="attach", child="chair", parent="floor"),
        Relation(kind="attach", child="lamp", parent="ceiling"),
        Relation(kind="attach", child="tv", parent="wall_2"),
        Relation(kind="attach", child="mug", parent="table"),
        Relation(kind="attach", child="book", parent="table"),
    ]
    return Scene(id="small", room=room, objects=objects, relations=relations)


@pytest.fixture(scope="session")
def reference_room(tmp_path_factory: pytest.TempPathFactory) -> ReferenceRoom:
    """The USD and URDF exports' reference scene and its MJCF model (``export_reference``)."""
    return build_reference_room(tmp_path_factory.mktemp("reference_room"))

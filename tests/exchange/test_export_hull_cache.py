"""The run's hull cache is the one the exports read: ``--cache-dir`` holds at export time too, and
the user's default cache is not touched."""

from __future__ import annotations

from pathlib import Path

import pytest
import trimesh

from scenemosaic.assets import HullCache
from scenemosaic.exchange import deliver_scene
from scenemosaic.scene import AssetRef, House, Pose, Room, Scene, SceneObject


def _mesh_room(folder: Path, room_id: str, x0: float) -> Scene:
    folder.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(0.4, 0.3, 0.5)).export(folder / f"{room_id}_box.obj")
    box = SceneObject(
        id=f"{room_id}_box_0",
        category="box",
        asset=AssetRef(kind="mesh", uri=f"{room_id}_box.obj", extents=(0.4, 0.3, 0.5)),
        pose=Pose(position=(x0 + 1.5, 1.5, 0.0)),
    )
    room = Room.rectangle(x0, 0.0, x0 + 3.0, 3.0).model_copy(update={"id": room_id})
    return Scene(id=room_id, room=room, objects=[box])


@pytest.fixture
def no_default_cache(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """Any read of the user's default cache fails the test."""
    from scenemosaic.assets import _objects

    def refuse() -> HullCache:
        raise AssertionError("the default hull cache was used")

    monkeypatch.setattr(_objects, "default_hull_cache", refuse)
    return tmp_path


def test_a_delivered_scene_reads_the_hull_cache_it_is_given(no_default_cache: Path) -> None:
    scene = _mesh_room(no_default_cache / "in", "room_a", 0.0)
    cache = HullCache(no_default_cache / "cache")
    files = deliver_scene(scene, no_default_cache / "out", no_default_cache / "in", hull_cache=cache)
    assert "scene.xml" in files and "scene.urdf" in files
    assert any((no_default_cache / "cache").rglob("*")), "the given cache was not filled"


def test_a_delivered_house_reads_the_hull_cache_it_is_given(no_default_cache: Path) -> None:
    rooms = [_mesh_room(no_default_cache / "in", "room_a", 0.0), _mesh_room(no_default_cache / "in", "room_b", 3.0)]
    cache = HullCache(no_default_cache / "cache")
    files = deliver_scene(House(id="two", rooms=rooms), no_default_cache / "out", no_default_cache / "in", hull_cache=cache)
    assert "scene.xml" in files
    assert any((no_default_cache / "cache").rglob("*"))

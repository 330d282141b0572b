"""``load_scene`` / ``load_scenes``: one entry point over every input format, with detection by content."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, get_args

import structlog

from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.exchange._common import read_json
from scenemosaic.exchange._front3d import import_front3d, looks_like_front3d
from scenemosaic.exchange._native import SCENE_FILE, scene_from_data
from scenemosaic.exchange._procthor import AssetDatabase, import_procthor, looks_like_procthor
from scenemosaic.exchange._sam3d import POSES_FILE, import_sam3d, looks_like_sam3d
from scenemosaic.scene import Provenance, Room, Scene

__all__ = ["FORMATS", "ImportFormat", "detect_format", "load_scene", "load_scenes"]

log = structlog.get_logger(__name__)

ImportFormat = Literal["auto", "native", "front3d", "procthor", "sam3d"]
"""Input formats ``load_scene`` understands; ``auto`` detects by content."""
FORMATS: tuple[str, ...] = tuple(f for f in get_args(ImportFormat) if f != "auto")
"""Every concrete format name."""

AssetDatabaseSource = str | os.PathLike[str] | Mapping[str, Any] | AssetDatabase | None


def detect_format(path: str | os.PathLike[str]) -> str:
    """Name the format of ``path`` by looking at its content (rules in ``docs/importers.md``).

    A folder holding ``scene.json`` is ``native``, one holding ``poses.json`` is ``sam3d``.
    A JSON file is ``front3d`` when it has a ``ThreedFront`` key, ``procthor`` when it has
    ``rooms`` with ``floorPolygon`` and ``objects``, ``sam3d`` when it says ``"format":
    "sam3d"`` or every object has a ``mesh``, ``native`` when every top-level key is a
    :class:`Scene` field. Anything else raises :class:`ImportFormatError`.
    """
    p = Path(path)
    if p.is_dir():
        fmt = _folder_format(p)
        if fmt is None:
            raise ImportFormatError(f"folder holds neither {SCENE_FILE} nor {POSES_FILE}", path=str(p))
        return fmt
    return _detect_data(read_json(p), p)


def load_scenes(
    path: str | os.PathLike[str],
    format: ImportFormat | str = "auto",
    *,
    room: Room | str | None = None,
    asset_database: AssetDatabaseSource = None,
) -> list[Scene]:
    """Import every scene ``path`` holds, in a stable order.

    ``path`` is a file, a native scene folder, a SAM3D folder (with ``poses.json``), or any
    other folder, whose ``*.json`` files are each imported (sorted by name). A ProcTHOR house
    gives one scene per room. A :class:`Room` ``room`` replaces the recovered room of
    single-room formats (``front3d``, ``sam3d``); a string ``room`` keeps only the scene whose
    id, room id or source room id (ProcTHOR's ``room|2``) equals it. ``asset_database`` (a path, a parsed mapping, or unset to read
    ``$SCENEMOSAIC_PROCTHOR_DB``) gives ProcTHOR asset sizes.
    """
    fmt = _check_format(format, path)
    p = Path(path)
    override = room if isinstance(room, Room) else None
    scenes: list[Scene] = []
    if p.is_dir():
        inner = _folder_format(p)
        if inner is not None and fmt in ("auto", inner):
            file = p / (SCENE_FILE if inner == "native" else POSES_FILE)
            scenes = _load_file(file, inner, room=override, asset_database=asset_database)
        else:
            files = sorted(q for q in p.glob("*.json") if q.is_file())
            if not files:
                raise ImportFormatError(
                    "folder holds no scene file (scene.json, poses.json or *.json)", path=str(p)
                )
            for f in files:
                scenes.extend(_load_file(f, fmt, room=override, asset_database=asset_database))
    else:
        scenes = _load_file(p, fmt, room=override, asset_database=asset_database)
    if isinstance(room, str):
        scenes = _select_room(scenes, room, p)
    return scenes


def load_scene(
    path: str | os.PathLike[str],
    format: ImportFormat | str = "auto",
    *,
    room: Room | str | None = None,
    asset_database: AssetDatabaseSource = None,
) -> Scene:
    """Import the one scene ``path`` holds (see :func:`load_scenes`).

    A source holding several scenes (a ProcTHOR house with several rooms, a folder of
    layouts) raises :class:`~scenemosaic.exceptions.UsageError` naming them: use
    :func:`load_scenes` there, or pick one with ``room="<room id>"``.
    """
    scenes = load_scenes(path, format, room=room, asset_database=asset_database)
    if len(scenes) != 1:
        ids = ", ".join(s.id for s in scenes[:8])
        raise UsageError(f"{os.fspath(path)} holds {len(scenes)} scenes ({ids}); use load_scenes()")
    return scenes[0]


# -- internals ------------------------------------------------------------------------------------


def _check_format(format: str, path: str | os.PathLike[str]) -> str:
    if format != "auto" and format not in FORMATS:
        raise ImportFormatError(
            f"unknown format {format!r}; use 'auto' or one of {', '.join(FORMATS)}",
            path=os.fspath(path),
            field="format",
        )
    return format


def _select_room(scenes: list[Scene], room: str, path: Path) -> list[Scene]:
    def names(scene: Scene) -> set[str]:
        out = {scene.id}
        if scene.room is not None:
            out.add(scene.room.id)
        source = scene.metadata.get("procthor", {}).get("room_id")
        if isinstance(source, str):
            out.add(source)
        return out

    picked = [s for s in scenes if room in names(s)]
    if not picked:
        known = ", ".join(sorted({n for s in scenes for n in names(s)}))
        raise UsageError(f"{path} has no room {room!r}; it has: {known}")
    return picked


def _folder_format(p: Path) -> str | None:
    if (p / SCENE_FILE).is_file():
        return "native"
    if (p / POSES_FILE).is_file():
        return "sam3d"
    return None


def _looks_native(data: Any) -> bool:
    if not isinstance(data, dict) or not ({"objects", "room"} & data.keys()):
        return False
    return set(data) <= set(Scene.model_fields)


def _detect_data(data: Any, path: Path) -> str:
    if looks_like_front3d(data):
        return "front3d"
    if looks_like_procthor(data):
        return "procthor"
    if looks_like_sam3d(data):
        return "sam3d"
    if _looks_native(data):
        return "native"
    keys = sorted(data)[:6] if isinstance(data, dict) else type(data).__name__
    raise ImportFormatError(
        f"unknown format (top-level {keys}); expected a native scene, a 3D-FRONT layout "
        "(ThreedFront), a ProcTHOR house (rooms + objects) or a SAM3D pose file (objects with mesh)",
        path=str(path),
    )


def _load_file(
    path: Path, fmt: str, *, room: Room | None, asset_database: AssetDatabaseSource
) -> list[Scene]:
    data = read_json(path)
    if fmt == "auto":
        fmt = _detect_data(data, path)
    if room is not None and fmt in ("native", "procthor"):
        raise UsageError(f"room= only applies to front3d and sam3d inputs; {path} is {fmt}")
    log.debug("import", path=str(path), format=fmt)
    if fmt == "native":
        scene = scene_from_data(data, source=str(path))
        if scene.provenance.source_format is None:
            # a scene written by hand: record where it came from; imported scenes keep their origin
            scene.provenance = Provenance(
                source_format="native", source_path=path.as_posix(), importer="scenemosaic.exchange.native"
            )
        return [scene]
    if fmt == "front3d":
        return [import_front3d(data, path, room=room)]
    if fmt == "procthor":
        return import_procthor(data, path, asset_database=asset_database)
    return [import_sam3d(data, path, room=room)]

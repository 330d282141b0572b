"""Delivering a scene: the folder layout every delivered scene has (``base/``, ``variant_<i>/``).

:func:`deliver_scene` writes ``scene.json`` (+ ``assets/``) through the native writer, then every
format of :func:`delivered_formats` from that saved copy (whose mesh uris the native writer
rewrote), the house file of a room taken from an AI2-THOR house, and the top-down picture.

Given a whole house it does the same: ``house_scene.json`` and
``rooms/<room id>/`` (:func:`~scenemosaic.exchange.save_house`), then every format written for the
whole house at once (one MuJoCo world, one USD stage, ...), the house plan as ``topdown.png``, and
the AI2-THOR house file with every room's objects moved.
"""

from __future__ import annotations

import importlib.util
import json
from collections.abc import Collection
from pathlib import Path
from typing import Any

import structlog

from scenemosaic.assets import HullCache, with_room_doors
from scenemosaic.exceptions import UsageError
from scenemosaic.exchange._native import read_house, read_scene, save_house
from scenemosaic.exchange._registry import FORMATS, write_scene
from scenemosaic.scene import House, RunFolder, Scene, write_atomic

__all__ = [
    "HOUSE_INDEX_FILE",
    "HOUSE_ROOMS_DIR",
    "deliver_scene",
    "delivered_files",
    "delivered_formats",
    "delivery_parts",
    "export_house_folder",
    "formats_left_out",
    "save_partial",
]

log = structlog.get_logger(__name__)

HOUSE_INDEX_FILE = RunFolder.HOUSE_FILE
"""The native house index in a delivered house folder, ``house_scene.json``: ``{"format":
"scenemosaic-house", "version": 1, "id", "rooms": [room ids in order], "metadata", "provenance"}``."""
HOUSE_ROOMS_DIR = RunFolder.ROOMS
"""The folder of a delivered house holding one native scene folder per room, ``rooms/<room id>/``."""

def delivered_formats() -> tuple[tuple[str, str], ...]:
    """The formats written beside ``scene.json`` (a house: ``house_scene.json``) in every delivered
    folder, with their destination in it (``write_scene``'s destination; empty: the folder itself),
    in registration order: every registered format with a ``delivered`` destination
    (``SceneFormat.delivered``). A format read from is also written back when it says so
    (``SceneFormat.written_back``: ProcTHOR's ``house.json``)."""
    return tuple((name, fmt.delivered) for name, fmt in FORMATS.items() if fmt.delivered is not None)


def delivery_parts() -> tuple[str, ...]:
    """The pieces of a delivered house that :func:`export_house_folder` can write apart, each into
    files of its own: the formats of :func:`delivered_formats`, those written back to their
    source (``procthor``: ``house.json``, for a house taken from an AI2-THOR house) and
    ``topdown`` (the plan, ``topdown.png``)."""
    back = tuple(name for name, fmt in FORMATS.items() if fmt.written_back)
    return (*(name for name, _ in delivered_formats()), *back, "topdown")


def _available(fmt: str) -> bool:
    extra = FORMATS[fmt].extra
    return extra is None or importlib.util.find_spec(extra[0]) is not None


def formats_left_out() -> dict[str, str]:
    """The delivered formats whose extra is not installed, with the ``pip install`` to run."""
    return {
        name: FORMATS[name].extra[1]  # type: ignore[index]  # _available is true without an extra
        for name, _ in delivered_formats()
        if not _available(name)
    }


def deliver_scene(
    scene: Scene | House,
    folder: Path,
    base_dir: Path | None,
    *,
    hull_cache: HullCache | None = None,
    parts: Collection[str] | None = None,
) -> list[str]:
    """Write a scene, or a whole house, in the delivered layout; returns the files written
    (relative to ``folder``: its files, then its folders as ``name/``).

    A room's scene: ``scene.json`` (+ ``assets/``) through the native writer, then, from that saved
    copy, every format of :func:`delivered_formats` (those whose extra is installed), the house
    file of a room taken from an AI2-THOR house (a format ``written_back``) and the top-down
    picture. A whole :class:`~scenemosaic.scene.House`: ``house_scene.json`` and
    ``rooms/<room id>/scene.json`` (+ ``assets/``), then the whole house in every delivered format
    at once (one MuJoCo world, one USD stage, one GLB, one sceneState), the house plan as
    ``topdown.png`` and, for a house imported from one AI2-THOR / ProcTHOR file, that file with
    every room's objects at their new poses; :func:`~scenemosaic.exchange.read_house` reads it back.

    ``base_dir`` resolves the input's relative mesh uris; ``hull_cache`` is the CoACD cache the
    formats with collision hulls read (the run's); ``parts`` writes only those of
    :func:`delivery_parts` after the native files (``()``: the native files alone).

    Raises:
        UsageError: a name in ``parts`` is none of :func:`delivery_parts`.
    """
    folder.mkdir(parents=True, exist_ok=True)
    (folder / RunFolder.PARTIAL).unlink(missing_ok=True)  # delivered now: no longer what a stopped run kept
    if isinstance(scene, House):
        write_scene(scene, "native", folder, base_dir)
        if parts is not None and not parts:
            return delivered_files(folder)
        return export_house_folder(folder, hull_cache=hull_cache, parts=parts)
    chosen = _chosen_parts(parts)
    write_scene(scene, "native", folder, base_dir)
    saved = read_scene(folder)
    _write_delivered(saved, folder, _written_back(saved.provenance.source_format), hull_cache, chosen)
    if "topdown" in chosen:
        from scenemosaic.render import render_topdown

        write_atomic(folder / RunFolder.TOPDOWN, render_topdown(saved, base_dir=folder))
    top = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if p.is_file())
    return [*top, *sorted(f"{p.name}/" for p in folder.iterdir() if p.is_dir() and p.name != "assets")]


def _chosen_parts(parts: Collection[str] | None) -> set[str]:
    every = delivery_parts()
    chosen = set(every) if parts is None else set(parts)
    unknown = sorted(chosen - set(every))
    if unknown:
        raise UsageError(f"no such delivery part: {', '.join(unknown)} (the parts: {', '.join(every)})")
    return chosen


def export_house_folder(
    folder: Path, *, hull_cache: HullCache | None = None, parts: Collection[str] | None = None
) -> list[str]:
    """Write every house-wide format beside the native house saved in ``folder`` (the second half
    of :func:`deliver_scene` of a house); returns the files (:func:`delivered_files`).

    ``parts`` (names of :func:`delivery_parts`; ``None``: all of them) writes only those pieces:
    they share no file, so a house run writes a house's pieces in its two worker processes at once,
    each process keeping the same pieces (and the memos they warm) from house to house.

    Raises:
        UsageError: a name in ``parts`` is none of :func:`delivery_parts`.
    """
    from scenemosaic.render import render_house_plan

    chosen = _chosen_parts(parts)
    saved = read_house(folder)
    sources = {s.provenance.source_format for s in saved.rooms}
    back = _written_back(sources.pop()) if len(sources) == 1 else None
    _write_delivered(saved, folder, back, hull_cache, chosen)
    if "topdown" in chosen:
        write_atomic(folder / RunFolder.TOPDOWN, render_house_plan(saved, base_dir=folder))
    log.info("house_delivered", folder=str(folder), rooms=len(saved.rooms), objects=len(saved.objects), parts=sorted(chosen))
    return delivered_files(folder)


def delivered_files(folder: Path) -> list[str]:
    """What a delivered house folder holds, as :func:`deliver_scene` returns it for a house: the files at its
    top (sorted), then its folders as ``name/`` (sorted)."""
    top = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if p.is_file())
    return [*top, *sorted(f"{p.name}/" for p in folder.iterdir() if p.is_dir())]


def _written_back(source_format: str | None) -> str | None:
    """The source format a delivered scene is written back in (``SceneFormat.written_back``), if any."""
    fmt = FORMATS.get(source_format or "")
    return fmt.name if fmt is not None and fmt.written_back else None


def _write_delivered(
    saved: Scene | House, folder: Path, back: str | None, hull_cache: HullCache | None, parts: Collection[str] | None = None
) -> None:
    """Every format of :func:`delivered_formats` whose extra is installed, through
    :func:`write_scene` (a house through each format's house writer), from the native copy saved
    in ``folder``; and the source format ``back`` the scene came from, when it is written back
    (the AI2-THOR house file); only those named in ``parts`` when given. The rooms' doors are hung
    once (``assets.with_room_doors``) for every simulator format."""
    formats = [(fmt, dest) for fmt, dest in delivered_formats() if (parts is None or fmt in parts) and _available(fmt)]
    hung = with_room_doors(saved) if any(FORMATS[fmt].room_doors for fmt, _ in formats) else saved
    for fmt, destination in formats:
        scene = hung if FORMATS[fmt].room_doors else saved
        write_scene(scene, fmt, folder / destination if destination else folder, folder, hull_cache=hull_cache)
    if back is not None and (parts is None or back in parts):  # back into the file it came from
        write_scene(saved, back, folder, folder)


def save_partial(scene: Scene | House, folder: Path, base_dir: Path | None, marker: dict[str, Any]) -> list[str]:
    """Keep what a failed or stopped run made: the native files only (``scene.json``, or
    ``house_scene.json`` and every room's, with their meshes) and ``partial.json`` holding
    ``marker`` (why it is partial), written first so the folder never looks delivered; returns the
    files written. The loaders refuse the folder unless asked for a partial result."""
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(folder / RunFolder.PARTIAL, json.dumps(marker, indent=2, sort_keys=True) + "\n")
    if isinstance(scene, House):
        save_house(scene, folder, base_dir=base_dir)
        return [RunFolder.PARTIAL, RunFolder.HOUSE_FILE, f"{RunFolder.ROOMS}/"]
    write_scene(scene, "native", folder, base_dir)
    return [RunFolder.PARTIAL, RunFolder.SCENE_FILE]

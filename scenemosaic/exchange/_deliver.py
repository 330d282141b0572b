"""Delivering a scene: the folder layout every delivered scene has (``base/``, ``variant_<i>/``).

:func:`deliver_scene` writes ``scene.json`` (+ ``assets/``) through the native writer, then every
format of :data:`DELIVERED_FORMATS` from that saved copy (whose mesh uris the native writer
rewrote), the house file of a room taken from an AI2-THOR house, and the top-down picture.

:func:`deliver_house` does the same for a whole house: ``house_scene.json`` and
``rooms/<room id>/`` (:func:`~scenemosaic.exchange.save_house`), then every format written for the
whole house at once (one MuJoCo world, one USD stage, ...), the house plan as ``topdown.png``, and
the AI2-THOR house file with every room's objects moved.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from pathlib import Path

import structlog

from scenemosaic.exchange._glb import export_house_glb
from scenemosaic.exchange._native import read_house, read_scene, save_house
from scenemosaic.exchange._procthor import export_procthor_house
from scenemosaic.exchange._registry import write_scene
from scenemosaic.exchange._sceneeval import export_house_sceneeval
from scenemosaic.exchange._urdf import export_house_urdf
from scenemosaic.exchange._usd import export_house_usd
from scenemosaic.physics import write_house_mjcf
from scenemosaic.scene import House, RunFolder, Scene, write_atomic

__all__ = [
    "DELIVERED_FORMATS",
    "HOUSE_INDEX_FILE",
    "HOUSE_ROOMS_DIR",
    "OPTIONAL_FORMATS",
    "deliver_house",
    "deliver_scene",
    "export_house_folder",
    "formats_left_out",
    "save_scene_only",
]

log = structlog.get_logger(__name__)

HOUSE_INDEX_FILE = RunFolder.HOUSE_FILE
"""The native house index in a delivered house folder, ``house_scene.json``: ``{"format":
"scenemosaic-house", "version": 1, "id", "rooms": [room ids in order], "metadata", "provenance"}``."""
HOUSE_ROOMS_DIR = RunFolder.ROOMS
"""The folder of a delivered house holding one native scene folder per room, ``rooms/<room id>/``."""

DELIVERED_FORMATS: tuple[tuple[str, str], ...] = (
    ("glb", "scene.glb"),
    ("sceneeval", "sceneeval"),
    ("mjcf", ""),
    ("urdf", ""),
    ("usd", ""),
)
"""Formats written beside ``scene.json`` in every delivered folder, with their destination in it;
plus ``procthor`` (``house.json``) for a room taken from an AI2-THOR / ProcTHOR house."""

OPTIONAL_FORMATS: dict[str, str] = {"usd": "pip install 'scenemosaic[usd]'"}
"""Delivered formats that need an extra: without it they are left out (the run's report says so,
with the command that installs it)."""

_EXTRA_MODULE = {"usd": "pxr"}


def _available(fmt: str) -> bool:
    module = _EXTRA_MODULE.get(fmt)
    return module is None or importlib.util.find_spec(module) is not None


def formats_left_out() -> dict[str, str]:
    """The delivered formats whose extra is not installed, with the ``pip install`` to run."""
    return {fmt: hint for fmt, hint in OPTIONAL_FORMATS.items() if not _available(fmt)}


def deliver_scene(scene: Scene, folder: Path, base_dir: Path | None) -> list[str]:
    """Write one scene in the delivered layout; returns the files written (relative to ``folder``)."""
    from scenemosaic.render import render_topdown

    folder.mkdir(parents=True, exist_ok=True)
    write_scene(scene, "native", folder, base_dir)
    saved = read_scene(folder)
    for fmt, destination in DELIVERED_FORMATS:
        if _available(fmt):
            write_scene(saved, fmt, folder / destination if destination else folder, folder)
    if saved.provenance.source_format == "procthor":  # back into the house it came from
        write_scene(saved, "procthor", folder, folder)
    write_atomic(folder / RunFolder.TOPDOWN, render_topdown(saved, base_dir=folder))
    top = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if p.is_file())
    return [*top, *sorted(f"{p.name}/" for p in folder.iterdir() if p.is_dir() and p.name != "assets")]


def deliver_house(house: House, folder: Path, base_dir: Path | None) -> list[str]:
    """Write a whole house in the delivered layout; returns the files written (relative to ``folder``).

    ``house_scene.json`` and ``rooms/<room id>/scene.json`` (+ ``assets/``) through the native
    writer, then, from that saved copy, the whole house in every format of
    :data:`DELIVERED_FORMATS` (those whose extra is installed): ``scene.glb``, ``sceneeval/``,
    ``scene.xml`` + ``mjcf/``, ``scene.urdf`` + ``urdf/``, ``scene.usda`` + ``usd/``; the house
    plan as ``topdown.png``; and, for a house imported from one AI2-THOR / ProcTHOR house file,
    that file as ``house.json`` with every room's objects at their new poses.
    ``base_dir`` resolves the input's relative mesh uris. :func:`~scenemosaic.exchange.read_house`
    reads the folder back.
    """
    folder.mkdir(parents=True, exist_ok=True)
    save_house(house, folder, base_dir=base_dir)
    return export_house_folder(folder)


def export_house_folder(folder: Path) -> list[str]:
    """Write every house-wide format beside the native house saved in ``folder`` (the second half
    of :func:`deliver_house`; a house run does it in its worker processes); returns the files."""
    from scenemosaic.render import render_house_plan

    saved = read_house(folder)
    writers: dict[str, Callable[[], Path]] = {
        "glb": lambda: export_house_glb(saved, folder / "scene.glb", folder),
        "sceneeval": lambda: export_house_sceneeval(saved, folder / "sceneeval", folder),
        "mjcf": lambda: write_house_mjcf(saved, folder, folder),
        "urdf": lambda: export_house_urdf(saved, folder, folder),
        "usd": lambda: export_house_usd(saved, folder, folder),
    }
    for fmt, _ in DELIVERED_FORMATS:
        if _available(fmt):
            writers[fmt]()
    if all(s.provenance.source_format == "procthor" for s in saved.rooms):  # back into its house file
        export_procthor_house(saved, folder)
    write_atomic(folder / RunFolder.TOPDOWN, render_house_plan(saved, base_dir=folder))
    log.info("house_delivered", folder=str(folder), rooms=len(saved.rooms), objects=len(saved.objects))
    top = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if p.is_file())
    return [*top, *sorted(f"{p.name}/" for p in folder.iterdir() if p.is_dir())]


def save_scene_only(scene: Scene, folder: Path, base_dir: Path | None) -> list[str]:
    """Write only ``scene.json`` (+ its mesh assets): the fast partial result of a stopped run."""
    folder.mkdir(parents=True, exist_ok=True)
    write_scene(scene, "native", folder, base_dir)
    return [RunFolder.SCENE_FILE]

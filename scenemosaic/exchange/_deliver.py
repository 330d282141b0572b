"""Delivering a scene: the folder layout every delivered scene has (``base/``, ``variant_<i>/``).

:func:`deliver_scene` writes ``scene.json`` (+ ``assets/``) through the native writer, then every
format of :data:`DELIVERED_FORMATS` from that saved copy (whose mesh uris the native writer
rewrote), the house file of a room taken from an AI2-THOR house, and the top-down picture.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from scenemosaic.exchange._native import read_scene
from scenemosaic.exchange._registry import write_scene
from scenemosaic.scene import RunFolder, Scene

__all__ = ["DELIVERED_FORMATS", "OPTIONAL_FORMATS", "deliver_scene", "formats_left_out", "save_scene_only"]

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
    (folder / RunFolder.TOPDOWN).write_bytes(render_topdown(saved, base_dir=folder))
    top = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if p.is_file())
    return [*top, *sorted(f"{p.name}/" for p in folder.iterdir() if p.is_dir() and p.name != "assets")]


def save_scene_only(scene: Scene, folder: Path, base_dir: Path | None) -> list[str]:
    """Write only ``scene.json`` (+ its mesh assets): the fast partial result of a stopped run."""
    folder.mkdir(parents=True, exist_ok=True)
    write_scene(scene, "native", folder, base_dir)
    return [RunFolder.SCENE_FILE]

"""The formats scenemosaic ships, registered once (importing :mod:`scenemosaic.exchange` does it).

Detection order matters: specific content tests first (3D-FRONT's ``ThreedFront``, SceneEval's
``"format": "sceneState"``, a Holodeck room before a ProcTHOR house because both have ``rooms`` +
``objects``, a SAM3D pose file), the native scene model last because its test is the loosest.

A format's module is imported when one of its functions is first called (:func:`_module`), not
here: registering the formats loads none of their backends (trimesh, MuJoCo, scipy, shapely), so
reading a native scene or house (``scenemosaic inspect``, ``load_scene`` of a run's output)
loads none of them either.
"""

from __future__ import annotations

import dataclasses
import importlib
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

from scenemosaic.exchange._common import POSES_FILE
from scenemosaic.exchange._native import SCENE_FILE, save_house, save_scene, scene_from_data
from scenemosaic.exchange._registry import ReadOptions, SceneFormat
from scenemosaic.exchange._registry import register_format as _register
from scenemosaic.scene import House, Provenance, Scene

if TYPE_CHECKING:
    from scenemosaic.assets import HullCache

__all__ = ["NATIVE_IMPORTER"]

NATIVE_IMPORTER = "scenemosaic.exchange.native"


def _builtin_format(fmt: SceneFormat) -> None:
    _register(dataclasses.replace(fmt, builtin=True))


def _module(name: str) -> ModuleType:
    """The format module ``scenemosaic.exchange.<name>``, imported on first use."""
    return importlib.import_module(f"scenemosaic.exchange.{name}")


def _looks_native(data: Any) -> bool:
    if not isinstance(data, dict) or not ({"objects", "room"} & data.keys()):
        return False
    return set(data) <= set(Scene.model_fields)


def _read_native(data: Any, path: Path, options: ReadOptions) -> list[Scene]:
    # mesh uris must lie in the scene's folder, or in the asset folder the caller named
    roots = [options.asset_dir] if options.asset_dir is not None else []
    scene = scene_from_data(data, source=str(path), roots=roots)
    if scene.provenance.source_format is None:
        # a scene written by hand: record where it came from; imported scenes keep their origin
        scene.provenance = Provenance(source_format="native", source_path=path.as_posix(), importer=NATIVE_IMPORTER)
    return [scene]


def _write_native(scene: Scene | House, folder: Path, base_dir: Path | None) -> Path:
    if isinstance(scene, House):
        return save_house(scene, folder, base_dir=base_dir)
    return save_scene(scene, folder, base_dir=base_dir)


def _write_glb(scene: Scene | House, path: Path, base_dir: Path | None) -> Path:
    from scenemosaic.exchange._glb import export_glb

    return export_glb(scene, path, base_dir=base_dir)


def _write_sceneeval(scene: Scene | House, folder: Path, base_dir: Path | None) -> Path:
    from scenemosaic.exchange._sceneeval import export_sceneeval

    return export_sceneeval(scene, folder, base_dir=base_dir)


def _write_mjcf(scene: Scene | House, folder: Path, base_dir: Path | None, *, hull_cache: HullCache | None = None) -> Path:
    from scenemosaic.exchange._mjcf import export_mjcf

    return export_mjcf(scene, folder, base_dir=base_dir, hull_cache=hull_cache)


def _write_usd(scene: Scene | House, destination: Path, base_dir: Path | None, *, hull_cache: HullCache | None = None) -> Path:
    from scenemosaic.exchange._usd import export_usd

    return export_usd(scene, destination, base_dir=base_dir, hull_cache=hull_cache)


def _write_urdf(scene: Scene | House, folder: Path, base_dir: Path | None, *, hull_cache: HullCache | None = None) -> Path:
    from scenemosaic.exchange._urdf import export_urdf

    return export_urdf(scene, folder, base_dir=base_dir, hull_cache=hull_cache)


_builtin_format(
    SceneFormat(
        "front3d",
        "3D-FRONT / ATISS / PhyScene layout with a ThreedFront key",
        detect=lambda data: _module("_front3d").looks_like_front3d(data),
        read=lambda data, path, o: [_module("_front3d").import_front3d(data, path, room=o.room)],
        takes_room=True,
    )
)
_builtin_format(
    SceneFormat(
        "sceneeval",
        "SceneEval sceneState (SceneEval, SceneSmith, LayoutVLM) with assets/<assetId>.glb meshes",
        detect=lambda data: _module("_sceneeval_read").looks_like_sceneeval(data),
        read=lambda data, path, o: [_module("_sceneeval_read").import_sceneeval(data, path, asset_dir=o.asset_dir)],
        write=_write_sceneeval,
        writes_houses=True,
        delivered="sceneeval",
    )
)
_builtin_format(  # before procthor: a Holodeck room also has rooms + objects
    SceneFormat(
        "holodeck",
        "Holodeck output, one room or a whole house (flat object list, parents and rooms named in the ids)",
        detect=lambda data: _module("_holodeck").looks_like_holodeck(data),
        read=lambda data, path, o: _module("_holodeck").import_holodeck(
            data, path, asset_database=o.asset_database, allow_orphans=o.allow_orphans
        ),
        holds_houses=True,
    )
)
_builtin_format(
    SceneFormat(
        "procthor",
        "AI2-THOR / ProcTHOR / Holodeck house with rooms and objects (written back: house.json, for a room or a house taken from one)",
        detect=lambda data: _module("_procthor").looks_like_procthor(data),
        read=lambda data, path, o: _module("_procthor").import_procthor(
            data, path, asset_database=o.asset_database, allow_orphans=o.allow_orphans
        ),
        write=lambda scene, folder, base_dir: _module("_procthor").export_procthor(scene, folder, base_dir),
        writes_houses=True,
        holds_houses=True,
        written_back=True,
    )
)
_builtin_format(
    SceneFormat(
        "sam3d",
        f"image-to-3D object set: {POSES_FILE} with a mesh per object",
        detect=lambda data: _module("_sam3d").looks_like_sam3d(data),
        read=lambda data, path, o: [_module("_sam3d").import_sam3d(data, path, room=o.room)],
        folder_file=POSES_FILE,
        takes_room=True,
    )
)
_builtin_format(
    SceneFormat(
        "native",
        f"a scenemosaic {SCENE_FILE} (or a folder holding one)",
        detect=_looks_native,
        read=_read_native,
        write=_write_native,
        writes_houses=True,
        folder_file=SCENE_FILE,
    )
)
_builtin_format(
    SceneFormat(
        "glb",
        "one GLB with a node per object (Y-up, as glTF)",
        write=_write_glb,
        writes_houses=True,
        room_doors=True,
        delivered="scene.glb",
    )
)
_builtin_format(
    SceneFormat(
        "mjcf",
        "MuJoCo scene.xml + mjcf/ meshes",
        write=_write_mjcf,
        writes_houses=True,
        room_doors=True,
        uses_hulls=True,
        delivered="",
    )
)
_builtin_format(
    SceneFormat(
        "usd",
        "ASCII USD scene.usda with UsdPhysics + usd/ per-object geometry (needs scenemosaic[usd])",
        write=_write_usd,
        writes_houses=True,
        room_doors=True,
        uses_hulls=True,
        delivered="",
        extra=("pxr", "pip install 'scenemosaic[usd]'"),
    )
)
_builtin_format(
    SceneFormat(
        "urdf",
        "URDF scene.urdf + urdf/<id>.urdf per object + urdf/meshes/",
        write=_write_urdf,
        writes_houses=True,
        room_doors=True,
        uses_hulls=True,
        delivered="",
    )
)

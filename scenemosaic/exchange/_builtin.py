"""The formats scenemosaic ships, registered once (importing :mod:`scenemosaic.exchange` does it).

Detection order matters: specific content tests first (3D-FRONT's ``ThreedFront``, SceneEval's
``"format": "sceneState"``, a Holodeck room before a ProcTHOR house because both have ``rooms`` +
``objects``, a SAM3D pose file), the native scene model last because its test is the loosest.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from scenemosaic.assets import HullCache
from scenemosaic.exchange._front3d import import_front3d, looks_like_front3d
from scenemosaic.exchange._glb import export_glb, export_house_glb
from scenemosaic.exchange._holodeck import import_holodeck, looks_like_holodeck
from scenemosaic.exchange._mjcf import export_house_mjcf, export_mjcf
from scenemosaic.exchange._native import SCENE_FILE, save_house, save_scene, scene_from_data
from scenemosaic.exchange._procthor import (
    export_procthor,
    export_procthor_house,
    import_procthor,
    looks_like_procthor,
)
from scenemosaic.exchange._registry import ReadOptions, SceneFormat, register_format
from scenemosaic.exchange._sam3d import POSES_FILE, import_sam3d, looks_like_sam3d
from scenemosaic.exchange._sceneeval import export_house_sceneeval, export_sceneeval
from scenemosaic.exchange._sceneeval_read import import_sceneeval, looks_like_sceneeval
from scenemosaic.exchange._urdf import export_house_urdf, export_urdf
from scenemosaic.exchange._usd import export_house_usd, export_usd
from scenemosaic.scene import House, Provenance, Scene

__all__ = ["NATIVE_IMPORTER"]

NATIVE_IMPORTER = "scenemosaic.exchange.native"


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


def _write_native(scene: Scene, folder: Path, base_dir: Path | None) -> Path:
    return save_scene(scene, folder, base_dir=base_dir)


def _write_native_house(house: House, folder: Path, base_dir: Path | None) -> Path:
    return save_house(house, folder, base_dir=base_dir)


def _write_glb(scene: Scene, path: Path, base_dir: Path | None) -> Path:
    return export_glb(scene, path, base_dir=base_dir)


def _write_sceneeval(scene: Scene, folder: Path, base_dir: Path | None) -> Path:
    return export_sceneeval(scene, folder, base_dir=base_dir)


def _write_mjcf(scene: Scene, folder: Path, base_dir: Path | None, *, hull_cache: HullCache | None = None) -> Path:
    return export_mjcf(scene, folder, base_dir=base_dir, hull_cache=hull_cache)


def _write_usd(scene: Scene, destination: Path, base_dir: Path | None, *, hull_cache: HullCache | None = None) -> Path:
    return export_usd(scene, destination, base_dir=base_dir, hull_cache=hull_cache)


def _write_urdf(scene: Scene, folder: Path, base_dir: Path | None, *, hull_cache: HullCache | None = None) -> Path:
    return export_urdf(scene, folder, base_dir=base_dir, hull_cache=hull_cache)


register_format(
    SceneFormat(
        "front3d",
        "3D-FRONT / ATISS / PhyScene layout with a ThreedFront key",
        detect=looks_like_front3d,
        read=lambda data, path, o: [import_front3d(data, path, room=o.room)],
        takes_room=True,
    )
)
register_format(
    SceneFormat(
        "sceneeval",
        "SceneEval sceneState (SceneEval, SceneSmith, LayoutVLM) with assets/<assetId>.glb meshes",
        detect=looks_like_sceneeval,
        read=lambda data, path, o: [import_sceneeval(data, path, asset_dir=o.asset_dir)],
        write=_write_sceneeval,
        write_house=export_house_sceneeval,
    )
)
register_format(  # before procthor: a Holodeck room also has rooms + objects
    SceneFormat(
        "holodeck",
        "Holodeck single-room output (flat object list, parents named in the ids)",
        detect=looks_like_holodeck,
        read=lambda data, path, o: [import_holodeck(data, path, asset_database=o.asset_database)],
    )
)
register_format(
    SceneFormat(
        "procthor",
        "AI2-THOR / ProcTHOR / Holodeck house with rooms and objects (written back: house.json, for a room or a house taken from one)",
        detect=looks_like_procthor,
        read=lambda data, path, o: import_procthor(
            data, path, asset_database=o.asset_database, allow_orphans=o.allow_orphans
        ),
        write=lambda scene, folder, base_dir: export_procthor(scene, folder, base_dir),
        write_house=export_procthor_house,
    )
)
register_format(
    SceneFormat(
        "sam3d",
        f"image-to-3D object set: {POSES_FILE} with a mesh per object",
        detect=looks_like_sam3d,
        read=lambda data, path, o: [import_sam3d(data, path, room=o.room)],
        folder_file=POSES_FILE,
        takes_room=True,
    )
)
register_format(
    SceneFormat(
        "native",
        f"a scenemosaic {SCENE_FILE} (or a folder holding one)",
        detect=_looks_native,
        read=_read_native,
        write=_write_native,
        write_house=_write_native_house,
        folder_file=SCENE_FILE,
    )
)
register_format(
    SceneFormat("glb", "one GLB with a node per object (Y-up, as glTF)", write=_write_glb, write_house=export_house_glb)
)
register_format(
    SceneFormat("mjcf", "MuJoCo scene.xml + mjcf/ meshes", write=_write_mjcf, write_house=export_house_mjcf, uses_hulls=True)
)
register_format(
    SceneFormat(
        "usd",
        "ASCII USD scene.usda with UsdPhysics + usd/ per-object geometry (needs scenemosaic[usd])",
        write=_write_usd,
        write_house=export_house_usd,
        uses_hulls=True,
    )
)
register_format(
    SceneFormat(
        "urdf",
        "URDF scene.urdf + urdf/<id>.urdf per object + urdf/meshes/",
        write=_write_urdf,
        write_house=export_house_urdf,
        uses_hulls=True,
    )
)

"""Importers: turn scene files of other tools into :class:`~scenemosaic.scene.Scene` objects.

This package sits above ``scene`` and ``assets`` (the SAM3D importer loads meshes). Formats:

* ``native`` — a folder with ``scene.json`` + ``assets/`` (:func:`save_scene` writes it), or a ``scene.json``;
* ``front3d`` — 3D-FRONT / ATISS / PhyScene layouts (``{"ThreedFront": ...}``);
* ``procthor`` — AI2-THOR / ProcTHOR / Holodeck houses (one scene per room);
* ``sam3d`` — image-to-3D object sets: ``poses.json`` + mesh files.

Every malformed input raises :class:`~scenemosaic.exceptions.ImportFormatError` naming the
file and the field. Conventions and rules: ``docs/importers.md``.
"""

from scenemosaic.importers._api import FORMATS, ImportFormat, detect_format, load_scene, load_scenes
from scenemosaic.importers._procthor import PROCTHOR_DB_ENV, AssetDatabase, load_asset_database
from scenemosaic.importers._room import dominant_orientation, recover_room
from scenemosaic.importers._sam3d import read_sdf_sim, write_sam3d_example
from scenemosaic.scene._io import read_scene, save_scene

__all__ = [
    "FORMATS",
    "PROCTHOR_DB_ENV",
    "AssetDatabase",
    "ImportFormat",
    "detect_format",
    "dominant_orientation",
    "load_asset_database",
    "load_scene",
    "load_scenes",
    "read_scene",
    "read_sdf_sim",
    "recover_room",
    "save_scene",
    "write_sam3d_example",
]

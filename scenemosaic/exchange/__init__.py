"""Exchange: every scene format in and out, behind one registry (as ``trimesh.exchange``).

Readers turn other tools' files into :class:`~scenemosaic.scene.Scene` objects; writers turn
scenes into files a simulator or an evaluator loads. A format is one module plus one
:func:`register_format` call (the built-ins are registered in ``_builtin.py``). Built in:

* ``native`` — a folder with ``scene.json`` + ``assets/`` (:func:`save_scene` writes it);
* ``front3d`` — 3D-FRONT / ATISS / PhyScene layouts (``{"ThreedFront": ...}``);
* ``procthor`` — AI2-THOR / ProcTHOR / Holodeck houses (one scene per room);
* ``sam3d`` — image-to-3D object sets: ``poses.json`` + mesh files;
* datasets of houses (``.jsonl``/``.jsonl.gz``, one house a line, as ProcTHOR-10k ships): read
  lazily, a house picked by its index (``load_scene(path, index=3)``; ``_dataset.py``);
* exports: GLB (:func:`export_glb`), SceneEval sceneState (:func:`export_sceneeval`),
  MJCF (:func:`export_mjcf`), USD with UsdPhysics (:func:`export_usd`, needs the ``usd`` extra)
  and URDF (:func:`export_urdf`, with ``scene.sdf`` beside it for PyBullet: :func:`load_pybullet`);
  a room taken from an AI2-THOR house back into that house
  (:func:`export_procthor`);
* houses: every export takes a whole :class:`~scenemosaic.scene.House` as readily as a room's
  scene (one world: one MuJoCo model, one USD stage, one GLB, the AI2-THOR file written back), and
  so does :func:`write_scene`; :func:`deliver_scene` writes a house's delivered folder.

Every malformed input raises :class:`~scenemosaic.exceptions.ImportFormatError` naming the
file and the field, values beyond the scene limits included. A reader only opens files inside
the input's own folder (or ``asset_dir=``), symlinks followed (``scenemosaic.scene.confined_path``).
Conventions and rules: ``docs/importers.md`` and ``docs/exports.md``.

Names load on first use (as in :mod:`scenemosaic`): importing the package registers the formats
and imports no format's backend (trimesh, MuJoCo, scipy, shapely), so reading a native scene or
house stays light (``scenemosaic inspect``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from scenemosaic.exchange import _builtin  # noqa: F401 - registers the built-in formats (light: see there)

if TYPE_CHECKING:  # what type checkers see; at run time the names load lazily
    from scenemosaic.exchange._dataset import (
        DatasetEntry,
        dataset_entries,
        dataset_entry,
        dataset_size,
        dataset_stem,
        is_dataset,
    )
    from scenemosaic.exchange._deliver import (
        HOUSE_INDEX_FILE,
        HOUSE_ROOMS_DIR,
        deliver_scene,
        delivered_files,
        delivered_formats,
        delivery_parts,
        export_house_folder,
        formats_left_out,
        save_partial,
    )
    from scenemosaic.exchange._glb import (
        GLB_ROOT_NODE,
        Y_UP_TO_Z_UP,
        Z_UP_TO_Y_UP,
        build_glb_scene,
        build_house_glb_scene,
        export_glb,
    )
    from scenemosaic.exchange._mjcf import export_mjcf
    from scenemosaic.exchange._native import read_house, read_scene, save_house, save_scene
    from scenemosaic.exchange._procthor import (
        HOUSE_FILE,
        SHARED_WALL_THICKNESS_M,
        AssetDatabase,
        export_procthor,
        load_asset_annotations,
        load_asset_database,
    )
    from scenemosaic.exchange._pybullet import PYBULLET_INSTALL_HINT, load_pybullet
    from scenemosaic.exchange._registry import (
        FORMATS,
        ImportFormat,
        ReadOptions,
        SceneFormat,
        detect_format,
        get_format,
        house_formats,
        is_house_source,
        load_house,
        load_scene,
        load_scenes,
        plugin_formats,
        register_format,
        writable_formats,
        write_scene,
    )
    from scenemosaic.exchange._sam3d import read_sdf_sim, write_sam3d_example
    from scenemosaic.exchange._sceneeval import (
        LOCAL_TO_GLTF,
        MODEL_ID_PREFIX,
        SupportType,
        export_sceneeval,
        gltf_to_world,
        house_sceneeval_state,
        sceneeval_state,
        support_type,
    )
    from scenemosaic.exchange._urdf import SDF_SCENE_FILE, export_urdf
    from scenemosaic.exchange._usd import export_usd

__all__ = [
    "FORMATS",
    "GLB_ROOT_NODE",
    "HOUSE_FILE",
    "HOUSE_INDEX_FILE",
    "HOUSE_ROOMS_DIR",
    "LOCAL_TO_GLTF",
    "MODEL_ID_PREFIX",
    "PYBULLET_INSTALL_HINT",
    "SDF_SCENE_FILE",
    "SHARED_WALL_THICKNESS_M",
    "Y_UP_TO_Z_UP",
    "Z_UP_TO_Y_UP",
    "AssetDatabase",
    "DatasetEntry",
    "ImportFormat",
    "ReadOptions",
    "SceneFormat",
    "SupportType",
    "build_glb_scene",
    "build_house_glb_scene",
    "dataset_entries",
    "dataset_entry",
    "dataset_size",
    "dataset_stem",
    "deliver_scene",
    "delivered_files",
    "delivered_formats",
    "delivery_parts",
    "detect_format",
    "export_glb",
    "export_house_folder",
    "export_mjcf",
    "export_procthor",
    "export_sceneeval",
    "export_urdf",
    "export_usd",
    "formats_left_out",
    "get_format",
    "gltf_to_world",
    "house_formats",
    "house_sceneeval_state",
    "is_dataset",
    "is_house_source",
    "load_asset_annotations",
    "load_asset_database",
    "load_house",
    "load_pybullet",
    "load_scene",
    "load_scenes",
    "plugin_formats",
    "read_house",
    "read_scene",
    "read_sdf_sim",
    "register_format",
    "save_house",
    "save_partial",
    "save_scene",
    "sceneeval_state",
    "support_type",
    "writable_formats",
    "write_sam3d_example",
    "write_scene",
]

_EXPORTS: dict[str, str] = {
    "DatasetEntry": "_dataset",
    "dataset_entries": "_dataset",
    "dataset_entry": "_dataset",
    "dataset_size": "_dataset",
    "dataset_stem": "_dataset",
    "is_dataset": "_dataset",
    "HOUSE_INDEX_FILE": "_deliver",
    "HOUSE_ROOMS_DIR": "_deliver",
    "deliver_scene": "_deliver",
    "delivered_files": "_deliver",
    "delivered_formats": "_deliver",
    "delivery_parts": "_deliver",
    "export_house_folder": "_deliver",
    "formats_left_out": "_deliver",
    "save_partial": "_deliver",
    "GLB_ROOT_NODE": "_glb",
    "Y_UP_TO_Z_UP": "_glb",
    "Z_UP_TO_Y_UP": "_glb",
    "build_glb_scene": "_glb",
    "build_house_glb_scene": "_glb",
    "export_glb": "_glb",
    "export_mjcf": "_mjcf",
    "read_house": "_native",
    "read_scene": "_native",
    "save_house": "_native",
    "save_scene": "_native",
    "HOUSE_FILE": "_procthor",
    "SHARED_WALL_THICKNESS_M": "_procthor",
    "AssetDatabase": "_procthor",
    "export_procthor": "_procthor",
    "load_asset_annotations": "_procthor",
    "load_asset_database": "_procthor",
    "PYBULLET_INSTALL_HINT": "_pybullet",
    "load_pybullet": "_pybullet",
    "FORMATS": "_registry",
    "ImportFormat": "_registry",
    "ReadOptions": "_registry",
    "SceneFormat": "_registry",
    "detect_format": "_registry",
    "get_format": "_registry",
    "house_formats": "_registry",
    "is_house_source": "_registry",
    "load_house": "_registry",
    "load_scene": "_registry",
    "load_scenes": "_registry",
    "plugin_formats": "_registry",
    "register_format": "_registry",
    "writable_formats": "_registry",
    "write_scene": "_registry",
    "read_sdf_sim": "_sam3d",
    "write_sam3d_example": "_sam3d",
    "LOCAL_TO_GLTF": "_sceneeval",
    "MODEL_ID_PREFIX": "_sceneeval",
    "SupportType": "_sceneeval",
    "export_sceneeval": "_sceneeval",
    "gltf_to_world": "_sceneeval",
    "house_sceneeval_state": "_sceneeval",
    "sceneeval_state": "_sceneeval",
    "support_type": "_sceneeval",
    "SDF_SCENE_FILE": "_urdf",
    "export_urdf": "_urdf",
    "export_usd": "_usd",
}
"""The module of each public name, imported when the name is first used."""


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'scenemosaic.exchange' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"scenemosaic.exchange.{module}"), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


if set(__all__) != set(_EXPORTS):  # pragma: no cover - a guard for maintainers
    raise ImportError("scenemosaic.exchange.__all__ and _EXPORTS disagree")

"""Exchange: every scene format in and out, behind one registry (as ``trimesh.exchange``).

Readers turn other tools' files into :class:`~scenemosaic.scene.Scene` objects; writers turn
scenes into files a simulator or an evaluator loads. A format is one module plus one
:func:`register_format` call (the built-ins are registered in ``_builtin.py``). Built in:

* ``native`` — a folder with ``scene.json`` + ``assets/`` (:func:`save_scene` writes it);
* ``front3d`` — 3D-FRONT / ATISS / PhyScene layouts (``{"ThreedFront": ...}``);
* ``procthor`` — AI2-THOR / ProcTHOR / Holodeck houses (one scene per room);
* ``sam3d`` — image-to-3D object sets: ``poses.json`` + mesh files;
* exports: GLB (:func:`export_glb`), SceneEval sceneState (:func:`export_sceneeval`),
  MJCF (:func:`export_mjcf`), USD with UsdPhysics (:func:`export_usd`, needs the ``usd`` extra)
  and URDF (:func:`export_urdf`, with ``scene.sdf`` beside it for PyBullet: :func:`load_pybullet`);
  a room taken from an AI2-THOR house back into that house
  (:func:`export_procthor`);
* houses: each export has a whole-house counterpart (:func:`export_house_glb`, ...,
  :func:`export_procthor_house`), registered beside it, so :func:`write_scene` takes a
  :class:`~scenemosaic.scene.House` too; :func:`deliver_house` writes a house's delivered folder.

Every malformed input raises :class:`~scenemosaic.exceptions.ImportFormatError` naming the
file and the field, values beyond the scene limits included. A reader only opens files inside
the input's own folder (or ``asset_dir=``), symlinks followed (``scenemosaic.scene.confined_path``).
Conventions and rules: ``docs/importers.md`` and ``docs/exports.md``.
"""

from scenemosaic.exchange import _builtin  # noqa: F401 - registers the built-in formats
from scenemosaic.exchange._deliver import (
    DELIVERED_FORMATS,
    HOUSE_INDEX_FILE,
    HOUSE_ROOMS_DIR,
    OPTIONAL_FORMATS,
    deliver_house,
    deliver_scene,
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
    export_house_glb,
)
from scenemosaic.exchange._mjcf import export_house_mjcf, export_mjcf
from scenemosaic.exchange._native import read_house, read_scene, save_house, save_scene
from scenemosaic.exchange._procthor import (
    HOUSE_FILE,
    SHARED_WALL_THICKNESS_M,
    AssetDatabase,
    export_procthor,
    export_procthor_house,
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
    load_house,
    load_scene,
    load_scenes,
    register_format,
    writable_formats,
    write_scene,
)
from scenemosaic.exchange._sam3d import read_sdf_sim, write_sam3d_example
from scenemosaic.exchange._sceneeval import (
    LOCAL_TO_GLTF,
    MODEL_ID_PREFIX,
    SupportType,
    export_house_sceneeval,
    export_sceneeval,
    gltf_to_world,
    house_sceneeval_state,
    sceneeval_state,
    support_type,
)
from scenemosaic.exchange._urdf import SDF_SCENE_FILE, export_house_urdf, export_urdf
from scenemosaic.exchange._usd import export_house_usd, export_usd

__all__ = [
    "DELIVERED_FORMATS",
    "FORMATS",
    "GLB_ROOT_NODE",
    "HOUSE_FILE",
    "HOUSE_INDEX_FILE",
    "HOUSE_ROOMS_DIR",
    "LOCAL_TO_GLTF",
    "MODEL_ID_PREFIX",
    "OPTIONAL_FORMATS",
    "PYBULLET_INSTALL_HINT",
    "SDF_SCENE_FILE",
    "SHARED_WALL_THICKNESS_M",
    "Y_UP_TO_Z_UP",
    "Z_UP_TO_Y_UP",
    "AssetDatabase",
    "ImportFormat",
    "ReadOptions",
    "SceneFormat",
    "SupportType",
    "build_glb_scene",
    "build_house_glb_scene",
    "deliver_house",
    "deliver_scene",
    "detect_format",
    "export_glb",
    "export_house_folder",
    "export_house_glb",
    "export_house_mjcf",
    "export_house_sceneeval",
    "export_house_urdf",
    "export_house_usd",
    "export_mjcf",
    "export_procthor",
    "export_procthor_house",
    "export_sceneeval",
    "export_urdf",
    "export_usd",
    "formats_left_out",
    "get_format",
    "gltf_to_world",
    "house_sceneeval_state",
    "load_asset_database",
    "load_house",
    "load_pybullet",
    "load_scene",
    "load_scenes",
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

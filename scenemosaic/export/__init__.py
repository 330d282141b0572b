"""Scene exports; frames and read-back recipes are in ``docs/exports.md``.

* :func:`export_glb` — the whole scene as one GLB (``base/scene.glb``): a node per object named
  by its id, the room under ``room/``, everything below a Z-up -> Y-up root node.
* :func:`export_sceneeval` — SceneEval's ``sceneState`` (``base/sceneeval/scene_base.json`` and
  ``assets/<assetId>.glb``) so SceneEval's own metric code can judge our scenes.

* :func:`export_mjcf` — ``scene.xml`` + ``mjcf/`` meshes that plain MuJoCo loads.
"""

from scenemosaic.export._glb import GLB_ROOT_NODE, Y_UP_TO_Z_UP, Z_UP_TO_Y_UP, build_glb_scene, export_glb
from scenemosaic.export._mjcf import export_mjcf
from scenemosaic.export._sceneeval import (
    LOCAL_TO_GLTF,
    MODEL_ID_PREFIX,
    SupportType,
    export_sceneeval,
    gltf_to_world,
    sceneeval_state,
    support_type,
)

__all__ = [
    "GLB_ROOT_NODE",
    "LOCAL_TO_GLTF",
    "MODEL_ID_PREFIX",
    "Y_UP_TO_Z_UP",
    "Z_UP_TO_Y_UP",
    "SupportType",
    "build_glb_scene",
    "export_glb",
    "export_mjcf",
    "export_sceneeval",
    "gltf_to_world",
    "sceneeval_state",
    "support_type",
]

"""Perception: the image front end. A photograph becomes an ordinary :class:`~scenemosaic.scene.Scene`.

Steps (``docs/perception.md``): the photograph is checked (:func:`load_image`); an inventory
lists its objects with pixel boxes (a vision model's :class:`InventoryAgent`, or a detections
file read by :func:`read_detections`); a :class:`Segmenter` cuts each one out; rounds of
:class:`VerifyAgent` correct the masks; a :class:`Reconstructor` lifts every object into the
camera frame; :func:`recover_frame` turns that into the Z-up world of ``docs/conventions.md``.
:func:`perceive` runs them all; ``generate photo.jpg`` calls it in its import stage.

Backends: segmenters ``grabcut`` (OpenCV, offline), ``box``, ``sam3`` (in-process) and any
``http://`` server; reconstructors ``box-lifter`` (offline metrology), ``sam3d`` (in-process)
and any ``http://`` server.
"""

from scenemosaic.perception._agents import (
    MAX_VERIFY_ROUNDS,
    VIEW_MAX_SIDE,
    InventoryAgent,
    PerceptionState,
    VerifyAgent,
    VerifyEvidence,
    VerifyOutput,
    VerifyRequest,
    mask_overlay,
    mask_rows,
    solve_verify,
    support_candidate,
)
from scenemosaic.perception._frame import recover_frame
from scenemosaic.perception._image import (
    DEFAULT_HFOV_DEG,
    IMAGE_SUFFIXES,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE,
    MIN_IMAGE_SIDE,
    Camera,
    SceneImage,
    is_image_path,
    load_image,
)
from scenemosaic.perception._inventory import DetectedObject, Inventory, inventory_problems, read_detections
from scenemosaic.perception._lift import BoxLifter, CameraPose, size_prior
from scenemosaic.perception._perceive import PERCEPTION_FOLDER, PerceptionResult, perceive, reconstructor_for
from scenemosaic.perception._reconstruct import (
    RECONSTRUCTOR_NAMES,
    SAM3D_INSTALL,
    HTTPReconstructor,
    LiftedObject,
    Reconstruction,
    Reconstructor,
    Sam3dReconstructor,
    SeenObject,
)
from scenemosaic.perception._segment import (
    PERCEPTION_INSTALL,
    SAM3_INSTALL,
    SEGMENTER_NAMES,
    BoxSegmenter,
    GrabCutSegmenter,
    HTTPSegmenter,
    ObjectMask,
    Sam3Segmenter,
    Segmenter,
    segmenter_for,
)
from scenemosaic.perception._truth import ObjectScore, TruthScore, heading_symmetry, score_against_truth

__all__ = [
    "DEFAULT_HFOV_DEG",
    "IMAGE_SUFFIXES",
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "MAX_VERIFY_ROUNDS",
    "MIN_IMAGE_SIDE",
    "PERCEPTION_FOLDER",
    "PERCEPTION_INSTALL",
    "RECONSTRUCTOR_NAMES",
    "SAM3D_INSTALL",
    "SAM3_INSTALL",
    "SEGMENTER_NAMES",
    "VIEW_MAX_SIDE",
    "BoxLifter",
    "BoxSegmenter",
    "Camera",
    "CameraPose",
    "DetectedObject",
    "GrabCutSegmenter",
    "HTTPReconstructor",
    "HTTPSegmenter",
    "Inventory",
    "InventoryAgent",
    "LiftedObject",
    "ObjectMask",
    "ObjectScore",
    "PerceptionResult",
    "PerceptionState",
    "Reconstruction",
    "Reconstructor",
    "Sam3Segmenter",
    "Sam3dReconstructor",
    "SceneImage",
    "SeenObject",
    "Segmenter",
    "TruthScore",
    "VerifyAgent",
    "VerifyEvidence",
    "VerifyOutput",
    "VerifyRequest",
    "heading_symmetry",
    "inventory_problems",
    "is_image_path",
    "load_image",
    "mask_overlay",
    "mask_rows",
    "perceive",
    "read_detections",
    "reconstructor_for",
    "recover_frame",
    "score_against_truth",
    "segmenter_for",
    "size_prior",
    "solve_verify",
    "support_candidate",
]

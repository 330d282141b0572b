"""Scene model (pydantic), geometry helpers, JSON io and importers.

This is the lowest layer: it imports nothing from the rest of scenemosaic but
``scenemosaic.exceptions``.
"""

from scenemosaic.scene._geometry import (
    front_vector,
    quat_from_yaw,
    quat_multiply,
    quat_to_matrix,
    yaw_from_quat,
)
from scenemosaic.scene._model import (
    CEILING,
    FLOOR,
    QUAT_NORM_TOLERANCE,
    AssetRef,
    ConstraintClause,
    CrossUnitConstraint,
    LocalUnit,
    Opening,
    Pose,
    Provenance,
    Relation,
    Room,
    Scene,
    SceneObject,
    SceneStructure,
    SimAttributes,
    Wall,
)
from scenemosaic.scene._tree import build_structure, format_tree, unit_frame, unit_layout, with_unit_layout

__all__ = [
    "CEILING",
    "FLOOR",
    "QUAT_NORM_TOLERANCE",
    "AssetRef",
    "ConstraintClause",
    "CrossUnitConstraint",
    "LocalUnit",
    "Opening",
    "Pose",
    "Provenance",
    "Relation",
    "Room",
    "Scene",
    "SceneObject",
    "SceneStructure",
    "SimAttributes",
    "Wall",
    "build_structure",
    "format_tree",
    "front_vector",
    "quat_from_yaw",
    "quat_multiply",
    "quat_to_matrix",
    "unit_frame",
    "unit_layout",
    "with_unit_layout",
    "yaw_from_quat",
]

"""Scene model (pydantic), geometry helpers, JSON io and importers.

This is the lowest layer: it imports nothing from the rest of scenemosaic but
``scenemosaic.exceptions``.
"""

from scenemosaic.scene._geometry import front_vector, quat_from_yaw, quat_multiply, quat_to_matrix, yaw_from_quat
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
    "front_vector",
    "quat_from_yaw",
    "quat_multiply",
    "quat_to_matrix",
    "yaw_from_quat",
]

"""The scene: pydantic model, rigid-transform geometry, the scene tree, category knowledge, rooms.

This is the lowest layer: it imports nothing from the rest of scenemosaic but
``scenemosaic.exceptions``. It owns the domain vocabulary every other layer shares: one
category normalization (:func:`normalize_category`, :func:`traits`), the ProcTHOR priors the
agents and importers read (package data, :func:`load_priors`, :func:`procthor_asset_database`),
one room recovery (:func:`recover_room`) and one rigid "move with descendants"
(:func:`with_unit_layout` / :func:`move_with_descendants`).
"""

from scenemosaic.scene._categories import (
    PROCTHOR_PRIORS_DIR,
    CategoryTraits,
    SupportPriors,
    is_known,
    load_priors,
    normalize_category,
    thor_type,
    traits,
)
from scenemosaic.scene._geometry import (
    FloatArray,
    front_vector,
    quat_from_matrix,
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
from scenemosaic.scene._room import (
    CEILING_LAMP_CATEGORIES,
    MIN_CEILING_HEIGHT,
    ROOM_MARGIN,
    TOP_CLEARANCE,
    dominant_orientation,
    recover_room,
)
from scenemosaic.scene._tree import (
    build_structure,
    descendants,
    format_tree,
    rigid_moves,
    unit_frame,
    unit_layout,
    with_unit_layout,
)

__all__ = [
    "CEILING",
    "CEILING_LAMP_CATEGORIES",
    "FLOOR",
    "MIN_CEILING_HEIGHT",
    "PROCTHOR_PRIORS_DIR",
    "QUAT_NORM_TOLERANCE",
    "ROOM_MARGIN",
    "TOP_CLEARANCE",
    "AssetRef",
    "CategoryTraits",
    "ConstraintClause",
    "CrossUnitConstraint",
    "FloatArray",
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
    "SupportPriors",
    "Wall",
    "build_structure",
    "descendants",
    "dominant_orientation",
    "format_tree",
    "front_vector",
    "is_known",
    "load_priors",
    "normalize_category",
    "quat_from_matrix",
    "quat_from_yaw",
    "quat_multiply",
    "quat_to_matrix",
    "recover_room",
    "rigid_moves",
    "thor_type",
    "traits",
    "unit_frame",
    "unit_layout",
    "with_unit_layout",
    "yaw_from_quat",
]

"""Physics: MuJoCo unit worlds, containment correction, gravity settling, collision and bounds checks.

Entry points: :func:`stabilize_scene` (per local unit, top-down), :func:`check_collisions`,
:func:`check_out_of_bounds` and :func:`validate_scene`. Tolerances are named constants in
:mod:`scenemosaic.physics._settings`; the frames and settings are described in ``docs/physics.md``.
"""

from scenemosaic.physics._checks import (
    RESTING_MIN_INSIDE_FRACTION,
    check_collisions,
    check_out_of_bounds,
    collision_report_for,
    require_finite_poses,
    resting_footprint,
    rests_within,
)
from scenemosaic.physics._doors import DOOR_PACK_CELL_M, DoorRepair, clear_doors
from scenemosaic.physics._hulls import HullInput, HullPiece, ObjectShape, hull_mesh, object_shape
from scenemosaic.physics._parts_free import PartRepair, free_part_paths
from scenemosaic.physics._pull import PartPull, pull_parts
from scenemosaic.physics._reports import (
    CollisionPair,
    CollisionReport,
    ObjectMotion,
    OutOfBoundsObject,
    OutOfBoundsReport,
    StabilizationReport,
    UnitReport,
    ValidationReport,
)
from scenemosaic.physics._screens import SCREEN_STEP_M, rehang_screens
from scenemosaic.physics._settings import (
    COLLISION_TOLERANCE_M,
    FELL_DROP_M,
    OOB_MIN_INSIDE_FRACTION,
    ROOM_FRICTION,
    TIPPED_TILT_DEG,
    SettleSettings,
    SimSettings,
)
from scenemosaic.physics._settle import settle_unit
from scenemosaic.physics._stabilize import stabilize_scene, stabilize_scene_sync
from scenemosaic.physics._units import UnitPlan, plan_units
from scenemosaic.physics._validate import (
    house_world,
    is_fixed,
    scene_world,
    support_gaps,
    validate_scene,
    write_house_mjcf,
    write_scene_mjcf,
)
from scenemosaic.physics._world import (
    ObjectInertial,
    RoomSlab,
    house_slabs,
    object_inertial,
    object_mass,
    part_inertials,
    room_slabs,
)
from scenemosaic.scene import THIN_RATIO, is_thin

__all__ = [
    "COLLISION_TOLERANCE_M",
    "DOOR_PACK_CELL_M",
    "FELL_DROP_M",
    "OOB_MIN_INSIDE_FRACTION",
    "RESTING_MIN_INSIDE_FRACTION",
    "ROOM_FRICTION",
    "SCREEN_STEP_M",
    "THIN_RATIO",
    "TIPPED_TILT_DEG",
    "CollisionPair",
    "CollisionReport",
    "DoorRepair",
    "HullInput",
    "HullPiece",
    "ObjectInertial",
    "ObjectMotion",
    "ObjectShape",
    "OutOfBoundsObject",
    "OutOfBoundsReport",
    "PartPull",
    "PartRepair",
    "RoomSlab",
    "SettleSettings",
    "SimSettings",
    "StabilizationReport",
    "UnitPlan",
    "UnitReport",
    "ValidationReport",
    "check_collisions",
    "check_out_of_bounds",
    "clear_doors",
    "collision_report_for",
    "free_part_paths",
    "house_slabs",
    "house_world",
    "hull_mesh",
    "is_fixed",
    "is_thin",
    "object_inertial",
    "object_mass",
    "object_shape",
    "part_inertials",
    "plan_units",
    "pull_parts",
    "rehang_screens",
    "require_finite_poses",
    "resting_footprint",
    "rests_within",
    "room_slabs",
    "scene_world",
    "settle_unit",
    "stabilize_scene",
    "stabilize_scene_sync",
    "support_gaps",
    "validate_scene",
    "write_house_mjcf",
    "write_scene_mjcf",
]

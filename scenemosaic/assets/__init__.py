"""Assets: mesh loading and canonicalization, content hashes, the CoACD hull cache and the
procedural furniture library.

The canonical asset frame is the object's local frame: Z up, metres, origin at the bottom
centre of the footprint, front along -Y (``docs/assets.md``). This layer imports only
:mod:`scenemosaic.scene` and :mod:`scenemosaic.exceptions` (and the in-process memo,
:mod:`scenemosaic._memo`).

Every file a mesh names (buffers, textures, materials) must lie in the mesh's folder
(:func:`referenced_files`); meshes above ``MAX_MESH_FACES`` faces are refused.
"""

from scenemosaic.assets._articulation import (
    DOOR_OPEN_DEG,
    DRAWER_TRAVEL_FRACTION,
    LID_OPEN_DEG,
    OPEN_STATES,
    ROOM_DOOR_OPEN_DEG,
    TOILET_LID_OPEN_DEG,
    USABLE_HINGE_RAD,
    USABLE_SLIDE_SHARE,
    Box6,
    HingeSide,
    JointType,
    OpenState,
    PartKind,
    PartSpec,
    declared_part,
    declared_tolerance,
    opening,
    pieces_in_box,
    usable_value,
    with_pieces,
)
from scenemosaic.assets._canonical import CanonicalMesh, load_mesh, mesh_hash
from scenemosaic.assets._files import MESH_SUFFIXES, PARTS_FILE_SUFFIX, referenced_files
from scenemosaic.assets._furniture import (
    ROOM_DOOR_CATEGORIES,
    ROOM_DOOR_HANDLE_PROUD_M,
    ROOM_DOOR_JAMB_M,
    ROOM_DOOR_LEAF_M,
    SHELF_PITCH,
)
from scenemosaic.assets._hulls import CoacdParams, HullCache, default_cache_dir, shutdown_workers
from scenemosaic.assets._objects import (
    PART_TAG,
    asset_fingerprint,
    default_hull_cache,
    object_articulation,
    object_hulls,
    object_mesh,
    object_mesh_arrays,
    object_part_arrays,
    object_part_meshes,
)
from scenemosaic.assets._opening import (
    OPEN_STATE_KEY,
    free_openings,
    open_scene,
    part_blockers,
    part_openings,
    short_parts,
)
from scenemosaic.assets._procedural import (
    MAX_PARTS,
    compartment_fits,
    interior_boards,
    known_categories,
    procedural_articulation,
    procedural_key,
    procedural_mesh,
    procedural_parts,
)
from scenemosaic.assets._room_doors import (
    FIT_CLEARANCE_M,
    FIT_STEP_DEG,
    ROOM_DOOR_KG_PER_M2,
    RoomDoor,
    room_door_leaves,
    with_room_doors,
)

__all__ = [
    "DOOR_OPEN_DEG",
    "DRAWER_TRAVEL_FRACTION",
    "FIT_CLEARANCE_M",
    "FIT_STEP_DEG",
    "LID_OPEN_DEG",
    "MAX_PARTS",
    "MESH_SUFFIXES",
    "OPEN_STATES",
    "OPEN_STATE_KEY",
    "PARTS_FILE_SUFFIX",
    "PART_TAG",
    "ROOM_DOOR_CATEGORIES",
    "ROOM_DOOR_HANDLE_PROUD_M",
    "ROOM_DOOR_JAMB_M",
    "ROOM_DOOR_KG_PER_M2",
    "ROOM_DOOR_LEAF_M",
    "ROOM_DOOR_OPEN_DEG",
    "SHELF_PITCH",
    "TOILET_LID_OPEN_DEG",
    "USABLE_HINGE_RAD",
    "USABLE_SLIDE_SHARE",
    "Box6",
    "CanonicalMesh",
    "CoacdParams",
    "HingeSide",
    "HullCache",
    "JointType",
    "OpenState",
    "PartKind",
    "PartSpec",
    "RoomDoor",
    "asset_fingerprint",
    "compartment_fits",
    "declared_part",
    "declared_tolerance",
    "default_cache_dir",
    "default_hull_cache",
    "free_openings",
    "interior_boards",
    "known_categories",
    "load_mesh",
    "mesh_hash",
    "object_articulation",
    "object_hulls",
    "object_mesh",
    "object_mesh_arrays",
    "object_part_arrays",
    "object_part_meshes",
    "open_scene",
    "opening",
    "part_blockers",
    "part_openings",
    "pieces_in_box",
    "procedural_articulation",
    "procedural_key",
    "procedural_mesh",
    "procedural_parts",
    "referenced_files",
    "room_door_leaves",
    "short_parts",
    "shutdown_workers",
    "usable_value",
    "with_pieces",
    "with_room_doors",
]

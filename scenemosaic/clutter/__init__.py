"""Clutter: small objects drawn from the ProcTHOR priors, moved between receptacles per variant,
settled by physics (``docs/clutter.md``).

Entry points: :func:`fill_scene` (receptacles emptier than the priors' typical density get objects
drawn for their type and the room's kind, packed, settled and kept only when they rest),
:func:`vary_scene` (a variant's small objects moved between the receptacles their type may use,
counts changed, assets swapped), :func:`carry_clutter` (a base scene's small objects carried onto a
variant whose furniture moved) and :func:`clutter_distance` (how differently two scenes place their
small objects). The priors are read by :func:`load_clutter_priors`.
"""

from scenemosaic.clutter._fill import (
    CLUTTER_METADATA,
    DEFAULT_DENSITY,
    MIN_BASE_RATIO,
    MIN_TYPICAL,
    OFF_SURFACE_M,
    ClutterReport,
    clutter_ids,
    fill_scene,
    new_clutter_object,
    receptacles,
    remove_objects,
)
from scenemosaic.clutter._priors import (
    ROOM_TYPE_FLAGS,
    ClutterAsset,
    ClutterPriors,
    load_clutter_priors,
    room_kind,
    thor_category,
)
from scenemosaic.clutter._rest import REST_SECONDS, REST_TOLERANCE_M, motions_over, rest_check
from scenemosaic.clutter._surfaces import MAX_TOP_HEIGHT_M, MIN_SURFACE_M2, Surface, receptacle_surfaces
from scenemosaic.clutter._vary import (
    CLUTTER_SPAN_M,
    MOVE_SHARE,
    SWAP_SHARE,
    SWAP_SIZE_RATIO,
    carry_clutter,
    clutter_distance,
    resting_place,
    small_objects,
    vary_scene,
)

__all__ = [
    "CLUTTER_METADATA",
    "CLUTTER_SPAN_M",
    "DEFAULT_DENSITY",
    "MAX_TOP_HEIGHT_M",
    "MIN_BASE_RATIO",
    "MIN_SURFACE_M2",
    "MIN_TYPICAL",
    "MOVE_SHARE",
    "OFF_SURFACE_M",
    "REST_SECONDS",
    "REST_TOLERANCE_M",
    "ROOM_TYPE_FLAGS",
    "SWAP_SHARE",
    "SWAP_SIZE_RATIO",
    "ClutterAsset",
    "ClutterPriors",
    "ClutterReport",
    "Surface",
    "carry_clutter",
    "clutter_distance",
    "clutter_ids",
    "fill_scene",
    "load_clutter_priors",
    "motions_over",
    "new_clutter_object",
    "receptacle_surfaces",
    "receptacles",
    "remove_objects",
    "rest_check",
    "resting_place",
    "room_kind",
    "small_objects",
    "thor_category",
    "vary_scene",
]

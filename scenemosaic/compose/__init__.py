"""Stage 5 of the method: compose whole-scene variants from unit variants and select diverse ones.

* :func:`novelty_distance` — the method's novelty-aware distance N(A, B) (A the reference).
* :class:`CandidatePool` — the lazy Cartesian product of group variants, scored through per-group
  and per-group-pair tables; :func:`select_diverse` — the dynamic max-min greedy over it.
* :func:`compose_variants` — a scene's m diverse valid variants; :func:`compose_house` — a
  house's, over one pool spanning every room.
* :func:`compose_transform` / :func:`decompose_transform` — anchor-relative grafting and the polar
  decomposition that recovers position, rotation and scale.
"""

from scenemosaic.compose._compose import (
    HOUSE_MAX_CANDIDATES,
    OCCUPANCY_GRID,
    CompositionReport,
    UnitLayouts,
    compose_house,
    compose_variants,
    kept_layouts,
)
from scenemosaic.compose._distance import (
    CLUTTER_WEIGHT,
    WEIGHTS,
    Arrangement,
    distance_terms,
    novelty_distance,
    novelty_with_clutter,
)
from scenemosaic.compose._pool import (
    ALPHA,
    CHUNK,
    MIN_NOVELTY,
    OCCUPANCY_WEIGHT,
    CandidatePool,
    GroupVariants,
    Selection,
    select_diverse,
)
from scenemosaic.compose._transform import compose_transform, decompose_transform

__all__ = [
    "ALPHA",
    "CHUNK",
    "CLUTTER_WEIGHT",
    "HOUSE_MAX_CANDIDATES",
    "MIN_NOVELTY",
    "OCCUPANCY_GRID",
    "OCCUPANCY_WEIGHT",
    "WEIGHTS",
    "Arrangement",
    "CandidatePool",
    "CompositionReport",
    "GroupVariants",
    "Selection",
    "UnitLayouts",
    "compose_house",
    "compose_transform",
    "compose_variants",
    "decompose_transform",
    "distance_terms",
    "kept_layouts",
    "novelty_distance",
    "novelty_with_clutter",
    "select_diverse",
]

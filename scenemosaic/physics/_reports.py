"""Typed reports returned by the physics entry points (pydantic, JSON-serializable)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "CollisionPair",
    "CollisionReport",
    "ObjectMotion",
    "OutOfBoundsObject",
    "OutOfBoundsReport",
    "StabilizationReport",
    "UnitReport",
    "ValidationReport",
]


class _Report(BaseModel):
    model_config = ConfigDict(extra="forbid")


class CollisionPair(_Report):
    """Two objects whose convex hulls interpenetrate; ``depth_m`` is the deepest hull-pair penetration."""

    a: str
    b: str
    depth_m: float = Field(description="Penetration depth in metres (positive = overlapping).")
    contacts: int = Field(default=0, description="Convex hull-piece pairs that interpenetrate (contact count).")


class CollisionReport(_Report):
    """Pairwise collisions counted above ``tolerance_m``, plus the shallower touching pairs for context."""

    tolerance_m: float
    pairs: list[CollisionPair] = Field(default_factory=list, description="Pairs deeper than the tolerance.")
    shallow: list[CollisionPair] = Field(
        default_factory=list, description="Pairs that touch or overlap by at most the tolerance."
    )
    thin_excluded: list[str] = Field(default_factory=list, description="Thin objects left out of counting.")
    checked_objects: int = 0

    @property
    def count(self) -> int:
        """Number of colliding pairs (SceneEval's COL numerator)."""
        return len(self.pairs)

    def object_ids(self) -> set[str]:
        """Ids of every object in a counted pair."""
        return {p.a for p in self.pairs} | {p.b for p in self.pairs}


class OutOfBoundsObject(_Report):
    """An object whose footprint is not (enough) over its support surface."""

    object_id: str
    anchor_id: str
    inside_fraction: float = Field(description="Fraction of the footprint area over the support surface.")


class OutOfBoundsReport(_Report):
    """Objects failing SceneEval's rule: less than ``min_inside_fraction`` of the footprint inside."""

    min_inside_fraction: float
    objects: list[OutOfBoundsObject] = Field(default_factory=list)
    checked_objects: int = 0
    skipped: list[str] = Field(default_factory=list, description="Objects with no surface to check against.")

    @property
    def count(self) -> int:
        """Number of out-of-bounds objects."""
        return len(self.objects)


class ObjectMotion(_Report):
    """How one object moved between two poses."""

    object_id: str
    displacement_m: float
    yaw_change_deg: float
    tilt_deg: float = Field(description="Angle between the object's up axis before and after, degrees.")


class UnitReport(_Report):
    """What stabilization did to one local unit."""

    anchor_id: str
    anchor_kind: Literal["floor", "wall", "ceiling", "object"]
    depth: int
    children: list[str]
    containment_moves: dict[str, float] = Field(
        default_factory=dict, description="Objects moved inside the anchor's surface, and by how far (m)."
    )
    larger_than_anchor: list[str] = Field(
        default_factory=list, description="Children that found no free place on the anchor's surface."
    )
    turned: list[str] = Field(
        default_factory=list, description="Loose items turned a quarter to fit the anchor's free surface."
    )
    separation_moves: dict[str, float] = Field(
        default_factory=dict,
        description="Objects moved to resolve initial interpenetration, and by how far (m).",
    )
    unresolved_overlaps: list[tuple[str, str]] = Field(default_factory=list)
    steps: int = 0
    simulated_s: float = 0.0
    wall_s: float = 0.0
    converged: bool = True
    fallbacks: list[str] = Field(default_factory=list, description="Fallbacks taken after a blow-up.")
    rolled_back: list[str] = Field(
        default_factory=list, description="Objects kept at their pre-simulation pose."
    )


class StabilizationReport(_Report):
    """Outcome of :func:`stabilize_scene`: one entry per unit (top-down) and per-object motion."""

    seed: int
    units: list[UnitReport] = Field(default_factory=list)
    motions: list[ObjectMotion] = Field(default_factory=list)
    unsupported_defaulted: list[str] = Field(
        default_factory=list,
        description="Objects with no support relation, treated as standing on the floor.",
    )
    wall_s: float = 0.0
    against_snapped: list[str] = Field(
        default_factory=list, description="Objects slid flush against the wall they stand against."
    )

    def motion(self, object_id: str) -> ObjectMotion:
        """Motion record of one object; raises ``KeyError`` when it was not stabilized."""
        for m in self.motions:
            if m.object_id == object_id:
                return m
        raise KeyError(object_id)


class ValidationReport(_Report):
    """Final check of a whole scene: residual collisions, out of bounds, and a short gravity run."""

    collisions: CollisionReport
    out_of_bounds: OutOfBoundsReport
    tipped: list[str] = Field(default_factory=list)
    fell: list[str] = Field(default_factory=list)
    motions: list[ObjectMotion] = Field(default_factory=list)
    max_displacement_m: float = 0.0
    support_gaps_m: dict[str, float] = Field(
        default_factory=dict,
        description="Per object: distance from its support along gravity (negative = sunk into it), metres.",
    )
    simulated_s: float = 0.0
    parts_moved: dict[str, float] = Field(
        default_factory=dict,
        description=(
            "Per movable part (``<object id>/<part>``, a room door's leaves among them) that moved "
            "from where it is delivered while the world settled, more than PART_DRIFT_DEG or "
            "PART_DRIFT_M: how far (degrees for a hinge, metres for a slide)."
        ),
    )
    nested: list[str] = Field(
        default_factory=list,
        description="Pairs of floor furniture (not containers, not a seat under a table) standing inside each other's boxes.",
    )

    @property
    def ok(self) -> bool:
        """True when nothing collides, nothing is out of bounds, nothing fell or tipped, and no
        part moved from where it is delivered."""
        return not (self.collisions.pairs or self.out_of_bounds.objects or self.tipped or self.fell or self.parts_moved)

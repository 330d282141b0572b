"""Named tolerances and the simulator settings used by stabilization and validation.

Every number that decides whether a scene counts as physically valid lives here, with its
unit, so reports and tests refer to one place.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "COLLISION_TOLERANCE_M",
    "DEFAULT_DENSITY_KG_M3",
    "FELL_DROP_M",
    "OOB_MIN_INSIDE_FRACTION",
    "PART_DRIFT_DEG",
    "PART_DRIFT_M",
    "ROOM_FRICTION",
    "SEPARATION_GAP_M",
    "TIPPED_TILT_DEG",
    "SettleSettings",
    "SimSettings",
]

COLLISION_TOLERANCE_M = 0.005
"""A pair of objects collides when their hulls interpenetrate deeper than this (metres).

SceneEval counts a pair as colliding when it still intersects after one object is moved
5 mm apart, which is the same as a penetration depth above 5 mm."""


OOB_MIN_INSIDE_FRACTION = 0.99
"""SceneEval's out-of-bounds rule: an object is out of bounds when less than this fraction of its
footprint lies over the floor polygon (or over its anchor's support surface)."""

TIPPED_TILT_DEG = 10.0
"""An object whose up axis tilts more than this many degrees (against its pose before simulation)
counts as tipped."""

FELL_DROP_M = 0.05
"""An object that moves more than this distance along gravity during validation counts as fallen."""

PART_DRIFT_DEG = 2.0
"""A hinged part (a door, a lid, a room door's leaf) that turns more than this many degrees from
where it is delivered while validation settles the world counts as moved: something pushes it, or
it does not hold its pose."""

PART_DRIFT_M = 0.01
"""A sliding part (a drawer) that slides more than this from where it is delivered while
validation settles the world counts as moved."""

SEPARATION_GAP_M = 0.003
"""Clearance left between siblings when deep initial interpenetrations are resolved geometrically.
A few millimetres so that resting contacts do not start in penetration."""

DEFAULT_DENSITY_KG_M3 = 400.0
"""Density used when an object has neither ``mass_kg`` nor ``density_kg_m3`` (roughly wood furniture
with hollow parts). The resulting mass is clamped to [0.05, 500] kg."""

ROOM_FRICTION = 1.0
"""Sliding friction coefficient of the room's floor, wall and ceiling slabs (MuJoCo's default geom
friction, which the simulated room has always used). The exports give the room this value too."""


@dataclass(frozen=True)
class SimSettings:
    """MuJoCo options for unit worlds, chosen for stable resting contact of stacked furniture."""

    timestep: float = 0.002
    """Integration step in seconds; 2 ms keeps box stacks stiff without jitter."""
    solver: str = "Newton"
    """Constraint solver (``Newton``, ``CG`` or ``PGS``); Newton converges in few iterations for contacts."""
    iterations: int = 30
    """Maximum solver iterations per step."""
    ls_iterations: int = 20
    """Maximum line-search iterations of the Newton/CG solver."""
    cone: str = "elliptic"
    """Friction cone; elliptic cones with a raised ``impratio`` stop slow creeping on slopes."""
    impratio: float = 10.0
    """Frictional-to-normal impedance ratio; > 1 makes friction stiffer (less sliding while resting)."""
    integrator: str = "implicitfast"
    """Integrator; implicit damping keeps joint damping unconditionally stable."""
    margin: float = 0.0
    """Contact margin in metres; zero so that resting objects touch their support instead of hovering."""
    gravity: float = 9.81
    """Magnitude of gravity, m/s^2; its direction depends on the unit's anchor."""
    damping_per_kg: float = 2.0
    """Joint damping of the translational degrees of freedom per kilogram of body mass (1/s)."""


@dataclass(frozen=True)
class SettleSettings:
    """When a settling run counts as converged, and when it counts as blown up."""

    max_time_s: float = 1.0
    """Step cap, in simulated seconds."""
    check_every: int = 10
    """Steps between convergence checks."""
    linear_speed_mps: float = 0.005
    """Every body's linear speed must stay under this (m/s) ..."""
    angular_speed_rps: float = 0.05
    """... and its angular speed under this (rad/s) ..."""
    window_s: float = 0.06
    """... for this long (simulated seconds) to count as settled."""
    blowup_speed_mps: float = 4.0
    """A body faster than this (m/s) counts as a blow-up."""
    blowup_displacement_m: float = 0.5
    """A body that moves further than this from its start counts as a blow-up."""

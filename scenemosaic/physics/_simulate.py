"""Stepping a built world until it settles, with blow-up detection."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from scenemosaic.physics._settings import SettleSettings
from scenemosaic.physics._world import BuiltWorld, DynamicBody

__all__ = ["SimOutcome", "body_speeds", "run_until_settled"]


@dataclass
class SimOutcome:
    """How a settling run ended."""

    steps: int = 0
    simulated_s: float = 0.0
    converged: bool = False
    blown_up: list[str] = field(default_factory=list)
    """Objects whose speed or displacement went past the blow-up bounds (or became NaN)."""


def body_speeds(world: BuiltWorld, body: DynamicBody) -> tuple[float, float]:
    """Linear and angular speed of a dynamic body (m/s, rad/s)."""
    v = world.data.qvel[body.dof_slice]
    if body.joint_mode == "free":
        return float(np.linalg.norm(v[:3])), float(np.linalg.norm(v[3:6]))
    return float(np.linalg.norm(v[:3])), float(np.linalg.norm(v[3:])) if len(v) > 3 else 0.0


_INSTABILITY_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)
"""MuJoCo's own instability checks. When one fires, ``mj_step`` resets the whole state to the
initial pose (and only prints a warning), so the NaN is gone before our own check could see it."""


def _instability_counts(world: BuiltWorld) -> list[int]:
    return [int(world.data.warning[w].number) for w in _INSTABILITY_WARNINGS]


def _unstable_bodies(world: BuiltWorld) -> list[str]:
    """Bodies named by the DOF index MuJoCo reported with its last instability warning."""
    out: list[str] = []
    for w in _INSTABILITY_WARNINGS:
        info = world.data.warning[w]
        if info.number == 0:
            continue
        dof = int(info.lastinfo)
        for b in world.bodies:
            sl = b.dof_slice
            if sl.start <= dof < sl.stop and b.object_id not in out:
                out.append(b.object_id)
    return out


def run_until_settled(world: BuiltWorld, settle: SettleSettings, *, min_time_s: float = 0.0) -> SimOutcome:
    """Step until every body stays slow for ``settle.window_s`` (after ``min_time_s``), or the cap.

    A body faster than ``blowup_speed_mps``, further than ``blowup_displacement_m`` from where
    it started, or with a non-finite state ends the run with that body listed in ``blown_up``
    (MuJoCo's own bad-state warnings count too: MuJoCo resets the state when it sees a NaN,
    which would otherwise look like a calm scene back at its start).
    """
    m, d = world.model, world.data
    out = SimOutcome()
    if not world.bodies:
        out.converged = True
        return out
    start = np.array([d.xpos[b.body_id] for b in world.bodies])
    cap = max(1, round(settle.max_time_s / m.opt.timestep))
    window = max(1, round(settle.window_s / m.opt.timestep))
    min_steps = round(min_time_s / m.opt.timestep)
    calm_steps = 0
    warned = _instability_counts(world)
    while out.steps < cap:
        n = min(settle.check_every, cap - out.steps)
        mujoco.mj_step(m, d, nstep=n)
        out.steps += n
        if _instability_counts(world) != warned:
            # MuJoCo found NaN/inf or a huge value and reset the state: a blow-up, never a rest.
            out.blown_up = _unstable_bodies(world) or [b.object_id for b in world.bodies]
            break
        if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            bad = [b.object_id for b in world.bodies if not np.all(np.isfinite(d.qvel[b.dof_slice]))]
            out.blown_up = bad or [b.object_id for b in world.bodies]
            break
        speeds = [body_speeds(world, b) for b in world.bodies]
        disp = np.linalg.norm(np.array([d.xpos[b.body_id] for b in world.bodies]) - start, axis=1)
        bad = [
            b.object_id
            for b, (lin, _), dd in zip(world.bodies, speeds, disp, strict=True)
            if lin > settle.blowup_speed_mps or dd > settle.blowup_displacement_m
        ]
        if bad:
            out.blown_up = bad
            break
        calm = all(lin < settle.linear_speed_mps and ang < settle.angular_speed_rps for lin, ang in speeds)
        calm_steps = calm_steps + n if calm else 0
        if calm_steps >= window and out.steps >= min_steps:
            out.converged = True
            break
    out.simulated_s = out.steps * float(m.opt.timestep)
    return out

"""The pull test: does every part of a delivered world open through its range, in plain MuJoCo?

Measured on the model a user loads (``base/scene.xml``, or any MJCF the exports write), reading
nothing of ours but the joint names (``<object id>/<part>``; a room door's leaves are the parts
named ``leaf``/``leaf_<k>``). Each part is tried on its own, from the world as loaded with every
part closed and the part's own weight cancelled (a lid is neither helped nor held by it; the rest
of the world keeps its weight, so furniture stands and what it carries rests): a hand's pull on the
part alone (a force along a slide, a torque about a hinge, applied to the part's body, so the
carcass is not shoved back by the test itself as a drive between the two would) turns or slides it
towards its upper limit at a steady pace (about its range a second), with at most
:data:`PULL_WEIGHTS` times its weight at its centre of mass, for :data:`PULL_SECONDS`; the pull and
the weight's cancelling build up over :data:`ONSET_S`, as a hand's do. A hinge
passes once it stands at 90° (or its whole range, when shorter), a slide at 80 % of its travel
(``assets.usable_opening``); a part that did not, or that moved another body more
than :data:`PUSHED_M` on its way, is blocked, by what its body touches at the end (another object,
or a wall) or by what it pushed; what a drawer carries (the objects touching it closed) rides with
it and is not counted as pushed, while something lying on a lid or a door is (a hinged part lifts
or throws it). A room door's leaf is swung the same way, from shut.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from scenemosaic.assets import usable_opening

__all__ = [
    "ONSET_S",
    "PULL_SECONDS",
    "PULL_WEIGHTS",
    "PUSHED_M",
    "PartPull",
    "pull_parts",
]

PULL_SECONDS = 2.0
"""How long each part is pulled, s."""
PULL_WEIGHTS = 2.0
"""The most the drive pulls with, in the part's weights at its centre of mass (plus what its joint's
friction and damping take at the drive's pace)."""
PUSHED_M = 0.02
"""A pull that moves another body further than this is blocked by it, m."""
ONSET_S = 0.3
"""The hand's pull, and the cancelling of the part's weight, build up over this long, s. A hand does
not strike at full force: a step of either at the first instant jolts the carcass on its contacts,
and a bowl on a dresser hopped 2-4 cm while the dresser's bottom drawer was pulled (held-out
``mq_hallway_3``); built up over 0.3 s nothing else moved by 1 mm."""
FASTEST_M_S = 5.0
"""No body may move faster than this during a pull (a world that explodes), m/s."""
_SLACK_RAD = math.radians(0.5)
_FREE, _SLIDE, _HINGE = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE))


@dataclass(frozen=True)
class PartPull:
    """What one part did when pulled."""

    joint: str
    """The part's joint: ``<object id>/<part>``."""
    kind: str
    """``hinge`` or ``slide``."""
    room_door: bool
    """Whether the part is a room door's leaf."""
    reached: float
    """The joint value it reached (rad or m)."""
    needed: float
    """The value that passes."""
    upper: float
    """Its upper limit."""
    passed: bool
    blocked_by: str | None
    """What stopped it: the object (or wall geom) its body touched at the end, or that it pushed."""
    pushed_m: float
    """How far it moved the body it moved most, m."""
    fastest_m_s: float
    """The fastest any body moved during the pull, m/s."""

    @property
    def reached_share(self) -> float:
        """``reached`` as a share of the upper limit."""
        return self.reached / self.upper if self.upper > 0 else 1.0


def _root_name(model: mujoco.MjModel, body: int) -> str:
    root = int(model.body_rootid[body])
    return model.body(root).name if root != 0 else "world"


def pull_parts(model: mujoco.MjModel | str | Path, *, room_doors: bool = True) -> list[PartPull]:
    """Pull every part (hinge or slide joint named ``<object>/<part>``) of ``model`` (an MJCF path
    or a loaded model), each on its own, and say how far it got (see the module). ``room_doors``:
    swing the rooms' door leaves too."""
    if not isinstance(model, mujoco.MjModel):
        model = mujoco.MjModel.from_xml_path(str(model))
    data = mujoco.MjData(model)
    parts = [
        j
        for j in range(model.njnt)
        if "/" in model.joint(j).name
        and int(model.jnt_type[j]) in (_HINGE, _SLIDE)
        and (room_doors or not _is_leaf(model.joint(j).name))
    ]
    closed = model.qpos0.copy()
    for j in parts:
        closed[model.jnt_qposadr[j]] = 0.0
    free = [j for j in range(model.njnt) if int(model.jnt_type[j]) == _FREE]
    return [_pull(model, data, j, closed, free) for j in parts]


def _is_leaf(joint: str) -> bool:
    part = joint.rsplit("/", 1)[1]
    return part == "leaf" or part.startswith("leaf_")


def _pull(model: mujoco.MjModel, data: mujoco.MjData, j: int, closed: np.ndarray, free: list[int]) -> PartPull:
    mujoco.mj_resetData(model, data)
    data.qpos[:] = closed
    mujoco.mj_forward(model, data)
    q, dof, body = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), int(model.jnt_bodyid[j])
    hinge = int(model.jnt_type[j]) == _HINGE
    upper = float(model.jnt_range[j][1])
    needed = usable_opening("hinge" if hinge else "slide", upper) - (_SLACK_RAD if hinge else 0.0)
    mass = float(model.body_subtreemass[body])
    if hinge:  # the lever of its weight: its centre of mass from the hinge line
        axis, anchor = data.xaxis[j], data.xanchor[j]
        r = data.xipos[body] - anchor
        lever = float(np.linalg.norm(r - axis * float(r @ axis)))
    else:
        lever = 1.0
    pace = max(upper, 1e-3) / 1.0  # its range in about a second
    most = PULL_WEIGHTS * mass * float(np.linalg.norm(model.opt.gravity)) * lever + float(model.dof_frictionloss[dof]) + float(model.dof_damping[dof]) * pace
    gain = 4.0 * most / pace
    root = int(model.body_rootid[body])
    # what a drawer holds (touching it as loaded) rides with it: not pushed out of its way
    load = _touching_roots(model, data, body, root) if not hinge else set()
    others = [f for f in free if int(model.body_rootid[model.jnt_bodyid[f]]) not in {root, *load}]
    start = {f: data.qpos[model.jnt_qposadr[f] : model.jnt_qposadr[f] + 3].copy() for f in others}
    weight = -model.opt.gravity * float(model.body_mass[body])  # its own weight cancelled
    fastest, steps, done_at = 0.0, int(PULL_SECONDS / model.opt.timestep), None
    for step in range(steps):
        # a hand's pull on the part alone (a force along a slide, a torque about a hinge): its
        # reaction is the hand's, so the carcass is not shoved back by the test itself
        onset = min(1.0, step * model.opt.timestep / ONSET_S)
        push = onset * float(np.clip(gain * (pace - data.qvel[dof]), -most, most))
        data.xfrc_applied[body, :3] = onset * weight + (0.0 if hinge else push) * data.xaxis[j]
        data.xfrc_applied[body, 3:] = (push if hinge else 0.0) * data.xaxis[j]
        mujoco.mj_step(model, data)
        fastest = max(fastest, float(np.max(np.linalg.norm(data.cvel[:, 3:], axis=1))))
        if done_at is None and data.qpos[q] >= needed:
            done_at = step
        if done_at is not None and step - done_at > int(0.1 / model.opt.timestep):
            break
    reached = float(data.qpos[q])
    pushed, pusher = 0.0, None
    for f in others:
        moved = float(np.linalg.norm(data.qpos[model.jnt_qposadr[f] : model.jnt_qposadr[f] + 3] - start[f]))
        if moved > pushed:
            pushed, pusher = moved, _root_name(model, int(model.jnt_bodyid[f]))
    passed = reached >= needed and pushed <= PUSHED_M and fastest <= FASTEST_M_S
    blocked_by = None
    if not passed:
        blocked_by = pusher if pushed > PUSHED_M else _touching(model, data, body, root)
    return PartPull(
        joint=model.joint(j).name, kind="hinge" if hinge else "slide", room_door=_is_leaf(model.joint(j).name),
        reached=reached, needed=needed, upper=upper, passed=passed, blocked_by=blocked_by, pushed_m=pushed,
        fastest_m_s=fastest,
    )  # fmt: skip


def _touching_roots(model: mujoco.MjModel, data: mujoco.MjData, body: int, root: int) -> set[int]:
    """The objects (root bodies) the part's body carries now: those it touches, its own excepted,
    and what rests on them in turn (a bowl on a box in a drawer)."""
    pairs = []
    for k in range(data.ncon):
        c = data.contact[k]
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        pairs.append((b1, b2))
    out: set[int] = set()
    reached, grew = {body}, True
    while grew:
        grew = False
        for b1, b2 in pairs:
            for here, there in ((b1, b2), (b2, b1)):
                other = int(model.body_rootid[there])
                if (here in reached or int(model.body_rootid[here]) in out) and other not in (root, 0) and other not in out:
                    out.add(other)
                    grew = True
    return out


def _touching(model: mujoco.MjModel, data: mujoco.MjData, body: int, root: int) -> str | None:
    """What the part's body presses on hardest at the end (an object by its id, a wall by its geom)."""
    best, name = 0.0, None
    force = np.zeros(6)
    for k in range(data.ncon):
        c = data.contact[k]
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        if body not in (b1, b2):
            continue
        other_geom, other = (c.geom2, b2) if b1 == body else (c.geom1, b1)
        if int(model.body_rootid[other]) == root:
            continue
        mujoco.mj_contactForce(model, data, k, force)
        if abs(force[0]) >= best:
            best = abs(force[0])
            name = model.geom(other_geom).name if other == 0 else _root_name(model, other)
    return name

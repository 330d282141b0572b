"""Articulation: the parts of a piece of furniture that open (drawers, doors, lids).

One data model, :class:`PartSpec`, describes a movable part of an object in the object's local
frame (Z up, metres, origin at the bottom centre of the footprint, front toward -Y): which of the
object's convex pieces move with it, the joint it turns or slides on (axis, a point on the axis,
limits, damping, friction) and the handle a gripper takes. Joint value ``0`` is the pose the
pieces are built in (closed, except a laptop's lid, see ``docs/articulation.md``); a positive
value opens the part: a drawer slides out along -Y, a door turns away from the carcass, a lid
lifts its front.

A procedural builder that draws a part also says how it moves (:func:`drawer`,
:func:`front_door`, :func:`lid`, which hold the geometric rules), so a category's articulation
lives with its builder. An imported mesh asset declares its parts with the same fields, the
pieces chosen by the box each part fills (:func:`pieces_in_box`). The simulators' exports (MJCF,
URDF, SDF) turn each part into a child body on a hinge or slide joint.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import numpy.typing as npt

__all__ = [
    "DOOR_OPEN_DEG",
    "DRAWER_TRAVEL_FRACTION",
    "LID_OPEN_DEG",
    "TOILET_LID_OPEN_DEG",
    "Box6",
    "HingeSide",
    "JointType",
    "PartKind",
    "PartSpec",
    "drawer",
    "front_door",
    "lid",
    "pieces_in_box",
]

FloatArray = npt.NDArray[np.float64]
Box6 = tuple[float, float, float, float, float, float]
"""An axis-aligned box in the object frame: ``(x0, x1, y0, y1, z_bottom, z_top)``."""
Vec3 = tuple[float, float, float]
PartKind = Literal["drawer", "door", "lid"]
JointType = Literal["slide", "hinge"]
HingeSide = Literal["-x", "+x"]
"""The edge a front door hangs on: its left (-X, seen from the front) or its right (+X)."""

DRAWER_TRAVEL_FRACTION = 0.9
"""How far a drawer slides out, as a fraction of its depth (front face to back panel): it stays
held by the last tenth, as on real runners."""
DOOR_OPEN_DEG = 110.0
"""How far a door turns from closed, degrees: past a right angle, as a kitchen cabinet's does."""
LID_OPEN_DEG = 100.0
"""How far a lid lifts from closed, degrees: just past upright, so it stays open on its own."""
TOILET_LID_OPEN_DEG = 95.0
"""How far a toilet's lid lifts, degrees: it leans back a little, toward the cistern."""

DRAWER_DAMPING_N_S_PER_M = 10.0
"""Viscous damping of a drawer's slide, N s/m (the grease of its runners)."""
DRAWER_FRICTION_N = 1.0
"""Dry friction of a drawer's slide, N: a drawer does not creep open when the chest is bumped."""
DOOR_DAMPING_N_M_S_PER_RAD_M = 5.0
"""Viscous damping of a door's hinge per metre of door width, N m s/rad per m."""
DOOR_FRICTION_N_M_PER_M = 0.5
"""Dry friction of a door's hinge per metre of width, N m per m (a catch keeps it shut)."""
LID_DAMPING_N_M_S_PER_RAD = 0.2
"""Viscous damping of a lid's hinge, N m s/rad."""
LID_FRICTION_N_M = 0.05
"""Dry friction of a lid's hinge, N m."""
JOINT_ARMATURE = 0.01
"""Rotor inertia added to every part joint (kg m^2 or kg): steadies the stepping of light parts."""


@dataclass(frozen=True)
class PartSpec:
    """One movable part of an object, in the object's local frame, in its built (closed) pose."""

    name: str
    """Unique within the object (``drawer_0``, ``door_1``, ``lid``); names the part's body, link
    and joint in every export (``<object id>/<name>``)."""
    kind: PartKind
    """What it is: ``drawer`` (slides out of the front), ``door`` (turns about an edge), ``lid``
    (turns about its back edge)."""
    joint: JointType
    """``slide`` (prismatic) for drawers, ``hinge`` (revolute) for doors and lids."""
    axis: Vec3
    """Unit vector in the object frame. A slide moves along it as the joint value grows; a hinge
    turns about it by the right-hand rule. Either way a positive value opens the part."""
    anchor: Vec3
    """A point of the object frame: on the hinge line for a hinge; for a slide the middle of the
    part's box. It is the origin of the part's own frame (axes parallel to the object's)."""
    limits: tuple[float, float]
    """Lower and upper joint value, metres (slide) or radians (hinge); ``0`` is the built pose."""
    damping: float
    """Viscous joint damping: N s/m (slide) or N m s/rad (hinge)."""
    friction: float
    """Dry joint friction (MuJoCo's ``frictionloss``): N (slide) or N m (hinge)."""
    pieces: tuple[int, ...]
    """Indices, into the object's list of convex pieces, of those that move with the part."""
    handle: int
    """Index of the piece a gripper takes (one of :attr:`pieces`)."""
    box: Box6
    """Bounds of the part's pieces in the built pose."""
    handle_box: Box6
    """Bounds of the handle piece in the built pose."""
    depth: float = 0.0
    """A drawer's depth, from its front face to the back of its box, metres (0 for the others)."""
    armature: float = JOINT_ARMATURE
    """Joint armature (added rotor inertia): kg (slide) or kg m^2 (hinge)."""

    @property
    def handle_centre(self) -> FloatArray:
        """Centre of the handle in the built pose, object frame."""
        x0, x1, y0, y1, z0, z1 = self.handle_box
        return np.array([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])

    def transform(self, value: float) -> FloatArray:
        """The 4x4 motion of the part's pieces, object frame, when its joint stands at ``value``
        (the identity at ``0``): a turn about the hinge line or a shift along the slide."""
        axis = np.asarray(self.axis, dtype=np.float64)
        out = np.eye(4)
        if self.joint == "slide":
            out[:3, 3] = axis * value
            return out
        k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
        rotation = np.eye(3) + math.sin(value) * k + (1.0 - math.cos(value)) * (k @ k)
        anchor = np.asarray(self.anchor, dtype=np.float64)
        out[:3, :3] = rotation
        out[:3, 3] = anchor - rotation @ anchor
        return out

    def shifted(self, offset: int) -> PartSpec:
        """The same part with its piece indices moved by ``offset`` (pieces listed after others)."""
        return replace(self, pieces=tuple(i + offset for i in self.pieces), handle=self.handle + offset)


def _bounds(boxes: Sequence[Box6]) -> Box6:
    a = np.array(boxes, dtype=np.float64)
    return (
        float(a[:, 0].min()),
        float(a[:, 1].max()),
        float(a[:, 2].min()),
        float(a[:, 3].max()),
        float(a[:, 4].min()),
        float(a[:, 5].max()),
    )


def drawer(name: str, pieces: Sequence[int], handle: int, boxes: Sequence[Box6]) -> PartSpec:
    """A drawer sliding out along -Y by :data:`DRAWER_TRAVEL_FRACTION` of its depth.

    ``boxes`` are the bounds of ``pieces`` in the same order (the handle's among them); the
    drawer's depth is the extent of their union along Y.
    """
    box = _bounds(boxes)
    depth = box[3] - box[2]
    return PartSpec(
        name=name,
        kind="drawer",
        joint="slide",
        axis=(0.0, -1.0, 0.0),
        anchor=((box[0] + box[1]) / 2, (box[2] + box[3]) / 2, (box[4] + box[5]) / 2),
        limits=(0.0, DRAWER_TRAVEL_FRACTION * depth),
        damping=DRAWER_DAMPING_N_S_PER_M,
        friction=DRAWER_FRICTION_N,
        pieces=tuple(pieces),
        handle=handle,
        box=box,
        handle_box=boxes[list(pieces).index(handle)],
        depth=depth,
    )


def front_door(
    name: str, pieces: Sequence[int], handle: int, boxes: Sequence[Box6], *, hinge: HingeSide
) -> PartSpec:
    """A door on the front (-Y) turning outward about a vertical line on its ``hinge`` side.

    The hinge line runs up the front face of the leaf (the door less its handle) at its edge on
    that side. Turning about the front edge keeps the whole door on its own side of the hinge line
    and in front of the carcass up to a right angle, so a neighbouring door hung hinge to hinge
    beside it (the middle pair of a row of four) is never struck. The axis is -Z for a door hung
    on its -X edge and +Z for one hung on its +X edge, so that a positive angle always opens it.
    """
    box = _bounds(boxes)
    leaf = _bounds([b for i, b in zip(pieces, boxes, strict=True) if i != handle] or list(boxes))
    x = leaf[0] if hinge == "-x" else leaf[1]
    width = leaf[1] - leaf[0]
    return PartSpec(
        name=name,
        kind="door",
        joint="hinge",
        axis=(0.0, 0.0, -1.0 if hinge == "-x" else 1.0),
        anchor=(x, leaf[2], leaf[4]),
        limits=(0.0, math.radians(DOOR_OPEN_DEG)),
        damping=DOOR_DAMPING_N_M_S_PER_RAD_M * width,
        friction=DOOR_FRICTION_N_M_PER_M * width,
        pieces=tuple(pieces),
        handle=handle,
        box=box,
        handle_box=boxes[list(pieces).index(handle)],
    )


def lid(
    name: str,
    pieces: Sequence[int],
    handle: int,
    boxes: Sequence[Box6],
    *,
    handle_box: Box6 | None = None,
    open_deg: float = LID_OPEN_DEG,
) -> PartSpec:
    """A lid turning up about its back (+Y) top edge, about -X, so a positive angle lifts its front.

    Turning about the top edge (not the bottom one) keeps the whole lid in front of the back plane
    up to upright, so it never reaches into a wall the object stands against. ``handle_box`` is
    where a gripper takes it (default: the handle piece's bounds), ``open_deg`` how far it lifts.
    """
    box = _bounds(boxes)
    return PartSpec(
        name=name,
        kind="lid",
        joint="hinge",
        axis=(-1.0, 0.0, 0.0),
        anchor=((box[0] + box[1]) / 2, box[3], box[5]),
        limits=(0.0, math.radians(open_deg)),
        damping=LID_DAMPING_N_M_S_PER_RAD,
        friction=LID_FRICTION_N_M,
        pieces=tuple(pieces),
        handle=handle,
        box=box,
        handle_box=handle_box if handle_box is not None else boxes[list(pieces).index(handle)],
    )


def pieces_in_box(
    bounds: Sequence[tuple[Sequence[float], Sequence[float]]], box: Box6, tol: float = 1e-3
) -> tuple[int, ...]:
    """Indices of the pieces whose bounds ``(lower, upper)`` lie inside ``box`` (grown by ``tol``
    metres): how a part declared by its box finds its pieces among a mesh asset's convex pieces."""
    lo = np.array([box[0], box[2], box[4]]) - tol
    hi = np.array([box[1], box[3], box[5]]) + tol
    return tuple(
        i
        for i, (lower, upper) in enumerate(bounds)
        if bool(np.all(np.asarray(lower) >= lo)) and bool(np.all(np.asarray(upper) <= hi))
    )

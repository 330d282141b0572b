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

import hashlib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, get_args

import numpy as np
import numpy.typing as npt

from scenemosaic.exceptions import AssetError

__all__ = [
    "DOOR_OPEN_DEG",
    "DRAWER_TRAVEL_FRACTION",
    "DROP_DOOR_OPEN_DEG",
    "LEVEL_AXIS_Z",
    "LID_OPEN_DEG",
    "OPEN_STATES",
    "ROOM_DOOR_OPEN_DEG",
    "TOILET_LID_OPEN_DEG",
    "USABLE_HINGE_RAD",
    "USABLE_SLIDE_SHARE",
    "Box6",
    "HingeSide",
    "JointType",
    "OpenState",
    "PartKind",
    "PartSpec",
    "declared_part",
    "declared_tolerance",
    "drawer",
    "drop_door",
    "front_door",
    "lid",
    "opening",
    "pieces_in_box",
    "usable_opening",
    "usable_value",
    "with_pieces",
]

FloatArray = npt.NDArray[np.float64]
Box6 = tuple[float, float, float, float, float, float]
"""An axis-aligned box in the object frame: ``(x0, x1, y0, y1, z_bottom, z_top)``."""
Vec3 = tuple[float, float, float]
PartKind = Literal["drawer", "door", "lid"]
JointType = Literal["slide", "hinge"]
HingeSide = Literal["-x", "+x"]
"""The edge a front door hangs on: its left (-X, seen from the front) or its right (+X)."""
OpenState = Literal["closed", "open", "random"]
"""The pose parts are delivered in: ``closed`` (every joint at 0), ``open`` (every joint at its
upper limit) or ``random`` (each joint somewhere in its range, drawn from the run seed)."""
OPEN_STATES: tuple[OpenState, ...] = get_args(OpenState)
"""Every :data:`OpenState`, ``closed`` first (the default)."""

DRAWER_TRAVEL_FRACTION = 0.9
"""How far a drawer slides out, as a fraction of its depth (front face to back panel): it stays
held by the last tenth, as on real runners."""
USABLE_HINGE_RAD = math.radians(90.0)
"""A hinged part is usable once it turns this far (or through its whole range, when shorter): a
person or a gripper reaches past a door or lid standing square to its frame."""
USABLE_SLIDE_SHARE = 0.8
"""A drawer is usable once it slides out this share of its travel."""


def usable_value(part: PartSpec) -> float:
    """The joint value at which ``part`` counts as open for use (:func:`usable_opening` of its joint
    and upper limit): what the repairs of what blocks a part (``physics.free_part_paths``) and
    clutter (``assets.swept_footprints``) ask of it."""
    return usable_opening(part.joint, part.limits[1])


def usable_opening(joint: str, upper: float) -> float:
    """The value at which a ``hinge`` or ``slide`` joint opening to ``upper`` counts as open for use:
    :data:`USABLE_HINGE_RAD` (or ``upper`` when smaller) for a hinge, :data:`USABLE_SLIDE_SHARE` of
    ``upper`` for a slide. The pull test (``physics.pull_parts``) reads joints from an MJCF with it."""
    return min(USABLE_HINGE_RAD, upper) if joint == "hinge" else USABLE_SLIDE_SHARE * upper


DOOR_OPEN_DEG = 110.0
"""How far a door turns from closed, degrees: past a right angle, as a kitchen cabinet's does."""
DROP_DOOR_OPEN_DEG = 90.0
"""How far a drop-down door (an oven's, a dishwasher's) falls open, degrees: to level, where its
stays hold it."""
LID_OPEN_DEG = 100.0
"""How far a lid lifts from closed, degrees: just past upright, so it stays open on its own."""
TOILET_LID_OPEN_DEG = 95.0
"""How far a toilet's lid lifts, degrees: it leans back a little, toward the cistern."""
ROOM_DOOR_OPEN_DEG = 100.0
"""How far a room's door (a leaf hung on a doorway) turns from shut, degrees: just past square to
the wall, so the open leaf stands beside the passage, not in it."""

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
LEVEL_AXIS_Z = 0.7
"""A hinge line with less than this upward share lies level: a lid's, a drop-down door's."""


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

    @property
    def level(self) -> bool:
        """Whether it turns about a hinge line lying level (a lid, a drop-down door): its weight
        turns it, so it rests only shut or against its stop (:data:`LEVEL_AXIS_Z`)."""
        return self.joint == "hinge" and abs(float(self.axis[2])) < LEVEL_AXIS_Z

    def clamped(self, value: float) -> float:
        """``value`` held within :attr:`limits` (a delivered pose never lies outside them)."""
        return min(max(float(value), self.limits[0]), self.limits[1])

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
    name: str,
    pieces: Sequence[int],
    handle: int,
    boxes: Sequence[Box6],
    *,
    hinge: HingeSide,
    open_deg: float = DOOR_OPEN_DEG,
) -> PartSpec:
    """A door on the front (-Y) turning outward about a vertical line on its ``hinge`` side, up
    to ``open_deg`` degrees (a room's door: :data:`ROOM_DOOR_OPEN_DEG`).

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
        limits=(0.0, math.radians(open_deg)),
        damping=DOOR_DAMPING_N_M_S_PER_RAD_M * width,
        friction=DOOR_FRICTION_N_M_PER_M * width,
        pieces=tuple(pieces),
        handle=handle,
        box=box,
        handle_box=boxes[list(pieces).index(handle)],
    )


def drop_door(name: str, pieces: Sequence[int], handle: int, boxes: Sequence[Box6]) -> PartSpec:
    """A door on the front (-Y) hinged along its bottom edge, falling open toward -Y to level.

    The hinge line runs along X at the bottom of the leaf's front face (the door less its handle),
    axis +X, so a positive angle tips the top of the door out and down. Turning about the front
    edge keeps the leaf in front of the carcass all the way to level; the leaf's weight lies behind
    the hinge line when shut, so it rests closed against its limit and falls open once pulled past
    upright. Damping and friction are a side-hung door's, per metre of width.
    """
    box = _bounds(boxes)
    leaf = _bounds([b for i, b in zip(pieces, boxes, strict=True) if i != handle] or list(boxes))
    width = leaf[1] - leaf[0]
    return PartSpec(
        name=name,
        kind="door",
        joint="hinge",
        axis=(1.0, 0.0, 0.0),
        anchor=((leaf[0] + leaf[1]) / 2, leaf[2], leaf[4]),
        limits=(0.0, math.radians(DROP_DOOR_OPEN_DEG)),
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


def opening(part: PartSpec, state: OpenState, *, seed: int = 0, key: str = "") -> float:
    """The joint value ``part`` is delivered at in ``state``: 0, its upper limit, or for ``random``
    a value drawn uniformly within its limits from ``seed``, ``key`` (the object's id) and the
    part's name; a part whose hinge line lies level (:attr:`PartSpec.level`: a lid) is drawn shut
    or at its limit, half and half, for its weight would swing it from anywhere between. The draw
    hashes those three (SHA-256), so it is the same in every process and does not depend on which
    other parts or objects a scene holds."""
    lower, upper = part.limits
    if state == "closed":
        return 0.0
    if state == "open":
        return upper
    digest = hashlib.sha256(f"{seed}\x00{key}\x00{part.name}".encode()).digest()
    fraction = int.from_bytes(digest[:8], "big") / 2.0**64
    if part.level:
        return upper if fraction >= 0.5 else lower
    return lower + fraction * (upper - lower)


def _box6(value: Any, what: str) -> Box6:
    if (
        not isinstance(value, Sequence)
        or len(value) != 6
        or not all(isinstance(v, int | float) for v in value)
    ):
        raise AssetError(f"{what} must be six numbers [x0, x1, y0, y1, z0, z1], not {value!r}")
    box = tuple(float(v) for v in value)
    if not all(math.isfinite(v) for v in box) or box[0] >= box[1] or box[2] >= box[3] or box[4] >= box[5]:
        raise AssetError(f"{what} must be finite and each lower bound below its upper one: {list(box)}")
    return box  # type: ignore[return-value]


def declared_part(record: Mapping[str, Any], scale: Sequence[float] = (1.0, 1.0, 1.0)) -> PartSpec:
    """The :class:`PartSpec` a mesh asset declares for one part, its coordinates multiplied by
    ``scale`` (the asset frame to the object's scaled frame), with no pieces yet: the simulator
    exports pick the asset's convex pieces that lie in its box (:func:`pieces_in_box`).

    ``record`` holds ``name``, ``kind`` (``drawer``, ``door`` or ``lid``), ``box`` (the part's
    bounds closed, ``[x0, x1, y0, y1, z0, z1]`` in the asset's canonical frame: Z up, front -Y,
    origin at the bottom centre of the footprint), optionally ``handle`` (the box a gripper takes;
    default: the middle of the part's front face, or of a lid's front edge), for a door ``hinge``
    (``-x``, ``+x`` or ``bottom``: a drop-down door; default ``-x``) and for a door or lid
    ``open_deg``. The rules are those of the procedural furniture: :func:`drawer`,
    :func:`front_door`, :func:`drop_door`, :func:`lid`. Raises
    :class:`~scenemosaic.exceptions.AssetError` naming what is wrong with ``record``.
    """
    name = record.get("name")
    if not isinstance(name, str) or not name or "/" in name:
        raise AssetError(f"a part needs a name without '/', not {name!r}")
    kind = record.get("kind")
    if kind not in ("drawer", "door", "lid"):
        raise AssetError(f"part {name!r}: kind must be drawer, door or lid, not {kind!r}")
    sx, sy, sz = (float(v) for v in scale)
    x0, x1, y0, y1, z0, z1 = _box6(record.get("box"), f"part {name!r}: box")
    box = (x0 * sx, x1 * sx, y0 * sy, y1 * sy, z0 * sz, z1 * sz)
    if record.get("handle") is not None:
        h0, h1, h2, h3, h4, h5 = _box6(record["handle"], f"part {name!r}: handle")
        grip = (h0 * sx, h1 * sx, h2 * sy, h3 * sy, h4 * sz, h5 * sz)
    else:  # the middle of the front face (a lid: of its front edge, on top)
        cx, cz, reach = (box[0] + box[1]) / 2, (box[4] + box[5]) / 2, 0.1 * (box[1] - box[0])
        thin = min(0.02, 0.5 * (box[3] - box[2]))
        if kind == "lid":
            grip = (
                cx - reach,
                cx + reach,
                box[2],
                box[2] + thin,
                box[5] - min(0.02, 0.5 * (box[5] - box[4])),
                box[5],
            )
        else:
            grip = (
                cx - reach,
                cx + reach,
                box[2],
                box[2] + thin,
                cz - 0.1 * (box[5] - box[4]),
                cz + 0.1 * (box[5] - box[4]),
            )
    boxes = [box, grip]
    open_deg = record.get("open_deg")
    if open_deg is not None and (not isinstance(open_deg, int | float) or not 0 < open_deg <= 180):
        raise AssetError(f"part {name!r}: open_deg must be a number of degrees in (0, 180], not {open_deg!r}")
    if kind == "drawer":
        spec = drawer(name, (0, 1), 1, boxes)
    elif kind == "lid":
        spec = lid(name, (0, 1), 1, boxes, handle_box=grip, open_deg=float(open_deg or LID_OPEN_DEG))
    else:
        hinge = record.get("hinge", "-x")
        if hinge not in ("-x", "+x", "bottom"):
            raise AssetError(f"part {name!r}: hinge must be -x, +x or bottom, not {hinge!r}")
        spec = (
            drop_door(name, (0, 1), 1, boxes)
            if hinge == "bottom"
            else front_door(name, (0, 1), 1, boxes, hinge=hinge)
        )
        if open_deg is not None:
            spec = replace(spec, limits=(0.0, math.radians(float(open_deg))))
    # the helpers took the part's box and the handle's as two pieces: the asset's own come later
    return replace(spec, pieces=(), handle=-1, handle_box=grip)


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


def declared_tolerance(size: Iterable[float]) -> float:
    """How far a convex piece (or a face) of a mesh asset may stand out of a declared part's box
    and still belong to it, metres: 2 % of the object's largest side, at least 5 mm. CoACD's
    pieces follow the surface only approximately."""
    return max(0.005, 0.02 * max(float(v) for v in size))


def with_pieces(
    parts: Sequence[PartSpec],
    bounds: Sequence[tuple[Sequence[float], Sequence[float]]],
    tol: float,
    owners: Sequence[str | None] | None = None,
) -> list[PartSpec]:
    """Declared parts (no ``pieces`` yet) given the object's convex pieces by their bounds: each
    part takes the pieces ``owners`` names it the owner of (the decomposition made them from its
    faces), else those inside its box (:func:`pieces_in_box`, grown by ``tol``) that no part
    before it took; its handle is the one nearest the middle of its handle box. A part that gets
    no piece is left out (the object stays rigid there); parts that have pieces are kept.
    """
    out: list[PartSpec] = []
    taken: set[int] = set()
    for part in parts:
        if part.pieces:
            out.append(part)
            taken.update(part.pieces)
            continue
        if owners is not None and part.name in owners:
            mine = tuple(i for i, owner in enumerate(owners) if owner == part.name)
        else:
            mine = tuple(i for i in pieces_in_box(bounds, part.box, tol) if i not in taken)
        if not mine:
            continue
        centres = [(np.asarray(bounds[i][0]) + np.asarray(bounds[i][1])) / 2 for i in mine]
        nearest = int(np.argmin([float(np.linalg.norm(c - part.handle_centre)) for c in centres]))
        out.append(replace(part, pieces=mine, handle=mine[nearest]))
        taken.update(mine)
    return out

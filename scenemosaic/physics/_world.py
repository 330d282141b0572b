"""MuJoCo worlds for units and whole scenes, built with ``MjSpec``.

Static parts (room slabs, the anchor, already-settled neighbours) go straight into the world
body; dynamic objects get their own body. Two joint layouts:

* ``"tilt"`` (unit settling): three world-axis slides plus two hinges about the in-plane axes,
  so an object can drop, slide and rock onto its support but never spins about the gravity axis
  (the layout's yaw is kept exactly). Ceiling units use ``"slide"`` (no hinges): a hanging
  lamp pushed against the ceiling by reversed gravity would otherwise balance on its cord.
* ``"free"`` (validation and export): a free joint, nothing locked.

Bodies of dynamic objects are placed at the object's origin (bottom centre of the footprint).
Every object body is named by the object's id, its collision geoms ``<id>_hull_<k>``. A builder
made with ``articulated=True`` (the whole-scene world of validation and the MJCF export) gives
each movable part of an object (``ObjectShape.articulation``: a drawer, a door, a lid) its own
child body ``<id>/<part>`` on a slide or hinge joint of the same name, with the part's limits,
damping, dry friction and armature, at the joint value :attr:`WorldBuilder.openings` gives it
(closed by default; an open part's joint ``ref`` is that value, so the model loads there); the
part's pieces keep their geom names. A contact
exclusion between the object's body and each part's (MuJoCo's parent filter alone would not hold
for an object welded to the world) makes a part meet its carcass only through its joint. The same
builder writes the MJCF export (:meth:`WorldBuilder.write_mjcf`), so the exported file is the
model that was simulated, not a second rendering of it.
"""

from __future__ import annotations

import functools
import hashlib
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import mujoco
import numpy as np
import numpy.typing as npt
import shapely
import trimesh

from scenemosaic._memo import Memo
from scenemosaic.physics._hulls import ObjectShape, hull_mesh
from scenemosaic.physics._settings import DEFAULT_DENSITY_KG_M3, ROOM_FRICTION, SimSettings
from scenemosaic.render import (
    WallPiece,
    category_color,
    house_wall_pieces,
    polygon_rectangles,
    wall_ends,
    wall_pieces,
)
from scenemosaic.scene import FloatArray, House, Room, SceneObject, Wall, write_atomic

__all__ = [
    "MJCF_MESH_DIR",
    "BuiltWorld",
    "DynamicBody",
    "JointMode",
    "ObjectInertial",
    "RoomSlab",
    "WorldBuilder",
    "house_slabs",
    "object_inertial",
    "object_mass",
    "part_inertials",
    "room_slabs",
]

MJCF_MESH_DIR = "mjcf"
"""Folder, beside ``scene.xml``, holding the exported meshes (relative, so the folder can move)."""

JointMode = Literal["tilt", "slide", "free"]

_SOLVERS = {
    "Newton": mujoco.mjtSolver.mjSOL_NEWTON,
    "CG": mujoco.mjtSolver.mjSOL_CG,
    "PGS": mujoco.mjtSolver.mjSOL_PGS,
}
_CONES = {"elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC, "pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL}
_INTEGRATORS = {
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
}


def object_mass(obj: SceneObject, shape: ObjectShape) -> float:
    """``mass_kg``, else density times hull volume, else the default density; clamped to [0.05, 500] kg."""
    if obj.sim.mass_kg is not None:
        return float(obj.sim.mass_kg)
    density = obj.sim.density_kg_m3 or DEFAULT_DENSITY_KG_M3
    volume = shape.volume if shape.volume > 0 else float(np.prod(shape.upper - shape.lower))
    return float(min(max(density * volume, 0.05), 500.0))


@dataclass(frozen=True)
class ObjectInertial:
    """Mass properties of an object as every simulated and exported model uses them.

    ``centre`` is the centre of mass in the object's local frame (the middle of its convex
    pieces' bounds); ``moments`` the principal moments about it, along the local axes, of a solid
    box of the pieces' bounds (kg m^2); ``diagonal`` the same moments raised to at least 1e-6, the
    inertia the models carry.
    """

    mass: float
    centre: FloatArray
    moments: FloatArray

    @property
    def diagonal(self) -> FloatArray:
        """The principal moments as written into a model: each at least 1e-6 kg m^2."""
        return np.maximum(self.moments, 1e-6)


def object_inertial(obj: SceneObject, shape: ObjectShape) -> ObjectInertial:
    """:func:`object_mass` with the centre and box inertia of the object's collision bounds."""
    return _box_inertial(object_mass(obj, shape), np.stack([shape.lower, shape.upper]))


MIN_PART_MASS_KG = 0.01
"""Least mass of a movable part (or carcass) in a simulated model, kg."""


def _box_inertial(mass: float, vertices: FloatArray) -> ObjectInertial:
    """``mass`` as a solid box over the bounds of ``vertices``: centre and principal moments."""
    lower, upper = vertices.min(axis=0), vertices.max(axis=0)
    size = upper - lower
    moments = (
        mass
        / 12.0
        * np.array([size[1] ** 2 + size[2] ** 2, size[0] ** 2 + size[2] ** 2, size[0] ** 2 + size[1] ** 2])
    )
    return ObjectInertial(mass=mass, centre=(lower + upper) / 2, moments=moments)


def part_inertials(obj: SceneObject, shape: ObjectShape) -> dict[str | None, ObjectInertial]:
    """Mass properties of an articulated object's fixed body (key ``None``: the pieces that do not
    move) and of each movable part (key: the part's name), in the object's local frame.

    The object's mass (:func:`object_mass`) is shared by the pieces' volumes (by their count when
    they have none), each share at least :data:`MIN_PART_MASS_KG`; each centre and box inertia
    are those of its pieces' bounds, as :func:`object_inertial` does for a whole object. The MJCF,
    URDF and SDF exports give these to the bodies and links of an articulated object.
    """
    total = object_mass(obj, shape)
    moving = shape.moving_pieces()
    groups: dict[str | None, list[int]] = {None: [i for i in range(len(shape.pieces)) if i not in moving]}
    for part in shape.articulation:
        groups[part.name] = list(part.pieces)
    volumes = np.array([p.volume for p in shape.pieces])
    whole = float(volumes.sum())
    out: dict[str | None, ObjectInertial] = {}
    for name, indices in groups.items():
        if not indices:
            continue
        share = float(volumes[indices].sum()) / whole if whole > 0 else len(indices) / len(shape.pieces)
        vertices = np.concatenate([shape.pieces[i].vertices for i in indices])
        out[name] = _box_inertial(max(total * share, MIN_PART_MASS_KG), vertices)
    return out


@dataclass(frozen=True)
class RoomSlab:
    """One static box of the simulated room (or house), in world coordinates."""

    name: str
    """Name of the MuJoCo geom. A room: ``floor``, ``ceiling``, ``wall_<wall id>`` for a wall
    that is one box, ``wall_<wall id>/<k>`` for the pieces of a wall cut around its openings. A
    house: ``floor`` (one for the whole house), ``<room id>/<wall id>[/<k>]`` and
    ``<room id>/ceiling[/<k>]``. Ids never hold a ``/``, so names never clash."""
    kind: Literal["floor", "wall", "ceiling"]
    part_id: str
    """``floor``, ``ceiling`` or the wall's id."""
    centre: FloatArray
    """Centre of the box, shape (3,)."""
    half_extents: FloatArray
    """Half sizes along the box's own axes, shape (3,)."""
    yaw: float
    """Rotation of the box about +Z, radians (0 for floor and ceiling)."""
    room_id: str | None = None
    """In a house: the id of the room scene the part belongs to (``None`` for the house's floor)."""
    piece: int | None = None
    """Which box of a part made of several (a wall cut around its openings, a ceiling over a
    non-rectangular floor); ``None`` when the part is one box."""

    @property
    def quaternion(self) -> tuple[float, float, float, float]:
        """The box's rotation as a unit quaternion (w, x, y, z)."""
        return (math.cos(self.yaw / 2), 0.0, 0.0, math.sin(self.yaw / 2))


SLAB_THICKNESS_M = 0.1
"""Thickness (metres) of the simulated floor and ceiling slabs (floor top at z = 0, ceiling
bottom at the ceiling height)."""
SLAB_MARGIN_M = 1.0
"""How far (metres) a room's floor and ceiling slabs (a house's floor slab) reach past the floor
polygons' bounds, so nothing falls off an edge."""


def _piece_slab(wall: Wall, box: WallPiece, **fields: object) -> RoomSlab:
    """The box of one wall piece, which stands outside the floor (``w`` from 0 to the thickness)."""
    mid = (
        np.asarray(wall.start, dtype=np.float64)
        + wall.direction * ((box.s0 + box.s1) / 2.0)
        + wall.outward_normal * ((box.w0 + box.w1) / 2.0)
    )
    return RoomSlab(
        kind="wall",
        part_id=wall.id,
        centre=np.array([mid[0], mid[1], (box.z0 + box.z1) / 2.0]),
        half_extents=np.array([(box.s1 - box.s0) / 2.0, (box.w1 - box.w0) / 2.0, (box.z1 - box.z0) / 2.0]),
        yaw=math.atan2(float(wall.direction[1]), float(wall.direction[0])),
        **fields,  # type: ignore[arg-type]
    )


def _flat_slab(
    kind: Literal["floor", "ceiling"], lo: FloatArray, hi: FloatArray, z: float, **fields: object
) -> RoomSlab:
    """A horizontal slab over the rectangle ``lo``-``hi``, :data:`SLAB_THICKNESS_M` thick, centred at height ``z``."""
    return RoomSlab(
        kind=kind,
        part_id=kind,
        centre=np.array([(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, z]),
        half_extents=np.array([(hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0, SLAB_THICKNESS_M / 2.0]),
        yaw=0.0,
        **fields,  # type: ignore[arg-type]
    )


def _wall_slabs(wall: Wall, pieces: list[WallPiece], prefix: str, room_id: str | None) -> list[RoomSlab]:
    if len(pieces) == 1:
        return [_piece_slab(wall, pieces[0], name=f"{prefix}{wall.id}", room_id=room_id)]
    return [
        _piece_slab(wall, box, name=f"{prefix}{wall.id}/{k}", room_id=room_id, piece=k)
        for k, box in enumerate(pieces)
    ]


def room_slabs(room: Room) -> list[RoomSlab]:
    """The room as simulated: a floor slab under z = 0 and a ceiling slab above the ceiling height,
    both covering the floor polygon's bounds plus :data:`SLAB_MARGIN_M` on every side, and the
    walls standing outside the floor polygon, as tall as each wall, reaching past each end as
    :func:`scenemosaic.render.wall_ends` says, with their doors, windows and open stretches cut
    out (:func:`scenemosaic.render.wall_panels`): a wall without openings is one box, a wall
    with openings the boxes around them. The MJCF, USD and URDF exports share these boxes.
    """
    pts = np.asarray(room.floor)
    lo, hi = pts.min(axis=0) - SLAB_MARGIN_M, pts.max(axis=0) + SLAB_MARGIN_M
    half = SLAB_THICKNESS_M / 2.0
    slabs = [
        _flat_slab("floor", lo, hi, -half, name="floor"),
        _flat_slab("ceiling", lo, hi, room.ceiling_height + half, name="ceiling"),
    ]
    for w in room.walls:
        slabs += _wall_slabs(w, wall_pieces(w, wall_ends(room, w)), "wall_", None)
    return slabs


def house_slabs(house: House) -> list[RoomSlab]:
    """The house as simulated: one floor slab under z = 0 over every room's floor polygon's bounds
    plus :data:`SLAB_MARGIN_M`; per room, its walls cut around their openings, each shared wall
    once and no wall on any room's floor (:func:`scenemosaic.render.house_wall_pieces`), and its
    ceiling over exactly its own floor (:func:`scenemosaic.render.polygon_rectangles`), so that a
    room's ceiling never reaches into its neighbour, whatever their heights. Names carry the room
    id (see :class:`RoomSlab`).
    """
    pts = np.concatenate([np.asarray(s.room.floor) for s in house.rooms if s.room is not None])
    lo, hi = pts.min(axis=0) - SLAB_MARGIN_M, pts.max(axis=0) + SLAB_MARGIN_M
    half = SLAB_THICKNESS_M / 2.0
    slabs = [_flat_slab("floor", lo, hi, -half, name="floor")]
    pieces = house_wall_pieces(house)
    for scene in house.rooms:
        room = scene.room
        if room is None:
            continue
        for w in room.walls:
            slabs += _wall_slabs(w, pieces[(scene.id, w.id)], f"{scene.id}/", scene.id)
        rects = polygon_rectangles(shapely.Polygon(room.floor))
        z = room.ceiling_height + half
        for k, (x0, y0, x1, y1) in enumerate(rects):
            piece = None if len(rects) == 1 else k
            name = f"{scene.id}/ceiling" if piece is None else f"{scene.id}/ceiling/{k}"
            slabs.append(
                _flat_slab(
                    "ceiling",
                    np.array([x0, y0]),
                    np.array([x1, y1]),
                    z,
                    name=name,
                    room_id=scene.id,
                    piece=piece,
                )
            )
    return slabs


def _quat_from_matrix(r: FloatArray) -> list[float]:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(r, dtype=np.float64).reshape(9))
    return [float(v) for v in q]


@dataclass
class DynamicBody:
    """A dynamic object in a built world."""

    object_id: str
    body_id: int
    joint_mode: JointMode
    dof_slice: slice
    qpos_slice: slice
    axis_aligned: bool
    """True when the body frame is world-aligned at build time (tilt/slide); geoms carry the object's rotation."""


@dataclass
class BuiltWorld:
    """A compiled world and where its dynamic objects live."""

    model: mujoco.MjModel
    data: mujoco.MjData
    bodies: list[DynamicBody] = field(default_factory=list)
    object_geoms: dict[str, list[int]] = field(default_factory=dict)



def _obj_text(vertex_text: str, faces_text: str | None) -> str:
    """A mesh of the compiled spec as OBJ text: a collision piece (no faces) as its convex hull,
    the solid MuJoCo makes of it; a visual mesh as it is."""
    verts = np.array(vertex_text.split(), dtype=np.float64).reshape(-1, 3)
    if faces_text is None:
        tm = hull_mesh(verts)
    else:
        faces = np.array(faces_text.split(), dtype=np.int64).reshape(-1, 3)
        tm = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    text = tm.export(file_type="obj")
    assert isinstance(text, str)  # trimesh writes OBJ as text
    return text


_OBJ_TEXTS: Memo[str, str] = Memo(8192)
"""OBJ files of written worlds by their spec text's hash: a house's variants share their furniture."""

class WorldBuilder:
    """Accumulates static and dynamic parts, then compiles one MuJoCo model."""

    def __init__(
        self,
        settings: SimSettings,
        gravity_dir: Sequence[float] | FloatArray = (0.0, 0.0, -1.0),
        *,
        articulated: bool = False,
    ) -> None:
        self.settings = settings
        self.articulated = articulated
        """Whether objects with movable parts get a child body per part on its joint (else one
        rigid body, the parts closed)."""
        self.openings: dict[str, dict[str, float]] = {}
        """Object id -> part name -> the joint value the part is placed at
        (:func:`scenemosaic.assets.part_openings`; a part not listed is closed)."""
        self._part_anchors: dict[str, dict[str, FloatArray]] = {}
        self._posed: set[str] = set()
        self.spec = mujoco.MjSpec()
        self.spec.modelname = "scenemosaic_unit"
        # inertias are always explicit (object_mass + box inertia), never derived from geoms
        self.spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        self.spec.compiler.degree = False  # hinge limits are radians (the written XML says so too)
        opt = self.spec.option
        opt.timestep = settings.timestep
        opt.solver = _SOLVERS[settings.solver]
        opt.iterations = settings.iterations
        opt.ls_iterations = settings.ls_iterations
        opt.cone = _CONES[settings.cone]
        opt.impratio = settings.impratio
        opt.integrator = _INTEGRATORS[settings.integrator]
        g = np.asarray(gravity_dir, dtype=np.float64)
        opt.gravity = (settings.gravity * g / max(float(np.linalg.norm(g)), 1e-12)).tolist()
        self.spec.compiler.autolimits = True
        self._meshes: dict[str, str] = {}
        self._dynamic: list[tuple[str, str, JointMode, bool]] = []
        self._geom_names: dict[str, list[str]] = {}
        self._dynamic_ids: set[str] = set()
        self._aligned: dict[str, bool] = {}
        self._count = 0

    # -- helpers ---------------------------------------------------------------------------
    def _name(self, prefix: str) -> str:
        self._count += 1
        return f"{prefix}_{self._count}"

    def _add_shape(
        self,
        body: mujoco.MjsBody,
        object_id: str,
        shape: ObjectShape,
        local_r: FloatArray,
        local_t: FloatArray,
        friction: float,
        rgba: Sequence[float] = (0.7, 0.7, 0.7, 1.0),
        indices: Sequence[int] | None = None,
    ) -> None:
        names = self._geom_names.setdefault(object_id, [])
        quat = _quat_from_matrix(local_r)
        for k in range(len(shape.pieces)) if indices is None else indices:
            piece = shape.pieces[k]
            name = f"{object_id}_hull_{k}"
            g = body.add_geom()
            g.name = name
            g.friction = [friction, 0.005, 0.0001]
            g.rgba = list(rgba)
            g.margin = self.settings.margin
            if piece.box is not None:
                centre, half = piece.box
                g.type = mujoco.mjtGeom.mjGEOM_BOX
                g.size = [float(v) for v in half]
                g.pos = (local_r @ centre + local_t).tolist()
            else:
                mesh_name = self._meshes.get(piece.key)
                if mesh_name is None:  # identical pieces share one mesh asset
                    mesh_name = self._meshes[piece.key] = name
                    self.spec.add_mesh(name=mesh_name, uservert=piece.vertices.reshape(-1).tolist())
                g.type = mujoco.mjtGeom.mjGEOM_MESH
                g.meshname = mesh_name
                g.pos = local_t.tolist()
            g.quat = quat
            g.group = 3
            names.append(name)

    # -- public ----------------------------------------------------------------------------
    def add_room(
        self, room: Room | None, *, floor: bool = True, walls: bool = True, ceiling: bool = True
    ) -> None:
        """Static room slabs (:func:`room_slabs`): a floor slab under z = 0, wall slabs outside
        each edge with their openings cut, a ceiling slab. No room: an infinite floor plane."""
        if room is None:
            if floor:
                g = self.spec.worldbody.add_geom()
                g.name = "floor"
                g.type = mujoco.mjtGeom.mjGEOM_PLANE
                g.size = [0.0, 0.0, 0.05]
            return
        wanted = {"floor": floor, "wall": walls, "ceiling": ceiling}
        self.add_slabs([slab for slab in room_slabs(room) if wanted[slab.kind]])

    def add_slabs(self, slabs: Sequence[RoomSlab]) -> None:
        """Static boxes welded to the world, each a geom named by its slab (ceilings in group 4)."""
        wb = self.spec.worldbody
        for slab in slabs:
            g = wb.add_geom()
            g.name = slab.name
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = [float(v) for v in slab.half_extents]
            g.pos = [float(v) for v in slab.centre]
            g.friction = [ROOM_FRICTION, 0.005, 0.0001]
            g.quat = list(slab.quaternion)
            if slab.kind == "ceiling":
                g.group = 4  # hidden in viewers by default: it would hide the scene from above

    def _opens(self, shape: ObjectShape) -> bool:
        return self.articulated and bool(shape.articulation)

    def _add_parts(
        self, body: mujoco.MjsBody, obj: SceneObject, shape: ObjectShape, rgba: Sequence[float]
    ) -> None:
        """Each movable part of ``obj`` as a child of ``body`` (whose frame is the object's): a body
        at the part's anchor on its slide or hinge joint, holding the part's pieces."""
        inertials = part_inertials(obj, shape)
        anchors = self._part_anchors.setdefault(obj.id, {})
        openings = self.openings.get(obj.id, {})
        for part in shape.articulation:
            anchor = np.asarray(part.anchor, dtype=np.float64)
            anchors[part.name] = anchor
            child = body.add_body()
            child.name = f"{obj.id}/{part.name}"
            child.pos = anchor.tolist()
            value = part.clamped(openings.get(part.name, 0.0))
            if value != 0.0:  # delivered open: the body at its open pose, the joint reading that value there
                motion = part.transform(value)
                child.pos = (motion[:3, :3] @ anchor + motion[:3, 3]).tolist()
                child.quat = _quat_from_matrix(motion[:3, :3])
            inertial = inertials[part.name]
            child.mass = inertial.mass
            child.explicitinertial = True
            child.ipos = (inertial.centre - anchor).tolist()
            child.inertia = inertial.diagonal.tolist()
            j = child.add_joint()
            j.name = f"{obj.id}/{part.name}"
            j.type = mujoco.mjtJoint.mjJNT_SLIDE if part.joint == "slide" else mujoco.mjtJoint.mjJNT_HINGE
            j.axis = list(part.axis)
            j.range = list(part.limits)
            if value != 0.0:
                j.ref = value  # qpos0: the model loads open, its range still 0 (closed) to open
            j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            j.damping = [part.damping, 0.0, 0.0]
            j.frictionloss = part.friction
            j.armature = part.armature
            self._add_shape(
                child, obj.id, shape, np.eye(3), -anchor, obj.sim.friction, rgba, indices=part.pieces
            )
            # MuJoCo never collides a body with its parent, unless the parent is welded to the world
            # (a held object): then only an explicit exclusion keeps the part off its own carcass
            exclude = self.spec.add_exclude()
            exclude.bodyname1 = obj.id
            exclude.bodyname2 = child.name

    def add_static(self, obj: SceneObject, shape: ObjectShape) -> None:
        """An object that never moves, at its current pose: a body welded to the world (no joint).
        Its movable parts, in an ``articulated`` world, still open on their joints."""
        m = obj.pose.matrix(with_scale=False)
        body = self.spec.worldbody.add_body()
        body.name = obj.id
        rgba = (0.5, 0.5, 0.6, 1)
        if not self._opens(shape):
            self._add_shape(body, obj.id, shape, m[:3, :3], m[:3, 3], obj.sim.friction, rgba)
            return
        body.pos = m[:3, 3].tolist()
        body.quat = list(obj.pose.quaternion)
        moving = shape.moving_pieces()
        fixed = [i for i in range(len(shape.pieces)) if i not in moving]
        self._add_shape(body, obj.id, shape, np.eye(3), np.zeros(3), obj.sim.friction, rgba, indices=fixed)
        self._add_parts(body, obj, shape, rgba)
        self._posed.add(obj.id)

    def part_names(self, object_id: str) -> list[str]:
        """The movable parts this builder gave ``object_id`` its own body for (``[]`` when rigid)."""
        return list(self._part_anchors.get(object_id, {}))

    def add_visual(
        self, obj: SceneObject, vertices: FloatArray, faces: npt.NDArray[np.int64], *, part: str | None = None
    ) -> None:
        """The object's visual mesh (local frame, already scaled) as a non-colliding, massless geom
        in the object's category colour. With ``part``, the mesh of that movable part (object
        frame, closed) on the part's body, named ``<id>_visual_<part>``."""
        name = f"{obj.id}_visual" if part is None else f"{obj.id}_visual_{part}"
        if obj.id not in self._geom_names:
            raise ValueError(f"add {obj.id!r} (static or dynamic) before its visual mesh")
        if part is not None and part not in self._part_anchors.get(obj.id, {}):
            raise ValueError(f"{obj.id!r} has no movable part {part!r} in this world")
        self.spec.add_mesh(
            name=name,
            uservert=np.asarray(vertices, dtype=np.float64).reshape(-1).tolist(),
            userface=np.asarray(faces, dtype=np.int64).reshape(-1).tolist(),
        )
        body = self.spec.body(obj.id if part is None else f"{obj.id}/{part}")
        m = obj.pose.matrix(with_scale=False)
        g = body.add_geom()
        g.name = name
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = name
        g.contype = 0
        g.conaffinity = 0
        g.group = 2
        g.mass = 0.0
        red, green, blue = category_color(obj.category)  # the GLB, USD, URDF and plan colour
        g.rgba = [red / 255.0, green / 255.0, blue / 255.0, 1.0]
        if part is not None:  # the part's body: the object's axes, its origin at the part's anchor
            local_r, local_t = np.eye(3), -self._part_anchors[obj.id][part]
        elif obj.id in self._posed:  # a body that carries the object's pose
            local_r, local_t = np.eye(3), np.zeros(3)
        elif obj.id not in self._dynamic_ids:  # static: a body at the origin, geoms in world coordinates
            local_r, local_t = m[:3, :3], m[:3, 3]
        elif self._aligned[obj.id]:  # tilt/slide: a world-aligned body at the object's origin
            local_r, local_t = m[:3, :3], np.zeros(3)
        else:  # free: the body carries the object's rotation
            local_r, local_t = np.eye(3), np.zeros(3)
        g.pos = local_t.tolist()
        g.quat = _quat_from_matrix(local_r)

    def add_dynamic(
        self,
        obj: SceneObject,
        shape: ObjectShape,
        *,
        mode: JointMode,
        tilt_axes: Sequence[FloatArray] = (),
    ) -> None:
        """A moving object with its mass, friction and the joints of ``mode``."""
        m = obj.pose.matrix(with_scale=False)
        inertial = object_inertial(obj, shape)
        mass = inertial.mass
        body = self.spec.worldbody.add_body()
        body.name = obj.id
        body.pos = m[:3, 3].tolist()
        body.mass = mass
        body.explicitinertial = True
        axis_aligned = mode != "free"
        if axis_aligned:
            # body frame = world axes; the object's rotation lives in the geoms and in the inertia
            r = m[:3, :3]
            body.ipos = (r @ inertial.centre).tolist()
            body.iquat = _quat_from_matrix(r)
            body.inertia = inertial.diagonal.tolist()
            self._add_shape(body, obj.id, shape, r, np.zeros(3), obj.sim.friction)
        elif self._opens(shape):
            body.quat = list(obj.pose.quaternion)
            fixed_part = part_inertials(obj, shape)[None]
            body.mass = fixed_part.mass
            body.ipos = fixed_part.centre.tolist()
            body.inertia = fixed_part.diagonal.tolist()
            moving = shape.moving_pieces()
            fixed = [i for i in range(len(shape.pieces)) if i not in moving]
            rgba = (0.7, 0.7, 0.7, 1.0)
            self._add_shape(body, obj.id, shape, np.eye(3), np.zeros(3), obj.sim.friction, rgba, indices=fixed)
            self._add_parts(body, obj, shape, rgba)
        else:
            body.quat = list(obj.pose.quaternion)
            body.ipos = inertial.centre.tolist()
            body.inertia = inertial.diagonal.tolist()
            self._add_shape(body, obj.id, shape, np.eye(3), np.zeros(3), obj.sim.friction)
        damping = self.settings.damping_per_kg * mass
        if mode == "free":
            j = body.add_freejoint()
            j.name = f"{obj.id}_free"
        else:
            for k, axis in enumerate(np.eye(3)):
                j = body.add_joint()
                j.name = f"s{k}_{obj.id}"
                j.type = mujoco.mjtJoint.mjJNT_SLIDE
                j.axis = axis.tolist()
                j.damping = [damping, 0.0, 0.0]
            if mode == "tilt":
                for k, axis in enumerate(tilt_axes):
                    j = body.add_joint()
                    j.name = f"h{k}_{obj.id}"
                    j.type = mujoco.mjtJoint.mjJNT_HINGE
                    j.axis = np.asarray(axis, dtype=np.float64).tolist()
                    j.damping = [self.settings.damping_per_kg * float(inertial.moments.mean()), 0.0, 0.0]
        self._dynamic.append((obj.id, body.name, mode, axis_aligned))
        self._dynamic_ids.add(obj.id)
        self._aligned[obj.id] = axis_aligned

    def write_mjcf(self, out_dir: Path, *, model_name: str) -> Path:
        """Write ``out_dir/scene.xml`` plus one OBJ per mesh under ``out_dir/mjcf/``; return the XML path.

        The XML is MuJoCo's own rendering of this builder's spec (so it is the simulated model);
        inline mesh vertices become relative OBJ files (collision pieces as their convex hulls, as
        MuJoCo uses them), so the folder can be moved and the XML stays readable.
        """
        self.spec.modelname = model_name
        light = self.spec.worldbody.add_light()
        light.pos = [0.0, 0.0, 5.0]
        light.dir = [0.0, 0.0, -1.0]
        light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        # to_xml compiles what it needs itself and gives the same text for a spec compiled or
        # not (the visual geoms' frames come from their meshes either way): compiling first only
        # cost time
        root = ET.fromstring(self.spec.to_xml())
        mesh_dir = out_dir / MJCF_MESH_DIR
        mesh_dir.mkdir(parents=True, exist_ok=True)
        compiler = root.find("compiler")
        if compiler is None:
            compiler = ET.SubElement(root, "compiler")
        compiler.set("meshdir", MJCF_MESH_DIR)
        for mesh in root.iter("mesh"):
            name = mesh.attrib["name"]
            vertex_text = mesh.attrib.pop("vertex")
            faces_text = mesh.attrib.pop("face", None)
            key = hashlib.sha1(f"{vertex_text}|{faces_text}".encode()).hexdigest()
            write_atomic(mesh_dir / f"{name}.obj", _OBJ_TEXTS.get(key, functools.partial(_obj_text, vertex_text, faces_text)))
            mesh.set("file", f"{name}.obj")
        ET.indent(root)
        path = out_dir / "scene.xml"
        write_atomic(path, ET.tostring(root, encoding="unicode") + "\n")
        return path

    def compile(self) -> BuiltWorld:
        """Compile the model, create its data and locate the dynamic bodies' dofs."""
        model = self.spec.compile()
        data = mujoco.MjData(model)
        bodies: list[DynamicBody] = []
        for oid, bname, mode, aligned in self._dynamic:
            bid = model.body(bname).id
            dof0 = int(model.body_dofadr[bid])
            ndof = int(model.body_dofnum[bid])
            jnt0 = int(model.body_jntadr[bid])
            q0 = int(model.jnt_qposadr[jnt0])
            nq = 7 if mode == "free" else ndof
            bodies.append(DynamicBody(oid, bid, mode, slice(dof0, dof0 + ndof), slice(q0, q0 + nq), aligned))
        geoms = {oid: [model.geom(n).id for n in names] for oid, names in self._geom_names.items()}
        mujoco.mj_forward(model, data)
        return BuiltWorld(model=model, data=data, bodies=bodies, object_geoms=geoms)

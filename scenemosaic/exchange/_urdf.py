"""URDF export: one single-link URDF per object and a ``scene.urdf`` holding them all.

Layout of the folder (every path inside the files is relative to the file that names it)::

    scene.urdf                      world link, the room, one link + joint per object
    urdf/<object id>.urdf           one link per object
    urdf/meshes/<id>_visual.obj     visual meshes (local frame, scaled)
    urdf/meshes/<id>_hull_<k>.obj   convex collision pieces that are not boxes

An object's link is its local frame (Z up, metres, origin at the bottom centre of its footprint,
front along local -Y). It carries the mass, centre of mass and box inertia of
:func:`scenemosaic.physics.object_inertial`, the visual mesh painted in the category colour, and
one ``<collision>`` per convex piece of :func:`scenemosaic.physics.object_shape` (a ``<box>`` for
a box piece, the piece's hull as an OBJ otherwise). URDF itself has no friction, so the object's
``sim.friction`` goes into the two extensions simulators read: PyBullet's
``<contact><lateral_friction>`` inside the link and Gazebo's ``<gazebo reference=...>`` with
``<mu1>``/``<mu2>``; other loaders ignore both.

Furniture that opens (``ObjectShape.articulation``: drawers, doors, lids) is more than one link:
the object's link holds what does not move, and each part is a link ``<id>/<part>`` whose frame
is the part's anchor (axes as the object's), on a ``prismatic`` (drawer) or ``revolute`` (door,
lid) joint of the same name, with the part's ``<limit>`` and ``<dynamics damping friction>``;
mass is shared as :func:`scenemosaic.physics.part_inertials` shares it. ``scene.sdf`` carries
the same links and joints in each object's model. The links stand closed (joint value 0); a part
the scene delivers open (:func:`scenemosaic.assets.part_openings`) gets ``<initial_position>`` in
``scene.sdf`` and a comment in the URDF, which has no place for it.

In ``scene.urdf`` a ``world`` link is the root; the room (:func:`scenemosaic.physics.room_slabs`,
the slabs the MJCF export simulates) is a link on a fixed joint with one box per slab (the ceiling
collides but has no visual, so viewers see into the room); each object
hangs from ``world`` by a joint whose origin is its pose (rotation as fixed-axis roll-pitch-yaw):
``floating`` for the objects the MJCF export gives a free joint, ``fixed`` for held ones
(``static``, hung from a wall or the ceiling). The XML is written with the standard library; no
extra is needed.

Beside it, ``scene.sdf`` is the same world as an SDFormat ``<world>``: one ``<model>`` per object,
placed by its ``<pose>``, ``<static>`` when held in place, and one static model for the room, all
naming the same mesh files under ``urdf/meshes/``. It is the file for simulators that do not
honour URDF's ``floating`` joint (PyBullet turns it into a fixed joint, Drake leaves the body at
the origin): ``pybullet.loadSDF("scene.sdf")`` gives one free body per movable object in one call.

:func:`export_urdf` of a house writes a whole house the same way: ``scene.urdf`` holds a ``floor`` link
(the house's one floor slab), one link per room named by its id (its walls cut around their
openings, each shared wall once, and its ceiling: :func:`scenemosaic.physics.house_slabs`), all
fixed to ``world``, and every object of every room; ``urdf/`` one file per object, as for a room.
"""

from __future__ import annotations

import hashlib
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from pathlib import Path
from types import MappingProxyType

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic._memo import Memo
from scenemosaic.assets import (
    HullCache,
    PartSpec,
    asset_fingerprint,
    object_mesh,
    object_part_meshes,
    part_openings,
)
from scenemosaic.physics import (
    ROOM_FRICTION,
    HullInput,
    ObjectInertial,
    ObjectShape,
    RoomSlab,
    house_slabs,
    is_fixed,
    object_inertial,
    object_shape,
    part_inertials,
    require_finite_poses,
    room_slabs,
)
from scenemosaic.render import CEILING_COLOR, FLOOR_COLOR, WALL_COLOR, category_color
from scenemosaic.scene import FloatArray, House, Scene, SceneObject, quat_to_matrix, write_atomic

__all__ = [
    "SDF_SCENE_FILE",
    "URDF_MESH_DIR",
    "URDF_OBJECT_DIR",
    "URDF_SCENE_FILE",
    "export_urdf",
    "rpy_from_matrix",
]

log = structlog.get_logger(__name__)

URDF_SCENE_FILE = "scene.urdf"
"""The whole-scene URDF :func:`export_urdf` writes in its folder."""
SDF_SCENE_FILE = "scene.sdf"
"""The whole scene as an SDFormat world, beside ``scene.urdf`` (``pybullet.loadSDF`` reads it)."""
SDF_VERSION = "1.7"
URDF_OBJECT_DIR = "urdf"
"""Folder, beside ``scene.urdf``, holding one URDF per object."""
URDF_MESH_DIR = "meshes"
"""Folder, inside :data:`URDF_OBJECT_DIR`, holding the OBJ meshes."""

_NO_ROOM_FLOOR_HALF = (50.0, 50.0, 0.05)
"""Half sizes of the floor slab used when the scene has no room (URDF has no infinite plane)."""


def _add_comment(parent: ET.Element, text: str) -> None:
    """Append an XML comment; ``--`` (allowed in ids, not in comments) is broken up."""
    while "--" in text:
        text = text.replace("--", "- -")
    parent.append(ET.Comment(f" {text.rstrip('-')} "))


def _num(value: float) -> str:
    return repr(float(value))


def _vec(values: Iterable[float]) -> str:
    return " ".join(_num(v) for v in values)


def rpy_from_matrix(r: FloatArray) -> tuple[float, float, float]:
    """URDF's roll, pitch, yaw of a rotation matrix: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Pitch comes from ``atan2`` (not ``asin``), so it stays accurate near ±90°; there, where
    roll and yaw turn about the same axis, roll is set to 0.
    """
    m = np.asarray(r, dtype=np.float64)
    cos_pitch = math.hypot(float(m[0, 0]), float(m[1, 0]))
    pitch = math.atan2(-float(m[2, 0]), cos_pitch)
    if cos_pitch > 1e-9:
        roll = math.atan2(float(m[2, 1]), float(m[2, 2]))
        yaw = math.atan2(float(m[1, 0]), float(m[0, 0]))
    else:  # gimbal lock
        roll = 0.0
        yaw = math.atan2(-float(m[0, 1]), float(m[1, 1]))
    return roll, pitch, yaw


def _origin(parent: ET.Element, xyz: Iterable[float], rpy: Iterable[float] = (0.0, 0.0, 0.0)) -> None:
    ET.SubElement(parent, "origin", xyz=_vec(xyz), rpy=_vec(rpy))


def _box_geometry(
    parent: ET.Element, tag: str, name: str, centre: Iterable[float], size: Iterable[float], yaw: float = 0.0
) -> ET.Element:
    element = ET.SubElement(parent, tag, name=name)
    _origin(element, centre, (0.0, 0.0, yaw))
    ET.SubElement(ET.SubElement(element, "geometry"), "box", size=_vec(size))
    return element


def _material(parent: ET.Element, name: str, rgb: tuple[int, int, int]) -> None:
    material = ET.SubElement(parent, "material", name=name)
    ET.SubElement(material, "color", rgba=_vec([rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0, 1.0]))


def _friction(link: ET.Element, friction: float) -> None:
    contact = ET.SubElement(link, "contact")
    ET.SubElement(contact, "lateral_friction", value=_num(friction))


def _gazebo(robot: ET.Element, link_name: str, friction: float) -> None:
    gazebo = ET.SubElement(robot, "gazebo", reference=link_name)
    ET.SubElement(gazebo, "mu1").text = _num(friction)
    ET.SubElement(gazebo, "mu2").text = _num(friction)


def _sdf_pose(parent: ET.Element, xyz: Iterable[float], rpy: Iterable[float] = (0.0, 0.0, 0.0)) -> None:
    """SDFormat's ``<pose>x y z roll pitch yaw</pose>`` (the same fixed-axis angles as URDF's ``rpy``)."""
    ET.SubElement(parent, "pose").text = _vec([*xyz, *rpy])


def _sdf_material(parent: ET.Element, rgb: tuple[int, int, int]) -> None:
    material = ET.SubElement(parent, "material")
    colour = _vec([rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0, 1.0])
    for tag in ("ambient", "diffuse"):
        ET.SubElement(material, tag).text = colour


def _sdf_shape(
    link: ET.Element,
    tag: str,
    name: str,
    *,
    mesh: str | None = None,
    box: tuple[Iterable[float], Iterable[float], float] | None = None,
    friction: float | None = None,
    offset: FloatArray | None = None,
) -> ET.Element:
    """A ``<visual>`` or ``<collision>``: a mesh file (moved by ``offset`` when given), or a box
    ``(centre, size, yaw)``; a collision carries the friction coefficient in SDFormat's
    ``<surface><friction><ode>``."""
    element = ET.SubElement(link, tag, name=name)
    geometry = ET.Element("geometry")
    if box is not None:
        centre, size, yaw = box
        _sdf_pose(element, centre, (0.0, 0.0, yaw))
        ET.SubElement(ET.SubElement(geometry, "box"), "size").text = _vec(size)
    else:
        assert mesh is not None
        if offset is not None:
            _sdf_pose(element, offset)
        ET.SubElement(ET.SubElement(geometry, "mesh"), "uri").text = mesh
    element.append(geometry)
    if friction is not None:
        ode = ET.SubElement(ET.SubElement(ET.SubElement(element, "surface"), "friction"), "ode")
        ET.SubElement(ode, "mu").text = _num(friction)
        ET.SubElement(ode, "mu2").text = _num(friction)
    return element


def _sdf_inertial(link: ET.Element, centre: Iterable[float], mass: float, diagonal: Iterable[float]) -> None:
    inertial = ET.SubElement(link, "inertial")
    _sdf_pose(inertial, centre)
    ET.SubElement(inertial, "mass").text = _num(mass)
    inertia = ET.SubElement(inertial, "inertia")
    for axis, value in zip(("ixx", "iyy", "izz"), diagonal, strict=True):
        ET.SubElement(inertia, axis).text = _num(value)
    for axis in ("ixy", "ixz", "iyz"):
        ET.SubElement(inertia, axis).text = "0"


def _sdf_model(world: ET.Element, name: str, *, static: bool) -> tuple[ET.Element, ET.Element]:
    """A ``<model>`` of one link, both called ``name``, appended to ``world``; returns (model, link)."""
    model = ET.SubElement(world, "model", name=name)
    ET.SubElement(model, "static").text = "1" if static else "0"
    return model, ET.Element("link", name=name)


_CLOSED: Mapping[str, float] = MappingProxyType({})
"""No part open: the openings of an object delivered closed."""

PART_JOINT_EFFORT = 100.0
"""``<limit effort>`` of a part's joint (N or N m): what an actuator on it may exert, far above
the few newtons that open a drawer, so no simulator holds a part shut by it."""
PART_JOINT_VELOCITY = 5.0
"""``<limit velocity>`` of a part's joint (m/s or rad/s)."""


def _part_joint(robot: ET.Element, obj: SceneObject, part: PartSpec, parent: str, value: float = 0.0) -> None:
    """URDF's ``prismatic`` or ``revolute`` joint of a movable part (its child link ``<id>/<part>``).
    URDF has no initial joint position: a part delivered open (``value``) says so in a comment;
    ``scene.sdf``'s ``<initial_position>`` and the sceneState carry the value."""
    name = f"{obj.id}/{part.name}"
    if value != 0.0:
        _add_comment(robot, f"{name} is delivered at {_num(value)} (scene.sdf initial_position)")
    joint = ET.SubElement(robot, "joint", name=name, type="prismatic" if part.joint == "slide" else "revolute")
    _origin(joint, part.anchor)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=name)
    ET.SubElement(joint, "axis", xyz=_vec(part.axis))
    ET.SubElement(
        joint,
        "limit",
        lower=_num(part.limits[0]),
        upper=_num(part.limits[1]),
        effort=_num(PART_JOINT_EFFORT),
        velocity=_num(PART_JOINT_VELOCITY),
    )
    ET.SubElement(joint, "dynamics", damping=_num(part.damping), friction=_num(part.friction))


def _sdf_part_joint(model: ET.Element, obj: SceneObject, part: PartSpec, value: float = 0.0) -> None:
    """SDFormat's ``revolute`` or ``prismatic`` joint of a movable part: at the child link's frame
    (the part's anchor, axes as the model's), so its axis reads the same in every frame. The link
    is posed closed (joint value 0); a part delivered open (``value``) gets ``<initial_position>``."""
    name = f"{obj.id}/{part.name}"
    joint = ET.SubElement(model, "joint", name=name, type="prismatic" if part.joint == "slide" else "revolute")
    ET.SubElement(joint, "parent").text = obj.id
    ET.SubElement(joint, "child").text = name
    axis = ET.SubElement(joint, "axis")
    if value != 0.0:
        ET.SubElement(axis, "initial_position").text = _num(value)
    ET.SubElement(axis, "xyz").text = _vec(part.axis)
    limit = ET.SubElement(axis, "limit")
    ET.SubElement(limit, "lower").text = _num(part.limits[0])
    ET.SubElement(limit, "upper").text = _num(part.limits[1])
    ET.SubElement(limit, "effort").text = _num(PART_JOINT_EFFORT)
    ET.SubElement(limit, "velocity").text = _num(PART_JOINT_VELOCITY)
    dynamics = ET.SubElement(axis, "dynamics")
    ET.SubElement(dynamics, "damping").text = _num(part.damping)
    ET.SubElement(dynamics, "friction").text = _num(part.friction)


def _moved(point: FloatArray, part: PartSpec | None) -> FloatArray:
    """A point of the object frame in the frame of ``part``'s link (its anchor; unchanged for the
    object's own link, so a rigid object's files stay as they were)."""
    return point if part is None else point - np.asarray(part.anchor, dtype=np.float64)


class _ObjectFiles:
    """The meshes of one object, written once and named from the per-object and the scene files.

    An object with movable parts has one visual file per link (``<id>_visual.obj`` for what does
    not move, ``<id>_visual_<part>.obj`` per part), each in the object frame, closed.
    """

    def __init__(self, obj: SceneObject, shape: ObjectShape, base_dir: Path | None, mesh_dir: Path) -> None:
        self.obj = obj
        self.shape = shape
        self.visual: str | None = None
        self.part_visuals: dict[str, str] = {}
        try:
            texts = _visual_texts(obj, shape, base_dir)
        except Exception as exc:  # the visual is optional: the collision pieces still describe the object
            log.warning("urdf_visual_mesh_failed", object_id=obj.id, error=str(exc))
        else:
            for part, text in texts:
                file_name = f"{obj.id}_visual.obj" if part is None else f"{obj.id}_visual_{part}.obj"
                write_atomic(mesh_dir / file_name, text)
                if part is None:
                    self.visual = file_name
                else:
                    self.part_visuals[part] = file_name
        self.hulls: list[str | None] = []
        for k, piece in enumerate(shape.pieces):
            if piece.box is not None:
                self.hulls.append(None)
                continue
            file_name = f"{obj.id}_hull_{k}.obj"
            _write_obj(piece.mesh(), mesh_dir / file_name)
            self.hulls.append(file_name)

    def _inertials(self) -> dict[str | None, ObjectInertial]:
        if not self.shape.articulation:
            return {None: object_inertial(self.obj, self.shape)}
        return part_inertials(self.obj, self.shape)

    def _indices(self, part: PartSpec | None) -> list[int]:
        if part is not None:
            return list(part.pieces)
        moving = self.shape.moving_pieces()
        return [k for k in range(len(self.shape.pieces)) if k not in moving]

    def links(self, mesh_prefix: str) -> list[ET.Element]:
        """The object's ``<link>`` elements, its mesh files named as ``<mesh_prefix><file>``: the
        object's own, then one per movable part (its frame at the part's anchor)."""
        inertials = self._inertials()
        out = [self._link(self.obj.id, None, inertials[None], mesh_prefix)]
        for part in self.shape.articulation:
            out.append(self._link(f"{self.obj.id}/{part.name}", part, inertials[part.name], mesh_prefix))
        return out

    def _link(self, name: str, part: PartSpec | None, inertial: ObjectInertial, mesh_prefix: str) -> ET.Element:
        obj = self.obj
        offset = np.zeros(3) if part is None else -np.asarray(part.anchor, dtype=np.float64)
        link = ET.Element("link", name=name)
        inertial_el = ET.SubElement(link, "inertial")
        _origin(inertial_el, _moved(inertial.centre, part))
        ET.SubElement(inertial_el, "mass", value=_num(inertial.mass))
        ixx, iyy, izz = inertial.diagonal
        ET.SubElement(
            inertial_el, "inertia", ixx=_num(ixx), ixy="0", ixz="0", iyy=_num(iyy), iyz="0", izz=_num(izz)
        )
        visual_file = self.visual if part is None else self.part_visuals.get(part.name)
        if visual_file is not None:
            visual = ET.SubElement(link, "visual", name=f"{obj.id}_visual" if part is None else f"{name}_visual")
            _origin(visual, offset)
            ET.SubElement(ET.SubElement(visual, "geometry"), "mesh", filename=mesh_prefix + visual_file)
            _material(visual, f"category_{obj.category}", category_color(obj.category))
        for k in self._indices(part):
            piece, file_name = self.shape.pieces[k], self.hulls[k]
            hull_name = f"{obj.id}_hull_{k}"
            if piece.box is not None:
                centre, half = piece.box
                _box_geometry(link, "collision", hull_name, _moved(centre, part), 2.0 * half)
            else:
                assert file_name is not None
                collision = ET.SubElement(link, "collision", name=hull_name)
                _origin(collision, offset)
                ET.SubElement(ET.SubElement(collision, "geometry"), "mesh", filename=mesh_prefix + file_name)
        _friction(link, obj.sim.friction)
        return link

    def joints(self, robot: ET.Element, openings: Mapping[str, float] = _CLOSED) -> None:
        """The joint of each movable part, appended to ``robot`` (after the links); ``openings``:
        part name -> the joint value it is delivered at (absent: closed)."""
        for part in self.shape.articulation:
            _part_joint(robot, self.obj, part, self.obj.id, part.clamped(openings.get(part.name, 0.0)))

    def sdf_model(
        self, world: ET.Element, mesh_prefix: str, *, movable: bool, openings: Mapping[str, float] = _CLOSED
    ) -> None:
        """The object as an SDFormat ``<model>`` placed at its pose (``<static>`` when held in place;
        a held model's parts still move on their joints, PyBullet holding its base link only);
        ``openings`` as for :meth:`joints`."""
        obj = self.obj
        inertials = self._inertials()
        model, link = _sdf_model(world, obj.id, static=not movable)
        _sdf_pose(model, obj.pose.position, rpy_from_matrix(quat_to_matrix(obj.pose.quaternion)))
        self._sdf_link(link, None, inertials[None], mesh_prefix)
        model.append(link)
        for part in self.shape.articulation:
            name = f"{obj.id}/{part.name}"
            part_link = ET.SubElement(model, "link", name=name)
            _sdf_pose(part_link, part.anchor)
            self._sdf_link(part_link, part, inertials[part.name], mesh_prefix)
        for part in self.shape.articulation:
            _sdf_part_joint(model, obj, part, part.clamped(openings.get(part.name, 0.0)))

    def _sdf_link(
        self, link: ET.Element, part: PartSpec | None, inertial: ObjectInertial, mesh_prefix: str
    ) -> None:
        obj = self.obj
        offset = None if part is None else -np.asarray(part.anchor, dtype=np.float64)
        _sdf_inertial(link, _moved(inertial.centre, part), inertial.mass, inertial.diagonal)
        visual_file = self.visual if part is None else self.part_visuals.get(part.name)
        if visual_file is not None:
            name = f"{obj.id}_visual" if part is None else f"{obj.id}/{part.name}_visual"
            visual = _sdf_shape(link, "visual", name, mesh=mesh_prefix + visual_file, offset=offset)
            _sdf_material(visual, category_color(obj.category))
        for k in self._indices(part):
            piece, file_name = self.shape.pieces[k], self.hulls[k]
            name = f"{obj.id}_hull_{k}"
            if piece.box is not None:
                centre, half = piece.box
                box = (_moved(centre, part), 2.0 * half, 0.0)
                _sdf_shape(link, "collision", name, box=box, friction=obj.sim.friction)
            else:
                assert file_name is not None
                _sdf_shape(
                    link, "collision", name, mesh=mesh_prefix + file_name, friction=obj.sim.friction, offset=offset
                )


def _write_obj(mesh: trimesh.Trimesh, path: Path) -> None:
    """Geometry only (no material file), so every file stands alone and equal meshes give equal bytes."""
    write_atomic(path, _mesh_text(mesh))


def _mesh_text(mesh: trimesh.Trimesh) -> str:
    """The OBJ text :func:`_write_obj` writes for ``mesh``."""
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    key = hashlib.sha1(vertices.tobytes() + b"|" + faces.tobytes()).hexdigest()
    return _OBJ_TEXTS.get(key, lambda: _obj_text(vertices, faces))


def _visual_texts(obj: SceneObject, shape: ObjectShape, base_dir: Path | None) -> tuple[tuple[str | None, str], ...]:
    """The OBJ texts of ``obj``'s visual meshes, ``(part name or None for what does not move,
    text)``: split by its movable parts when it has some. Made once per process for each asset
    (:func:`~scenemosaic.assets.asset_fingerprint`): a house's variants share their furniture."""

    def make() -> tuple[tuple[str | None, str], ...]:
        visuals = object_part_meshes(obj, base_dir) if shape.articulation else {None: object_mesh(obj, base_dir)}
        return tuple(
            (part, _mesh_text(trimesh.Trimesh(vertices=v.vertices, faces=v.faces, process=False)))
            for part, v in visuals.items()
        )

    return _VISUAL_TEXTS.get((asset_fingerprint(obj, base_dir), bool(shape.articulation)), make)


_VISUAL_TEXTS: Memo[tuple[str, bool], tuple[tuple[str | None, str], ...]] = Memo(4096)
"""Visual OBJ texts by asset fingerprint (:func:`_visual_texts`)."""


def _obj_text(vertices: FloatArray, faces: npt.NDArray[np.int64]) -> str:
    plain = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    text = plain.export(file_type="obj", include_normals=False, include_texture=False)
    assert isinstance(text, str)  # trimesh returns OBJ as text
    return text


_OBJ_TEXTS: Memo[str, str] = Memo(8192)
"""OBJ files by their vertices' and faces' hash: a house's variants share their furniture."""


def _write_xml(robot: ET.Element, path: Path) -> None:
    ET.indent(robot)
    write_atomic(path, '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n")


def _free_name(candidate: str, taken: set[str]) -> str:
    name, n = candidate, 2
    while name in taken:
        name, n = f"{candidate}_{n}", n + 1
    taken.add(name)
    return name


def _slab_link(name: str, slabs: list[tuple[str, str, FloatArray, FloatArray, float]]) -> ET.Element:
    """A link of static boxes ``(name, kind, centre, half extents, yaw)``: each a collision, and a
    visual too except the ceiling's (so viewers see in from above)."""
    link = ET.Element("link", name=name)
    colors = {"floor": FLOOR_COLOR, "wall": WALL_COLOR, "ceiling": CEILING_COLOR}
    for slab_name, kind, centre, half, yaw in slabs:
        if kind != "ceiling":
            visual = _box_geometry(link, "visual", slab_name, centre, 2.0 * half, yaw)
            _material(visual, f"room_{kind}", colors[kind])
        _box_geometry(link, "collision", slab_name, centre, 2.0 * half, yaw)
    _friction(link, ROOM_FRICTION)
    return link


def _sdf_slab_model(
    world: ET.Element, name: str, slabs: list[tuple[str, str, FloatArray, FloatArray, float]]
) -> None:
    """The static boxes of :func:`_slab_link` as one static SDFormat model."""
    model, link = _sdf_model(world, name, static=True)
    _sdf_inertial(link, (0.0, 0.0, 0.0), 1.0, (1.0, 1.0, 1.0))  # unused (static); PyBullet warns without one
    colors = {"floor": FLOOR_COLOR, "wall": WALL_COLOR, "ceiling": CEILING_COLOR}
    for slab_name, kind, centre, half, yaw in slabs:
        box = (centre, 2.0 * half, yaw)
        if kind != "ceiling":
            _sdf_material(_sdf_shape(link, "visual", slab_name, box=box), colors[kind])
        _sdf_shape(link, "collision", slab_name, box=box, friction=ROOM_FRICTION)
    model.append(link)


def _boxes(slabs: list[RoomSlab]) -> list[tuple[str, str, FloatArray, FloatArray, float]]:
    return [(s.name, s.kind, s.centre, s.half_extents, s.yaw) for s in slabs]


def _room_boxes(scene: Scene) -> list[tuple[str, str, FloatArray, FloatArray, float]]:
    if scene.room is None:
        half = np.array(_NO_ROOM_FLOOR_HALF)
        return [("floor", "floor", np.array([0.0, 0.0, -half[2]]), half, 0.0)]
    return _boxes(room_slabs(scene.room))


def _joint(robot: ET.Element, name: str, kind: str, parent: str, child: str, obj: SceneObject | None) -> None:
    joint = ET.SubElement(robot, "joint", name=name, type=kind)
    if obj is None:
        _origin(joint, (0.0, 0.0, 0.0))
    else:
        _origin(joint, obj.pose.position, rpy_from_matrix(quat_to_matrix(obj.pose.quaternion)))
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)


class _UrdfWriter:
    """The folder being written: ``scene.urdf``'s root, and one file per object under ``urdf/``."""

    def __init__(self, folder: str | Path, name: str, taken: set[str], comment: str) -> None:
        self.out = Path(folder)
        self.object_dir = self.out / URDF_OBJECT_DIR
        self.mesh_dir = self.object_dir / URDF_MESH_DIR
        self.mesh_dir.mkdir(parents=True, exist_ok=True)
        self.taken = taken
        self.world = _free_name("world", taken)
        self.robot = ET.Element("robot", name=name)
        _add_comment(self.robot, f"{comment}: Z up, metres, kilograms; root link {self.world}")
        ET.SubElement(self.robot, "link", name=self.world)
        self.sdf = ET.Element("sdf", version=SDF_VERSION)
        _add_comment(
            self.sdf,
            f"{comment}: Z up, metres, kilograms; one model per object, static models are held in place",
        )
        self.sdf_world = ET.SubElement(self.sdf, "world", name=name)

    def fixed(self, name: str, slabs: list[tuple[str, str, FloatArray, FloatArray, float]]) -> None:
        """A static link of ``slabs`` on a fixed joint to the world, and the same boxes as a static
        model of ``scene.sdf``."""
        self.robot.append(_slab_link(name, slabs))
        _joint(self.robot, f"{name}_joint", "fixed", self.world, name, None)
        _gazebo(self.robot, name, ROOM_FRICTION)
        _sdf_slab_model(self.sdf_world, name, slabs)

    def objects(self, scene: Scene, shapes: dict[str, ObjectShape], base: Path | None) -> None:
        """Every object of ``scene``: its own ``urdf/<id>.urdf`` and its link and joint here."""
        openings = part_openings(scene)
        for obj in scene.objects:
            opened = openings.get(obj.id, _CLOSED)
            files = _ObjectFiles(obj, shapes[obj.id], base, self.mesh_dir)
            movable = not is_fixed(scene, obj)
            single = ET.Element("robot", name=obj.id)
            held = "movable (a free body)" if movable else "held in place: load it with a fixed base"
            _add_comment(single, f"scenemosaic object {obj.id} ({obj.category}), {held}")
            single.extend(files.links(f"{URDF_MESH_DIR}/"))
            files.joints(single, opened)
            _gazebo(single, obj.id, obj.sim.friction)
            _write_xml(single, self.object_dir / f"{obj.id}.urdf")

            self.robot.extend(files.links(f"{URDF_OBJECT_DIR}/{URDF_MESH_DIR}/"))
            _joint(self.robot, f"{obj.id}_joint", "floating" if movable else "fixed", self.world, obj.id, obj)
            files.joints(self.robot, opened)
            _gazebo(self.robot, obj.id, obj.sim.friction)
            files.sdf_model(self.sdf_world, f"{URDF_OBJECT_DIR}/{URDF_MESH_DIR}/", movable=movable, openings=opened)

    def save(self, count: int) -> Path:
        path = self.out / URDF_SCENE_FILE
        _write_xml(self.robot, path)
        _write_xml(self.sdf, self.out / SDF_SCENE_FILE)
        log.info("urdf_exported", path=str(path), objects=count)
        return path


def export_urdf(
    scene: Scene | House,
    folder: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
) -> Path:
    """Write ``folder/scene.urdf``, ``folder/urdf/<id>.urdf`` and their meshes; return ``scene.urdf``.

    See the module docstring for the contents. ``base_dir`` resolves relative mesh uris;
    ``hull_cache`` and ``hulls`` are passed to :func:`scenemosaic.physics.object_shape`, as the
    MJCF export does. Paths in the files are relative, so the folder can be moved; equal scenes
    give equal bytes.

    Raises:
        PhysicsError: an object's pose is not finite (nothing is written).
    """
    if isinstance(scene, House):  # a whole house: every room in one world
        return _export_house_urdf(scene, folder, base_dir, hull_cache=hull_cache, hulls=hulls)
    require_finite_poses(scene, "export URDF")
    base = Path(base_dir) if base_dir is not None else None
    shapes = {o.id: object_shape(o, base, cache=hull_cache, hulls=hulls) for o in scene.objects}
    writer = _UrdfWriter(folder, scene.id, {o.id for o in scene.objects}, f"scenemosaic scene {scene.id}")
    writer.fixed(_free_name("room", writer.taken), _room_boxes(scene))
    writer.objects(scene, shapes, base)
    return writer.save(len(scene.objects))


def _export_house_urdf(
    house: House,
    folder: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
) -> Path:
    """Write a whole house as ``folder/scene.urdf`` plus ``folder/urdf/<id>.urdf`` per object; return
    ``scene.urdf``.

    As :func:`export_urdf`, with the house's static boxes (:func:`scenemosaic.physics.house_slabs`,
    those its MJCF simulates) on fixed links: ``floor`` (the one floor slab) and one link per room,
    named by the room's id (its walls and ceiling; a name an object already has gets ``_2``...).
    Every object of every room hangs from ``world``, ``floating`` or ``fixed`` as in its own room.

    Raises:
        PhysicsError: an object's pose is not finite (nothing is written).
    """
    for scene in house.rooms:
        require_finite_poses(scene, "export URDF")
    base = Path(base_dir) if base_dir is not None else None
    objects = house.objects
    shapes = {o.id: object_shape(o, base, cache=hull_cache, hulls=hulls) for o in objects}
    writer = _UrdfWriter(folder, house.id, {o.id for o in objects}, f"scenemosaic house {house.id}")
    slabs = house_slabs(house)
    writer.fixed(_free_name("floor", writer.taken), _boxes([s for s in slabs if s.room_id is None]))
    for scene in house.rooms:
        mine = [s for s in slabs if s.room_id == scene.id]
        writer.fixed(_free_name(scene.id, writer.taken), _boxes(mine))
    for scene in house.rooms:
        writer.objects(scene, shapes, base)
    return writer.save(len(objects))

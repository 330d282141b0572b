"""USD export: ``scene.usda`` plus one geometry layer per object under ``usd/``, all ASCII.

The stage is Z up, one unit = one metre, one kilogram per mass unit, and its default prim is
``/World``. Its physics is the world the MJCF export writes (:func:`scenemosaic.physics.scene_world`),
expressed with UsdPhysics:

* ``/World/PhysicsScene`` — gravity along -Z with the simulator's magnitude;
* ``/World/Room`` — the room's slabs (:func:`scenemosaic.physics.room_slabs`) as ``Cube`` prims
  carrying ``PhysicsCollisionAPI``: static colliders. A wall cut around its openings is an
  ``Xform`` named by the wall holding one such ``Cube`` per piece, ``piece_<k>``;
* ``/World/Objects/<name>`` — one ``Xform`` per object, named by its id made into a USD
  identifier, placed by the object's rigid pose (translate + orient). It references
  ``usd/<name>.usda``, which holds ``visual`` (the visual mesh) and ``collision/piece_<k>`` (the
  convex pieces, ``PhysicsMeshCollisionAPI`` approximation ``convexHull``, purpose ``guide``).
  Objects the MJCF export gives a free joint also carry ``PhysicsRigidBodyAPI`` and
  ``PhysicsMassAPI`` (mass, centre of mass and box inertia of
  :func:`scenemosaic.physics.object_inertial`); held ones (``static``, hung from a wall or the
  ceiling) only collide;
* ``/World/PhysicsMaterials/<name>`` — a ``Material`` with ``PhysicsMaterialAPI`` per object (its
  friction) and one for the room, bound with the ``physics`` purpose.

Furniture that opens (``ObjectShape.articulation``): the object's prim and layer hold what does not
move (its mass the share :func:`scenemosaic.physics.part_inertials` gives it); each drawer, door
and lid is a rigid body of its own beside it, ``<parent>/<name>_<part>`` (``customData``
``scenemosaic:partOf``, the object's id, and ``scenemosaic:part``), placed at the part's anchor with the object's
orientation, referencing ``usd/<name>_<part>.usda`` (its visual and collision pieces in its own
frame, closed; the prim itself stands where the scene delivers the part,
:func:`scenemosaic.assets.part_openings`), and joined to the object's prim by
``<parent>/<name>_<part>/joint``: a
``PhysicsPrismaticJoint`` (limits in metres) or ``PhysicsRevoluteJoint`` (limits in degrees, as
UsdPhysics has them) whose joint frames sit at the anchor on both bodies, turned so the joint's
``X``/``Y``/``Z`` axis is the part's opening direction; its damping is a ``PhysicsDriveAPI``
(``linear`` or ``angular``) of stiffness 0, and its dry friction, which core UsdPhysics cannot say,
is kept in the joint's ``customData`` ``scenemosaic:friction``.

Meshes are written in the object's local frame with its scale already applied (their bounds are
the object's size), as in the GLB and MJCF exports, so no scale op is authored; the pose's scale is
kept in the prim's ``customData`` for reference. Every asset path is relative, so the folder can be
moved. ``pxr`` (``pip install 'scenemosaic[usd]'``) is imported only when writing.

:func:`export_usd` of a house writes a whole house the same way on one stage: ``/World/floor`` (the
house's one floor slab), then per room ``/World/<room>`` holding ``Room/`` (its walls, shared
walls once, and its ceiling, :func:`scenemosaic.physics.house_slabs`) and ``Objects/``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
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
from scenemosaic.exceptions import MissingExtraError, UsageError
from scenemosaic.physics import (
    ROOM_FRICTION,
    HullInput,
    ObjectInertial,
    ObjectShape,
    RoomSlab,
    SimSettings,
    house_slabs,
    is_fixed,
    object_inertial,
    object_shape,
    part_inertials,
    require_finite_poses,
    room_slabs,
)
from scenemosaic.render import CEILING_COLOR, FLOOR_COLOR, RGB, WALL_COLOR, category_color
from scenemosaic.scene import House, Scene, SceneObject, quat_from_matrix, write_atomic

__all__ = [
    "USD_GEOMETRY_DIR",
    "USD_INSTALL_HINT",
    "USD_SCENE_FILE",
    "export_usd",
    "usd_prim_name",
]

log = structlog.get_logger(__name__)

USD_SCENE_FILE = "scene.usda"
"""The stage :func:`export_usd` writes when given a folder."""
USD_GEOMETRY_DIR = "usd"
"""Folder, beside the stage, holding one geometry layer per object (referenced with a relative path)."""
USD_INSTALL_HINT = "pip install 'scenemosaic[usd]'"
"""The command that installs the USD extra (usd-core, which provides ``pxr``)."""

_NOT_IDENTIFIER = re.compile(r"[^A-Za-z0-9_]")
_CEILING_OPACITY = 0.25
_ROOM_MATERIAL = "room"
"""The room's physics material, ``/World/PhysicsMaterials/room``; no object's material takes the name."""


def usd_prim_name(object_id: str, taken: set[str]) -> str:
    """A USD prim name for ``object_id``: ``.`` and ``-`` become ``_``, a leading digit gets a ``_``
    in front, and a name already in ``taken`` gets ``_2``, ``_3``... (the name is added to ``taken``)."""
    stem = _NOT_IDENTIFIER.sub("_", object_id)
    if not stem or stem[0].isdigit():
        stem = "_" + stem
    name, n = stem, 2
    while name in taken:
        name, n = f"{stem}_{n}", n + 1
    taken.add(name)
    return name


def _import_pxr() -> Any:
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt
    except ImportError as exc:
        raise MissingExtraError(
            f"the USD export needs usd-core (module pxr), which is not installed: {USD_INSTALL_HINT}"
        ) from exc
    return Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt


def _color(rgb: RGB) -> tuple[float, float, float]:
    return (rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0)


class _Writer:
    """Authoring helpers over the ``pxr`` modules, imported once per export."""

    def __init__(self) -> None:
        self.Gf, self.Sdf, self.Usd, self.UsdGeom, self.UsdPhysics, self.UsdShade, self.Vt = _import_pxr()

    def new_stage(self, default_prim: str) -> tuple[Any, Any]:
        """An in-memory ASCII layer and its stage, Z up, metres and kilograms, with ``/<default_prim>``."""
        layer = self.Sdf.Layer.CreateAnonymous(".usda")
        stage = self.Usd.Stage.Open(layer)
        self.UsdGeom.SetStageUpAxis(stage, self.UsdGeom.Tokens.z)
        self.UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        self.UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
        root = self.UsdGeom.Xform.Define(stage, f"/{default_prim}")
        stage.SetDefaultPrim(root.GetPrim())
        return layer, stage

    def save(self, layer: Any, path: Path) -> None:
        """Write ``layer`` to ``path``; a copy of that file already open in this process is reloaded."""
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")  # USD picks the format by suffix
        try:
            if not layer.Export(str(tmp)):
                raise OSError(f"USD could not write {path}")
            os.replace(tmp, path)  # atomic, and never through a symlink at ``path``
        finally:
            tmp.unlink(missing_ok=True)
        opened = self.Sdf.Layer.Find(str(path))
        if opened is not None:
            opened.Reload()

    def save_text(self, text: str, path: Path) -> None:
        """Write a layer exported as ``text`` to ``path``, as :meth:`save` writes it."""
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, text)
        opened = self.Sdf.Layer.Find(str(path))
        if opened is not None:
            opened.Reload()

    def mesh(self, stage: Any, prim_path: str, mesh: trimesh.Trimesh) -> Any:
        """A triangle ``Mesh`` prim (no subdivision) with its points, faces and extent."""
        usd_mesh = self.UsdGeom.Mesh.Define(stage, prim_path)
        points = self.Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(mesh.vertices, dtype=np.float32))
        faces = np.ascontiguousarray(mesh.faces, dtype=np.int32)
        usd_mesh.CreatePointsAttr(points)
        usd_mesh.CreateFaceVertexCountsAttr(
            self.Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32))
        )
        usd_mesh.CreateFaceVertexIndicesAttr(self.Vt.IntArray.FromNumpy(faces.reshape(-1)))
        usd_mesh.CreateExtentAttr(self.UsdGeom.PointBased.ComputeExtent(points))
        usd_mesh.CreateSubdivisionSchemeAttr(self.UsdGeom.Tokens.none)
        return usd_mesh

    def collider(self, prim: Any, approximation: str | None = None) -> None:
        """Make ``prim`` collide; a mesh gets ``approximation`` (e.g. ``convexHull``)."""
        self.UsdPhysics.CollisionAPI.Apply(prim)
        if approximation is not None:
            self.UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(approximation)

    def physics_material(self, stage: Any, prim_path: str, friction: float) -> Any:
        """A ``Material`` with ``PhysicsMaterialAPI``: static and dynamic friction, no restitution."""
        material = self.UsdShade.Material.Define(stage, prim_path)
        api = self.UsdPhysics.MaterialAPI.Apply(material.GetPrim())
        api.CreateStaticFrictionAttr(float(friction))
        api.CreateDynamicFrictionAttr(float(friction))
        api.CreateRestitutionAttr(0.0)
        return material

    def bind_physics(self, prim: Any, material: Any) -> None:
        """Bind ``material`` to ``prim`` and its descendants for the ``physics`` purpose."""
        self.UsdShade.MaterialBindingAPI.Apply(prim).Bind(
            material, self.UsdShade.Tokens.fallbackStrength, "physics"
        )


def _layer_text(
    w: _Writer,
    name: str,
    obj: SceneObject,
    shape: ObjectShape,
    base_dir: Path | None,
    *,
    part: PartSpec | None = None,
) -> str:
    """:func:`_object_layer` as ``.usda`` text, made once per process for each name, asset
    (:func:`~scenemosaic.assets.asset_fingerprint`: the visual and the parts), category (the
    colour) and set of collision pieces: a house's variants share their furniture's layers."""
    key = (
        name,
        asset_fingerprint(obj, base_dir),
        obj.category,
        None if part is None else part.name,
        tuple(piece.key for piece in shape.pieces),
    )
    return _LAYER_TEXTS.get(key, lambda: str(_object_layer(w, name, obj, shape, base_dir, part=part).ExportToString()))


_LAYER_TEXTS: Memo[tuple[str, str, str, str | None, tuple[str, ...]], str] = Memo(4096)


def _object_layer(
    w: _Writer,
    name: str,
    obj: SceneObject,
    shape: ObjectShape,
    base_dir: Path | None,
    *,
    part: PartSpec | None = None,
) -> Any:
    """The geometry layer of one object: ``/<name>/visual`` and ``/<name>/collision/piece_<k>``.

    For an object with movable parts, what does not move; with ``part``, that part's visual and
    pieces in its own frame (the object frame moved to the part's anchor). Pieces keep the
    object's numbering ``k``.
    """
    layer, stage = w.new_stage(name)
    root = f"/{name}"
    try:
        if shape.articulation:
            key = None if part is None else part.name
            visual: trimesh.Trimesh | None = object_part_meshes(obj, base_dir).get(key)
        else:
            visual = object_mesh(obj, base_dir)
    except Exception as exc:  # the visual is optional: the collision pieces still describe the object
        log.warning("usd_visual_mesh_failed", object_id=obj.id, error=str(exc))
        visual = None
    anchor = None if part is None else np.asarray(part.anchor, dtype=np.float64)
    if visual is not None:
        if anchor is not None:
            visual = visual.copy()
            visual.apply_translation(-anchor)
        mesh = w.mesh(stage, f"{root}/visual", visual)
        mesh.CreateDisplayColorPrimvar(w.UsdGeom.Tokens.constant).Set(
            [w.Gf.Vec3f(*_color(category_color(obj.category)))]
        )
    w.UsdGeom.Scope.Define(stage, f"{root}/collision")
    moving = shape.moving_pieces()
    for k, piece in enumerate(shape.pieces):
        if (k in moving) != (part is not None) or (part is not None and k not in part.pieces):
            continue
        piece_mesh = piece.mesh()
        if anchor is not None:
            piece_mesh.apply_translation(-anchor)
        mesh = w.mesh(stage, f"{root}/collision/piece_{k}", piece_mesh)
        mesh.CreatePurposeAttr(w.UsdGeom.Tokens.guide)  # renderers skip it; physics does not
        w.collider(mesh.GetPrim(), w.UsdPhysics.Tokens.convexHull)
    return layer


def _axis_frame(axis: tuple[float, float, float]) -> tuple[str, tuple[float, float, float, float]]:
    """UsdPhysics names a joint's axis ``X``, ``Y`` or ``Z`` of its joint frame: the token, and the
    joint frame's rotation (w, x, y, z) that turns that axis onto ``axis`` (a half turn for a
    negative one: about Z for X and Y, about X for Z)."""
    k = int(np.argmax(np.abs(axis)))
    token = "XYZ"[k]
    if axis[k] > 0:
        return token, (1.0, 0.0, 0.0, 0.0)
    return token, (0.0, 0.0, 0.0, 1.0) if k < 2 else (0.0, 1.0, 0.0, 0.0)


def _add_part(
    w: _Writer,
    stage: Any,
    obj: SceneObject,
    part: PartSpec,
    object_path: str,
    part_path: str,
    material: Any,
    mass: ObjectInertial,
    value: float = 0.0,
) -> None:
    """A movable part's rigid body at ``part_path`` and its joint to the object's prim. A part
    delivered open (joint ``value``) has its body at the open pose: UsdPhysics reads a joint's
    position from where its two bodies stand, so the joint frames stay those of the closed part."""
    xform = w.UsdGeom.Xform.Define(stage, part_path)
    prim = xform.GetPrim()
    pose = obj.pose.matrix(with_scale=False) @ part.transform(value)
    anchor = pose @ np.array([*part.anchor, 1.0])
    xform.AddTranslateOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Vec3d(*map(float, anchor[:3])))
    orient = obj.pose.quaternion if value == 0.0 else quat_from_matrix(pose[:3, :3])
    xform.AddOrientOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Quatd(*map(float, orient)))
    prim.SetCustomDataByKey("scenemosaic:partOf", obj.id)  # not objectId: that names objects' own prims
    prim.SetCustomDataByKey("scenemosaic:part", part.name)
    prim.SetCustomDataByKey("scenemosaic:kind", part.kind)
    w.UsdPhysics.RigidBodyAPI.Apply(prim)
    api = w.UsdPhysics.MassAPI.Apply(prim)
    api.CreateMassAttr(mass.mass)
    api.CreateCenterOfMassAttr(w.Gf.Vec3f(*(mass.centre - np.asarray(part.anchor)).tolist()))
    api.CreateDiagonalInertiaAttr(w.Gf.Vec3f(*mass.diagonal.tolist()))
    api.CreatePrincipalAxesAttr(w.Gf.Quatf(1.0, 0.0, 0.0, 0.0))
    w.bind_physics(prim, material)
    slide = part.joint == "slide"
    schema = w.UsdPhysics.PrismaticJoint if slide else w.UsdPhysics.RevoluteJoint
    joint = schema.Define(stage, f"{part_path}/joint")
    token, turn = _axis_frame(part.axis)
    joint.CreateBody0Rel().SetTargets([object_path])
    joint.CreateBody1Rel().SetTargets([part_path])
    joint.CreateAxisAttr(token)
    joint.CreateLocalPos0Attr(w.Gf.Vec3f(*map(float, part.anchor)))
    joint.CreateLocalRot0Attr(w.Gf.Quatf(*turn))
    joint.CreateLocalPos1Attr(w.Gf.Vec3f(0.0, 0.0, 0.0))
    joint.CreateLocalRot1Attr(w.Gf.Quatf(*turn))
    lower, upper = part.limits if slide else (np.degrees(part.limits[0]), np.degrees(part.limits[1]))
    joint.CreateLowerLimitAttr(float(lower))
    joint.CreateUpperLimitAttr(float(upper))
    drive = w.UsdPhysics.DriveAPI.Apply(joint.GetPrim(), "linear" if slide else "angular")
    drive.CreateTypeAttr("force")
    drive.CreateStiffnessAttr(0.0)
    drive.CreateTargetVelocityAttr(0.0)
    drive.CreateDampingAttr(float(part.damping if slide else part.damping * np.pi / 180.0))  # per degree
    joint.GetPrim().SetCustomDataByKey("scenemosaic:friction", float(part.friction))


def _add_cube(w: _Writer, stage: Any, prim_path: str, slab: RoomSlab) -> None:
    """One static box: a unit ``Cube`` placed, turned and scaled to the slab, colliding."""
    cube = w.UsdGeom.Cube.Define(stage, prim_path)
    cube.CreateSizeAttr(1.0)
    cube.AddTranslateOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Vec3d(*map(float, slab.centre)))
    cube.AddOrientOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Quatd(*slab.quaternion))
    cube.AddScaleOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Vec3d(*(2.0 * slab.half_extents).tolist()))
    cube.CreateExtentAttr([w.Gf.Vec3f(-0.5, -0.5, -0.5), w.Gf.Vec3f(0.5, 0.5, 0.5)])  # a unit cube
    colors = {"floor": FLOOR_COLOR, "wall": WALL_COLOR, "ceiling": CEILING_COLOR}
    cube.CreateDisplayColorPrimvar(w.UsdGeom.Tokens.constant).Set([w.Gf.Vec3f(*_color(colors[slab.kind]))])
    if slab.kind == "ceiling":  # see-through, so the room stays visible from above
        cube.CreateDisplayOpacityPrimvar(w.UsdGeom.Tokens.constant).Set([_CEILING_OPACITY])
    w.collider(cube.GetPrim())


def _add_slabs(w: _Writer, stage: Any, parent: str, slabs: list[RoomSlab]) -> None:
    """The slabs under ``parent``: a part that is one box is a ``Cube`` named by the part (``floor``,
    ``ceiling``, the wall's id); a part of several boxes an ``Xform`` so named, one ``Cube``
    ``piece_<k>`` per box."""
    taken: set[str] = set()
    names: dict[str, str] = {}
    for slab in slabs:
        if slab.part_id not in names:
            names[slab.part_id] = usd_prim_name(slab.part_id, taken)
        path = f"{parent}/{names[slab.part_id]}"
        if slab.piece is None:
            _add_cube(w, stage, path, slab)
        else:
            w.UsdGeom.Xform.Define(stage, path)
            _add_cube(w, stage, f"{path}/piece_{slab.piece}", slab)


def _add_room(w: _Writer, stage: Any, scene: Scene) -> None:
    room_prim = w.UsdGeom.Xform.Define(stage, "/World/Room").GetPrim()
    material = w.physics_material(stage, f"/World/PhysicsMaterials/{_ROOM_MATERIAL}", ROOM_FRICTION)
    w.bind_physics(room_prim, material)
    if scene.room is None:  # no room: an unbounded ground plane, as the MJCF export
        plane = w.UsdGeom.Plane.Define(stage, "/World/Room/floor")
        plane.CreateAxisAttr(w.UsdGeom.Tokens.z)
        plane.CreateDisplayColorPrimvar(w.UsdGeom.Tokens.constant).Set([w.Gf.Vec3f(*_color(FLOOR_COLOR))])
        w.collider(plane.GetPrim())
        return
    _add_slabs(w, stage, "/World/Room", room_slabs(scene.room))


def _add_object(
    w: _Writer, stage: Any, scene: Scene, obj: SceneObject, prim_path: str, name: str, shape: ObjectShape
) -> None:
    """The object's prim at ``prim_path`` (pose, physics, material binding ``name``). The reference
    to its geometry layer is added later, on the closed layer (see :func:`_Export.save`)."""
    xform = w.UsdGeom.Xform.Define(stage, prim_path)
    prim = xform.GetPrim()
    xform.AddTranslateOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Vec3d(*map(float, obj.pose.position)))
    xform.AddOrientOp(w.UsdGeom.XformOp.PrecisionDouble).Set(w.Gf.Quatd(*map(float, obj.pose.quaternion)))
    movable = not is_fixed(scene, obj)
    prim.SetCustomDataByKey("scenemosaic:objectId", obj.id)
    prim.SetCustomDataByKey("scenemosaic:category", obj.category)
    prim.SetCustomDataByKey("scenemosaic:movable", movable)
    prim.SetCustomDataByKey("scenemosaic:poseScale", w.Gf.Vec3d(*map(float, obj.pose.scale)))
    if movable:
        inertial = object_inertial(obj, shape) if not shape.articulation else part_inertials(obj, shape)[None]
        w.UsdPhysics.RigidBodyAPI.Apply(prim)
        mass = w.UsdPhysics.MassAPI.Apply(prim)
        mass.CreateMassAttr(inertial.mass)
        mass.CreateCenterOfMassAttr(w.Gf.Vec3f(*inertial.centre.tolist()))
        mass.CreateDiagonalInertiaAttr(w.Gf.Vec3f(*inertial.diagonal.tolist()))
        mass.CreatePrincipalAxesAttr(w.Gf.Quatf(1.0, 0.0, 0.0, 0.0))
    material = w.physics_material(stage, f"/World/PhysicsMaterials/{name}", obj.sim.friction)
    w.bind_physics(prim, material)


def _stage_path(destination: Path) -> Path:
    suffix = destination.suffix.lower()
    if suffix == ".usda":
        return destination
    if suffix in {".usd", ".usdc", ".usdz"}:
        raise UsageError(f"export_usd writes ASCII USD: give a folder or a .usda file, not {destination}")
    return destination / USD_SCENE_FILE


class _Export:
    """One stage being written: the physics scene, then rooms and objects, then the files."""

    def __init__(self, w: _Writer, stage_path: Path, base_dir: Path | None) -> None:
        self.w = w
        self.stage_path = stage_path
        self.base_dir = base_dir
        self.layer, self.stage = w.new_stage("World")
        physics_scene = w.UsdPhysics.Scene.Define(self.stage, "/World/PhysicsScene")
        physics_scene.CreateGravityDirectionAttr(w.Gf.Vec3f(0.0, 0.0, -1.0))
        physics_scene.CreateGravityMagnitudeAttr(SimSettings().gravity)
        w.UsdGeom.Scope.Define(self.stage, "/World/PhysicsMaterials")
        self.taken: set[str] = {_ROOM_MATERIAL}  # object names: materials and geometry files
        self.references: list[tuple[str, str]] = []
        self.count = 0

    def objects(self, scene: Scene, parent: str, shapes: dict[str, ObjectShape]) -> None:
        """Every object of ``scene`` under ``parent`` (an ``Xform``), with its geometry layer."""
        w = self.w
        w.UsdGeom.Xform.Define(self.stage, parent)
        openings = part_openings(scene)
        for obj in scene.objects:
            name = usd_prim_name(obj.id, self.taken)
            relative = f"{USD_GEOMETRY_DIR}/{name}.usda"
            w.save_text(
                _layer_text(w, name, obj, shapes[obj.id], self.base_dir), self.stage_path.parent / relative
            )
            prim_path = f"{parent}/{name}"
            _add_object(w, self.stage, scene, obj, prim_path, name, shapes[obj.id])
            self.references.append((prim_path, f"./{relative}"))
            self.count += 1
            self._parts(obj, shapes[obj.id], parent, name, openings.get(obj.id, {}))

    def _parts(
        self, obj: SceneObject, shape: ObjectShape, parent: str, name: str, openings: Mapping[str, float]
    ) -> None:
        """Each movable part of ``obj``: its geometry layer, its body beside the object's, its joint;
        ``openings``: part name -> the joint value it is delivered at (absent: closed)."""
        if not shape.articulation:
            return
        w = self.w
        material = self.stage.GetPrimAtPath(f"/World/PhysicsMaterials/{name}")
        masses = part_inertials(obj, shape)
        for part in shape.articulation:
            part_name = usd_prim_name(f"{name}_{part.name}", self.taken)
            relative = f"{USD_GEOMETRY_DIR}/{part_name}.usda"
            layer = _layer_text(w, part_name, obj, shape, self.base_dir, part=part)
            w.save_text(layer, self.stage_path.parent / relative)
            part_path = f"{parent}/{part_name}"
            object_path = f"{parent}/{name}"
            binding = w.UsdShade.Material(material)
            value = part.clamped(openings.get(part.name, 0.0))
            _add_part(w, self.stage, obj, part, object_path, part_path, binding, masses[part.name], value)
            self.references.append((part_path, f"./{relative}"))

    def save(self) -> Path:
        # The references go in once the stage is gone: composing them on the in-memory layer would
        # look for the relative files beside an anonymous layer, which has no folder.
        del self.stage
        for prim_path, asset_path in self.references:
            self.layer.GetPrimAtPath(prim_path).referenceList.Prepend(self.w.Sdf.Reference(asset_path))
        self.w.save(self.layer, self.stage_path)
        log.info("usd_exported", path=str(self.stage_path), objects=self.count)
        return self.stage_path


def export_usd(
    scene: Scene | House,
    path_or_folder: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
) -> Path:
    """Write the scene as an ASCII USD stage with UsdPhysics and return the stage's path.

    ``path_or_folder`` is a folder (the stage is ``<folder>/scene.usda``) or a ``.usda`` path; the
    per-object geometry layers go to ``usd/`` beside the stage (see the module docstring for the
    prims). ``base_dir`` resolves relative mesh uris; ``hull_cache`` and ``hulls`` are passed to
    :func:`scenemosaic.physics.object_shape`, as the MJCF export does. Equal scenes give equal bytes.

    Raises:
        MissingExtraError: ``pxr`` is not installed (``pip install 'scenemosaic[usd]'``).
        PhysicsError: an object's pose is not finite (nothing is written).
    """
    if isinstance(scene, House):  # a whole house: every room in one world
        return _export_house_usd(scene, path_or_folder, base_dir, hull_cache=hull_cache, hulls=hulls)
    w = _Writer()  # first, so a missing extra fails before any work
    require_finite_poses(scene, "export USD")
    base = Path(base_dir) if base_dir is not None else None
    shapes = {o.id: object_shape(o, base, cache=hull_cache, hulls=hulls) for o in scene.objects}
    export = _Export(w, _stage_path(Path(path_or_folder)), base)
    _add_room(w, export.stage, scene)
    export.objects(scene, "/World/Objects", shapes)
    return export.save()


def _export_house_usd(
    house: House,
    path_or_folder: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
) -> Path:
    """Write a whole house as one ASCII USD stage with UsdPhysics; return the stage's path.

    As :func:`export_usd`, on one stage: ``/World/floor`` is the house's floor slab; each room is
    ``/World/<room>`` (its id made a prim name; ``customData`` ``scenemosaic:roomId`` holds the
    id) with ``Room/`` (its walls cut around their openings, each shared wall once, and its
    ceiling: :func:`scenemosaic.physics.house_slabs`, the boxes the house's MJCF simulates) and
    ``Objects/<name>`` (every object of the room, rigid or static as in its own room). Object
    names are unique over the house; their geometry layers share ``usd/``.

    Raises:
        MissingExtraError: ``pxr`` is not installed (``pip install 'scenemosaic[usd]'``).
        PhysicsError: an object's pose is not finite (nothing is written).
    """
    w = _Writer()
    for scene in house.rooms:
        require_finite_poses(scene, "export USD")
    base = Path(base_dir) if base_dir is not None else None
    shapes = {o.id: object_shape(o, base, cache=hull_cache, hulls=hulls) for o in house.objects}
    export = _Export(w, _stage_path(Path(path_or_folder)), base)
    stage = export.stage
    slabs = house_slabs(house)
    material = w.physics_material(stage, f"/World/PhysicsMaterials/{_ROOM_MATERIAL}", ROOM_FRICTION)
    rooms_taken = {"PhysicsScene", "PhysicsMaterials", "floor"}
    floor = [slab for slab in slabs if slab.room_id is None]
    _add_slabs(w, stage, "/World", floor)
    w.bind_physics(stage.GetPrimAtPath("/World/floor"), material)
    for scene in house.rooms:
        room_path = f"/World/{usd_prim_name(scene.id, rooms_taken)}"
        room_prim = w.UsdGeom.Xform.Define(stage, room_path).GetPrim()
        room_prim.SetCustomDataByKey("scenemosaic:roomId", scene.id)
        shell = w.UsdGeom.Xform.Define(stage, f"{room_path}/Room").GetPrim()
        w.bind_physics(shell, material)
        _add_slabs(w, stage, f"{room_path}/Room", [slab for slab in slabs if slab.room_id == scene.id])
        export.objects(scene, f"{room_path}/Objects", shapes)
    del stage  # no stage may stay open on the layer while the references go in (see _Export.save)
    return export.save()

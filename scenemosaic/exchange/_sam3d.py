"""SAM3D-style object sets: meshes from an image-to-3D model plus one pose per mesh.

Layout (``docs/importers.md`` has the full statement)::

    my_objects/
      poses.json
      meshes/bed.glb ...           any file trimesh reads; paths are relative to poses.json

``poses.json``::

    {
      "format": "sam3d",                       optional marker
      "units": "m",                            m | cm | mm (default m): positions and mesh coordinates
      "frame": "z_up",                         z_up | y_up (default z_up): default for every object
      "room": {"floor": [[x, y], ...], "ceiling_height": 2.5},    optional
      "objects": [
        {"id": "bed", "label": "bed", "mesh": "meshes/bed.glb",
         "position": [x, y, z], "quaternion": [w, x, y, z], "scale": [sx, sy, sz],
         "frame": "z_up", "up_axis": "auto", "front": "-y", "description": "...",
         "sim": {"mass_kg": 100, "friction": 0.6}}
      ]
    }

An ``id`` is optional (default ``<label>_<n>``); a given one is the object's identity, so a
repeated id, or one reserved for a room anchor (``floor``, ``ceiling``, ``wall_<n>``), is an
error naming the field rather than a silent rename.

A pose places the **mesh file's own coordinates** in the world, as image-to-3D models report
it: ``world = position + R(quaternion) * (scale * mesh_point)``. ``y_up`` poses (and room
points, read as (x, z)) are turned to Z-up by (x, y, z) -> (x, -z, y). The importer loads each
mesh with :func:`scenemosaic.assets.load_mesh`, which gives the transform ``C`` from the file
to the canonical frame (bottom centre at the origin, Z up, front -Y), and composes
``world * C^-1``: the canonical object's pose. The mesh's world placement is preserved exactly
whatever ``C`` is. ``front`` names the canonical axis the mesh's front points along (default
``-y``, our convention); another value adds a turn about +Z to ``C`` so that the object's front
is -Y as everywhere else.
"""

from __future__ import annotations

import json
import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
import structlog
from pydantic import ValidationError
from scipy.spatial.transform import Rotation

from scenemosaic.exceptions import AssetError, ImportFormatError
from scenemosaic.exchange._common import POSES_FILE, FieldReader
from scenemosaic.exchange._native import copy_mesh
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    MAX_OBJECT_SIZE,
    AssetRef,
    FloatArray,
    Pose,
    Provenance,
    Room,
    Scene,
    SceneObject,
    SimAttributes,
    confined_path,
    coordinate_problem,
    missing_file,
    real_path,
    recover_room,
    sanitize_id,
    scale_problem,
    unique_id,
    write_atomic,
)

__all__ = [
    "EXAMPLE_MESH_FOLDER",
    "POSES_FILE",
    "UNIT_SCALES",
    "import_sam3d",
    "looks_like_sam3d",
    "read_sdf_sim",
    "write_sam3d_example",
]

log = structlog.get_logger(__name__)

UNIT_SCALES: Mapping[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Metres per unit for the accepted ``units`` values."""
IMPORTER = "scenemosaic.exchange.sam3d"
_FRAMES = ("z_up", "y_up")
_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
_ROTATION_TOL = 1e-6
UpAxis = Literal["auto", "y", "z"]
_UP_AXES: tuple[UpAxis, ...] = ("auto", "y", "z")
_FRONT_TURNS = {"-y": 0.0, "+y": math.pi, "+x": -math.pi / 2, "-x": math.pi / 2}
"""Turn about +Z that brings each canonical axis onto our front (-Y)."""


def looks_like_sam3d(data: Any) -> bool:
    """Detection rule: ``format == "sam3d"``, or ``objects`` whose entries carry a ``mesh`` field."""
    if not isinstance(data, dict):
        return False
    if data.get("format") == "sam3d":
        return True
    objects = data.get("objects")
    return (
        isinstance(objects, list)
        and bool(objects)
        and all(isinstance(o, dict) and "mesh" in o for o in objects)
    )


def import_sam3d(data: Any, path: Path, *, room: Room | None = None) -> Scene:
    """Build a :class:`Scene` of mesh objects from a parsed ``poses.json`` at ``path``.

    Mesh uris are stored as absolute paths (the scene has no folder yet; :func:`save_scene`
    copies them and makes them relative). A mesh must lie inside the folder of ``poses.json``
    (sub-folders included; symlinks followed), and so must every file it references. Without
    ``room`` (argument or file) the room is recovered from the objects like a 3D-FRONT layout's.
    """
    from scenemosaic.assets import load_mesh, mesh_hash  # importers sit above assets

    r = FieldReader(path)
    top = r.mapping(data, "")
    units = top.get("units", "m")
    if not isinstance(units, str) or units not in UNIT_SCALES:
        r.fail("units", f"unknown units {units!r}; use one of {sorted(UNIT_SCALES)}")
    unit = UNIT_SCALES[units]
    default_frame = _frame(r, top.get("frame", "z_up"), "frame")
    given_room = room if room is not None else _room(r, top.get("room"), default_frame, unit)
    items = r.objects(r.get(top, "objects", ""), "objects")
    if not items:
        r.fail("objects", "the object set is empty")
    explicit = _explicit_ids(r, items)
    taken: set[str] = set(explicit.values())
    counters: dict[str, int] = {}
    objects: list[SceneObject] = []
    notes: list[str] = []
    meshes: dict[tuple[Path, str, str], tuple[FloatArray, tuple[float, float, float], str]] = {}
    for i, raw in enumerate(items):
        f = f"objects[{i}]"
        item = r.mapping(raw, f)
        label = r.label(r.get(item, "label", f), f"{f}.label")
        raw_id = item.get("id")
        who = f"object {raw_id!r}" if isinstance(raw_id, str) and raw_id else f"object {label!r}"
        mesh_rel = r.text(r.get(item, "mesh", f), f"{f}.mesh")
        mesh_path = r.file(path.parent, mesh_rel, f"{f}.mesh", what=who)
        if mesh_path.is_dir():
            r.fail(f"{f}.mesh", f"{who}: {mesh_rel!r} is a directory, not a mesh file")
        if not mesh_path.is_file():
            r.fail(f"{f}.mesh", f"mesh file {missing_file(mesh_path)}")
        position = np.array(r.vector(r.get(item, "position", f), 3, f"{f}.position"))
        r.check(coordinate_problem(position * unit), f"{f}.position", what=who)
        quat = r.vector(item.get("quaternion", [1.0, 0.0, 0.0, 0.0]), 4, f"{f}.quaternion")
        norm = math.sqrt(sum(c * c for c in quat))
        if norm < 1e-9:
            r.fail(f"{f}.quaternion", "quaternion has zero norm")
        scale = np.array(r.vector(item.get("scale", [1.0, 1.0, 1.0]), 3, f"{f}.scale"))
        if scale.min() <= 0:
            r.fail(f"{f}.scale", f"scale must be positive on every axis, got {scale.tolist()}")
        r.check(scale_problem(scale), f"{f}.scale", what=who)
        frame = _frame(r, item.get("frame", default_frame), f"{f}.frame")
        up_raw = item.get("up_axis", "auto")
        if up_raw not in _UP_AXES:
            r.fail(f"{f}.up_axis", f"unknown up axis {up_raw!r}; use 'auto', 'y' or 'z'")
        up_axis: UpAxis = up_raw

        front = item.get("front", "-y")
        if front not in _FRONT_TURNS:
            r.fail(f"{f}.front", f"unknown front axis {front!r}; use one of {sorted(_FRONT_TURNS)}")

        key = (mesh_path, up_axis, front)
        if key not in meshes:
            try:
                loaded = load_mesh(mesh_path, up_axis=up_axis, unit_scale=unit)
            except AssetError as exc:
                raise AssetError(f"{path}: {f}.mesh: {exc}") from exc
            meshes[key] = _turn_to_front(loaded, _FRONT_TURNS[front], mesh_hash)
        transform, extents, digest = meshes[key]

        w, qx, qy, qz = (c / norm for c in quat)
        source_to_world = np.eye(4)
        source_to_world[:3, :3] = Rotation.from_quat([qx, qy, qz, w]).as_matrix() @ np.diag(scale)
        source_to_world[:3, 3] = position
        to_z_up = np.eye(4)
        to_z_up[:3, :3] = unit * (_Y_UP_TO_Z_UP if frame == "y_up" else np.eye(3))
        placed = to_z_up @ source_to_world @ np.linalg.inv(transform)
        pose, exact = _pose_from_matrix(placed)
        if not exact:
            notes.append(f"{f}: scale is not aligned with the canonical axes; rotation approximated")

        if raw_id is not None and not isinstance(raw_id, str):
            r.fail(f"{f}.id", "expected a string")
        n = counters.get(label, 0)
        counters[label] = n + 1
        oid = explicit[i] if i in explicit else unique_id(f"{label}_{n}", taken)
        description = item.get("description", label.replace("_", " "))
        if not isinstance(description, str):
            r.fail(f"{f}.description", "expected a string")
        sim = _sim(r, item.get("sim"), f"{f}.sim")
        objects.append(
            r.scene_object(
                f,
                who,
                id=oid,
                category=label,
                description=description[:500],
                asset=AssetRef(
                    kind="mesh",
                    uri=mesh_path.as_posix(),
                    extents=extents,
                    sha256=digest,
                    source_transform=[float(v) for v in transform.reshape(-1)],
                ),
                pose=pose,
                sim=sim,
            )
        )

    scene_room = given_room
    if scene_room is None:
        scene_room = recover_room(objects, source=str(path))
        notes.append("room recovered from the objects' footprints")
    log.debug("sam3d_imported", path=str(path), objects=len(objects))
    return Scene(
        id=sanitize_id(path.parent.name if path.name == POSES_FILE else path.stem, fallback="scene"),
        room=scene_room,
        objects=objects,
        provenance=Provenance(
            source_format="sam3d", source_path=path.as_posix(), importer=IMPORTER, notes=notes
        ),
    )


def _explicit_ids(r: FieldReader, items: list[Any]) -> dict[int, str]:
    """Our id for each object that gives one, by index.

    Explicit ids are the objects' identities (masks, meshes and poses refer to them): a repeated
    one is an error naming both entries by their original text, never renamed. Ids already in
    the id alphabet are kept verbatim; the others are sanitized (:func:`sanitize_id`) and, should
    two sanitize alike, told apart with a suffix. Generated ids (``label_n``) steer around all.
    """
    first: dict[str, int] = {}
    given: list[tuple[int, str]] = []
    for i, raw in enumerate(items):
        raw_id = raw.get("id") if isinstance(raw, Mapping) else None
        if not isinstance(raw_id, str) or not raw_id:
            continue
        if raw_id in first:
            r.fail(f"objects[{i}].id", f"duplicate id {raw_id!r} (objects[{first[raw_id]}] has it too)")
        sid = sanitize_id(raw_id)
        if sid in (FLOOR, CEILING) or re.fullmatch(r"wall_\d+", sid):
            r.fail(f"objects[{i}].id", f"id {raw_id!r} is reserved for a room anchor")
        first[raw_id] = i
        given.append((i, raw_id))
    out: dict[int, str] = {}
    taken: set[str] = set()
    verbatim = [(i, raw_id) for i, raw_id in given if sanitize_id(raw_id) == raw_id]
    for i, raw_id in verbatim:
        out[i] = raw_id
        taken.add(raw_id)
    for i, raw_id in given:
        if i not in out:
            out[i] = unique_id(sanitize_id(raw_id), taken)
    return out


def _turn_to_front(
    canonical: Any, turn: float, mesh_hash: Any
) -> tuple[FloatArray, tuple[float, float, float], str]:
    """The canonical transform, extents and hash after turning the mesh's front onto -Y."""
    transform = np.asarray(canonical.transform, dtype=np.float64)
    extents = tuple(float(v) for v in canonical.extents)
    if turn == 0.0:
        return transform, (extents[0], extents[1], extents[2]), str(canonical.sha256)
    spin = np.eye(4)
    spin[:3, :3] = Rotation.from_euler("z", turn).as_matrix()
    spin[np.abs(spin) < 1e-15] = 0.0  # exact quarter turns
    mesh = canonical.mesh.copy()
    mesh.apply_transform(spin)
    quarter = abs(abs(turn) - math.pi / 2) < 1e-12
    size = (extents[1], extents[0], extents[2]) if quarter else (extents[0], extents[1], extents[2])
    return spin @ transform, size, str(mesh_hash(mesh))


def _frame(r: FieldReader, value: Any, field: str) -> str:
    if value not in _FRAMES:
        r.fail(field, f"unknown frame {value!r}; use 'z_up' or 'y_up'")
    return str(value)


def _sim(r: FieldReader, value: Any, field: str) -> SimAttributes:
    if value is None:
        return SimAttributes()
    try:
        return SimAttributes.model_validate(dict(r.mapping(value, field)))
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err["loc"])
        r.fail(f"{field}.{where}" if where else field, err["msg"])


def _room(r: FieldReader, value: Any, frame: str, unit: float) -> Room | None:
    if value is None:
        return None
    spec = r.mapping(value, "room")
    points = r.array(r.get(spec, "floor", "room"), "room.floor")
    floor = []
    for j, p in enumerate(points):
        a, b = r.vector(p, 2, f"room.floor[{j}]")
        floor.append((a * unit, -b * unit) if frame == "y_up" else (a * unit, b * unit))
    height = r.number(spec.get("ceiling_height", 2.8 / unit), "room.ceiling_height") * unit
    if not 0 < height <= MAX_OBJECT_SIZE:
        r.fail("room.ceiling_height", f"must be positive and at most {MAX_OBJECT_SIZE:g} m, got {height:g} m")
    try:
        return Room.from_polygon(floor, ceiling_height=height)
    except ValidationError as exc:
        r.fail("room.floor", exc.errors()[0]["msg"])


def _pose_from_matrix(m: FloatArray) -> tuple[Pose, bool]:
    """Split a 4x4 ``T R S`` into a :class:`Pose`; ``exact`` is false when ``S`` was not axis-aligned."""
    linear = m[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    rot = linear / scale
    exact = bool(np.allclose(rot.T @ rot, np.eye(3), atol=_ROTATION_TOL) and np.linalg.det(rot) > 0)
    if not exact:
        u, _, vt = np.linalg.svd(rot)
        rot = u @ vt
        if np.linalg.det(rot) < 0:
            u[:, -1] *= -1
            rot = u @ vt
    qx, qy, qz, qw = Rotation.from_matrix(rot).as_quat()
    pose = Pose(
        position=(float(m[0, 3]), float(m[1, 3]), float(m[2, 3])),
        quaternion=(float(qw), float(qx), float(qy), float(qz)),
        scale=(float(scale[0]), float(scale[1]), float(scale[2])),
    )
    return pose, exact


# -- SDF side files and the shared example --------------------------------------------------------


def read_sdf_sim(path: str | os.PathLike[str]) -> SimAttributes:
    """Mass and friction of the first model in an SDF file (stdlib XML), as :class:`SimAttributes`.

    Friction is the first ``<mu>`` under a collision's ``surface/friction/ode``.
    """
    p = Path(path)
    try:
        root = ET.parse(p).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ImportFormatError(f"cannot parse SDF: {exc}", path=str(p)) from exc
    values: dict[str, Any] = {"source": f"sdf:{p.name}"}
    mass = root.find(".//link/inertial/mass")
    if mass is not None and mass.text:
        values["mass_kg"] = _sdf_float(p, "inertial.mass", mass.text)
    mu = root.find(".//collision/surface/friction/ode/mu")
    if mu is not None and mu.text:
        values["friction"] = _sdf_float(p, "collision.surface.friction.ode.mu", mu.text)
    try:
        return SimAttributes.model_validate(values)
    except ValidationError as exc:
        raise ImportFormatError(str(exc.errors()[0]["msg"]), path=str(p)) from exc


def _sdf_float(path: Path, field: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError as exc:
        raise ImportFormatError(f"not a number: {text!r}", path=str(path), field=field) from exc
    if not math.isfinite(value):
        raise ImportFormatError(f"must be finite, got {text!r}", path=str(path), field=field)
    return value


def _sdf_room(sdf: Path) -> tuple[tuple[float, float, float, float], float] | None:
    """(xmin, ymin, xmax, ymax) of the floor box and the tallest wall top, from a room SDF."""
    try:
        root = ET.parse(sdf).getroot()
    except (ET.ParseError, OSError):
        return None
    floor: tuple[float, float, float, float] | None = None
    top = 0.0
    for col in root.iter("collision"):
        size_el = col.find("geometry/box/size")
        pose_el = col.find("pose")
        if size_el is None or not size_el.text:
            continue
        sx, sy, sz = (float(v) for v in size_el.text.split())
        px, py, pz = (
            (float(v) for v in (pose_el.text or "0 0 0").split()[:3]) if pose_el is not None else (0, 0, 0)
        )
        if "floor" in (col.get("name") or ""):
            floor = (px - sx / 2, py - sy / 2, px + sx / 2, py + sy / 2)
        else:
            top = max(top, pz + sz / 2)
    if floor is None or top <= 0:
        return None
    return floor, top


EXAMPLE_MESH_FOLDER = "meshes"
"""Folder, beside the example's ``poses.json``, that holds the copies of the shared meshes."""
_EXAMPLE_MESHES = {
    "bed": ("generated_assets/sdf/king_bed_*/king_bed.gltf", "bed"),
    "work_desk": ("generated_assets/sdf/work_desk_*/work_desk.gltf", "desk"),
    "office_chair": ("generated_assets/sdf/office_chair_*/office_chair.gltf", "office_chair"),
    "printer": ("generated_assets/sdf/printer_*/printer.gltf", "printer"),
    "coffee_mug": ("generated_assets/manipulands/sdf/coffee_mug_*/coffee_mug.gltf", "coffee_mug"),
}
_EXAMPLE_FRONT = "+y"
"""The shared SAM3D meshes face glTF -Z (the bed's headboard and the chair's backrest are on +Z),
i.e. canonical +Y after the Y-up -> Z-up turn: the example says so with ``"front": "+y"``."""


def write_sam3d_example(
    folder: str | os.PathLike[str], shared_dir: str | os.PathLike[str], *, frame: str = "z_up"
) -> Path:
    """Write a ``poses.json`` for the five shared SAM3D meshes into ``folder``; return its path.

    ``shared_dir`` is the ``sam3d_objects`` folder of the shared data. A bedroom-office in the
    5 x 5 m room of ``room_geometry.sdf``: the bed against the north wall, the work desk
    against the south wall, the office chair in front of the desk facing it, the printer
    (turned a quarter so it fits the desk's depth) and the mug on the desk top. Mass and
    friction come from each mesh's ``.sdf``. The meshes are copied, with their buffers, into
    ``folder/meshes/<stem>-<hash12>/`` and referenced relative to ``poses.json``: a pose file
    may only use meshes inside its own folder. ``frame`` picks the frame the poses are written
    in (``z_up`` or ``y_up``).
    """
    from scenemosaic.assets import load_mesh, mesh_hash

    if frame not in _FRAMES:
        raise ImportFormatError(f"unknown frame {frame!r}; use 'z_up' or 'y_up'", field="frame")
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    shared = Path(shared_dir)
    room_info = _sdf_room(shared / "room_geometry.sdf")
    (xmin, ymin, xmax, ymax), ceiling = room_info or ((-2.5, -2.5, 2.5, 2.5), 2.5)

    found: dict[str, tuple[Path, tuple[FloatArray, tuple[float, float, float], str], SimAttributes]] = {}
    for key, (pattern, _) in _EXAMPLE_MESHES.items():
        matches = sorted(shared.glob(pattern))
        if not matches:
            raise AssetError(f"no mesh matching {pattern!r} under {shared}")
        source = real_path(matches[0])
        sdfs = sorted(source.parent.glob("*.sdf"))
        sim = read_sdf_sim(confined_path(source.parent, sdfs[0].name)) if sdfs else SimAttributes()
        mesh = out / copy_mesh(source, out, key, EXAMPLE_MESH_FOLDER)
        found[key] = (mesh, _turn_to_front(load_mesh(mesh), _FRONT_TURNS[_EXAMPLE_FRONT], mesh_hash), sim)

    def ext(key: str) -> FloatArray:
        return np.asarray(found[key][1][1], dtype=np.float64)

    gap = 0.05
    bed, desk, chair = ext("bed"), ext("work_desk"), ext("office_chair")
    printer, mug = ext("printer"), ext("coffee_mug")
    desk_x = xmax - gap - desk[0] / 2 - 0.3
    desk_y = ymin + gap + desk[1] / 2
    left_edge = desk_x - desk[0] / 2
    placements = {  # canonical bottom-centre position and yaw (0 faces -Y)
        "bed": ((xmin + gap + bed[0] / 2 + 0.4, ymax - gap - bed[1] / 2, 0.0), 0.0),
        "work_desk": ((desk_x, desk_y, 0.0), math.pi),
        "office_chair": ((desk_x, desk_y + desk[1] / 2 + chair[1] / 2 + 0.15, 0.0), 0.0),
        # a quarter turn puts the printer's depth along the desk's width
        "printer": ((left_edge + printer[1] / 2 + 0.03, desk_y, float(desk[2])), math.pi / 2),
        "coffee_mug": ((desk_x + desk[0] / 2 - mug[0] / 2 - 0.12, desk_y - 0.1, float(desk[2])), math.pi),
    }
    to_file = np.eye(4)
    if frame == "y_up":
        to_file[:3, :3] = _Y_UP_TO_Z_UP.T
    objects = []
    for key, (position, yaw) in placements.items():
        mesh, canonical, sim = found[key]
        placed = np.eye(4)
        placed[:3, :3] = Rotation.from_euler("z", yaw).as_matrix()
        placed[:3, 3] = position
        source_to_world = to_file @ placed @ canonical[0]
        linear = source_to_world[:3, :3]
        scale = np.linalg.norm(linear, axis=0)
        qx, qy, qz, qw = Rotation.from_matrix(linear / scale).as_quat()
        objects.append(
            {
                "id": key,
                "label": _EXAMPLE_MESHES[key][1],
                "mesh": mesh.relative_to(out).as_posix(),
                "position": [round(float(v), 9) for v in source_to_world[:3, 3]],
                "quaternion": [round(float(v), 12) for v in (qw, qx, qy, qz)],
                "scale": [round(float(v), 12) for v in scale],
                "front": _EXAMPLE_FRONT,
                "sim": sim.model_dump(exclude_none=True),
            }
        )
    floor = [[xmin, ymin], [xmax, ymin], [xmax, ymax], [xmin, ymax]]
    if frame == "y_up":
        floor = [[x, -y] for x, y in floor]
    doc = {
        "format": "sam3d",
        "units": "m",
        "frame": frame,
        "room": {"floor": floor, "ceiling_height": ceiling},
        "objects": objects,
    }
    return write_atomic(out / POSES_FILE, json.dumps(doc, indent=2) + "\n")

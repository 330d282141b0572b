"""Whole-scene GLB export: one node per object, named by its id, plus the room under ``room/``.

Frames (the full statement is ``docs/exports.md``). glTF is Y-up, so the file has a single
root node, :data:`GLB_ROOT_NODE`, whose matrix is :data:`Z_UP_TO_Y_UP` (a -90° rotation about
X). Everything below it is in our world frame: Z up, metres, objects facing their local -Y.
A glTF viewer therefore shows the scene upright; a reader that wants our Z-up frame back
either reads each child node's matrix relative to the root (it *is* the Z-up pose) or maps
Y-up world points with ``(x, y, z) -> (x, -z, y)`` (:data:`Y_UP_TO_Z_UP`).

Furniture that opens (``scenemosaic.assets.object_articulation``): the object's node holds what
does not move, and each drawer, door and lid is a child node ``<id>/<part>`` whose matrix is the
translation to the part's anchor (object frame) and whose mesh is the part in that frame, closed:
a viewer that turns or shifts that node about its origin opens the part (``docs/articulation.md``).
A part delivered open (``--open-state``) has that motion already in its node's matrix.

A house (:func:`export_glb` of a house) has, under the same root, one node per room named by the
room's id (identity matrix), holding ``<room id>/floor``, ``<room id>/<wall id>`` (openings cut,
each shared wall once), ``<room id>/ceiling`` and a node per object of the room.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import structlog
import trimesh
from trimesh.visual.material import PBRMaterial

from scenemosaic._memo import Memo
from scenemosaic.assets import (
    object_articulation,
    object_mesh_arrays,
    object_part_arrays,
    object_part_meshes,
    part_openings,
)
from scenemosaic.exceptions import UsageError
from scenemosaic.render import (
    CEILING_COLOR,
    FLOOR_COLOR,
    RGB,
    WALL_COLOR,
    WallPiece,
    category_color,
    ceiling_mesh,
    floor_mesh,
    house_wall_pieces,
    moved_arrays,
    object_local_mesh,
    wall_ends,
    wall_mesh,
    wall_pieces,
)
from scenemosaic.scene import FloatArray, House, Room, Scene, SceneObject, write_atomic

__all__ = [
    "GLB_ROOT_NODE",
    "ROOM_NODE_PREFIX",
    "Y_UP_TO_Z_UP",
    "Z_UP_TO_Y_UP",
    "build_glb_scene",
    "build_house_glb_scene",
    "export_glb",
]

log = structlog.get_logger(__name__)

GLB_ROOT_NODE = "scenemosaic:z_up"
"""Name of the root node carrying the Z-up -> Y-up rotation (a ':' never occurs in object ids)."""
ROOM_NODE_PREFIX = "room/"
"""Room geometry nodes are ``room/floor``, ``room/<wall id>`` (``room/wall_0`` ...) and ``room/ceiling``."""

Z_UP_TO_Y_UP = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
"""Rotation of -90° about X: our (x, y, z) -> glTF (x, z, -y). Up +Z -> +Y, front -Y -> +Z."""
Y_UP_TO_Z_UP = Z_UP_TO_Y_UP.T.copy()
"""The inverse: glTF (x, y, z) -> our (x, -z, y)."""

CEILING_ALPHA = 0.25
"""Opacity of the ceiling slab, so viewers can look into the room from above."""


def _material(color: RGB, *, alpha: float = 1.0, name: str) -> PBRMaterial:
    return PBRMaterial(  # type: ignore[no-untyped-call]
        name=name,
        baseColorFactor=[color[0], color[1], color[2], round(alpha * 255)],
        metallicFactor=0.0,
        roughnessFactor=0.8,
        alphaMode="BLEND" if alpha < 1.0 else "OPAQUE",
        doubleSided=alpha < 1.0,
    )


def paint_mesh(mesh: trimesh.Trimesh, color: RGB, *, name: str, alpha: float = 1.0) -> trimesh.Trimesh:
    """(Package-internal.) A copy of ``mesh`` carrying one PBR material (its own texture visuals are dropped)."""
    return _painted(mesh.vertices, mesh.faces, color, name=name, alpha=alpha)


def _painted(
    vertices: FloatArray, faces: npt.NDArray[np.int64], color: RGB, *, name: str, alpha: float = 1.0
) -> trimesh.Trimesh:
    """:func:`paint_mesh` of the mesh of ``vertices`` and ``faces`` (copied): all it reads of a mesh."""
    out = trimesh.Trimesh(vertices=vertices.copy(), faces=faces.copy(), process=False)
    out.visual = trimesh.visual.TextureVisuals(  # type: ignore[no-untyped-call]
        material=_material(color, alpha=alpha, name=name)
    )
    return out


def _untextured(obj: SceneObject) -> bool:
    """Whether ``obj``'s meshes never carry a texture (:func:`with_visual` paints them): procedural
    furniture and boxes. Their GLB meshes are painted straight from the shared arrays."""
    return obj.asset.kind in ("procedural", "box")


_ROOM_ARRAYS: Memo[tuple[str, ...], tuple[FloatArray, npt.NDArray[np.int64]]] = Memo(1024)
"""A room's floor, wall and ceiling meshes as read-only arrays, by what they are made of (the
room, and a wall's pieces): a house's variants share their rooms, and building each wall's
boxes again was a good part of a house's GLB."""


def _room_arrays(
    key: tuple[str, ...], make: Callable[[], trimesh.Trimesh]
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    def frozen() -> tuple[FloatArray, npt.NDArray[np.int64]]:
        mesh = make()
        vertices, faces = np.array(mesh.vertices, dtype=np.float64), np.array(mesh.faces, dtype=np.int64)
        vertices.setflags(write=False)
        faces.setflags(write=False)
        return vertices, faces

    return _ROOM_ARRAYS.get(key, frozen)


def with_visual(mesh: trimesh.Trimesh, category: str) -> trimesh.Trimesh:
    """(Package-internal.) ``mesh`` itself when it carries a UV texture, else a copy painted in the category colour."""
    if isinstance(mesh.visual, trimesh.visual.TextureVisuals) and mesh.visual.uv is not None:
        return mesh
    return paint_mesh(mesh, category_color(category), name=category)


def _root() -> trimesh.Scene:
    out = trimesh.Scene()
    out.graph.update(  # type: ignore[no-untyped-call]
        frame_from=out.graph.base_frame, frame_to=GLB_ROOT_NODE, matrix=Z_UP_TO_Y_UP
    )
    return out


def _add_objects(out: trimesh.Scene, scene: Scene, parent: str, base_dir: Path | None) -> None:
    openings = part_openings(scene)
    for obj in scene.objects:
        parts = object_articulation(obj, base_dir)
        plain = _untextured(obj)  # painted from the arrays every export shares, the same mesh
        color = category_color(obj.category)
        if not parts:
            if plain:
                mesh = _painted(*object_mesh_arrays(obj, base_dir), color, name=obj.category)
            else:
                mesh = with_visual(object_local_mesh(obj, base_dir), obj.category)
            out.add_geometry(
                mesh, node_name=obj.id, geom_name=obj.id, parent_node_name=parent,
                transform=obj.pose.matrix(with_scale=False),
            )  # fmt: skip
            continue
        if plain:
            arrays = object_part_arrays(obj, base_dir)
            body = _painted(*arrays[None], color, name=obj.category)
        else:
            meshes = object_part_meshes(obj, base_dir)
            body = with_visual(meshes[None], obj.category)
        out.add_geometry(
            body, node_name=obj.id, geom_name=obj.id,
            parent_node_name=parent, transform=obj.pose.matrix(with_scale=False),
        )  # fmt: skip
        for part in parts:
            name = f"{obj.id}/{part.name}"
            at = np.eye(4)
            at[:3, 3] = part.anchor
            value = part.clamped(openings.get(obj.id, {}).get(part.name, 0.0))
            if value != 0.0:  # delivered open: the node's matrix moves the part to its open pose
                at = part.transform(value) @ at
            shift = np.eye(4)  # what Trimesh.apply_translation(-anchor) applies
            shift[:3, 3] = -np.asarray(part.anchor, dtype=np.float64)
            if plain:
                mesh = _painted(*moved_arrays(*arrays[part.name], shift), color, name=obj.category)
            else:
                mesh = meshes[part.name].copy()
                mesh.apply_transform(shift)
                mesh = with_visual(mesh, obj.category)
            out.add_geometry(
                mesh, node_name=name, geom_name=name, parent_node_name=obj.id,
                transform=at,
            )  # fmt: skip


def _add_room(
    out: trimesh.Scene, room: Room, prefix: str, parent: str, pieces: dict[str, list[WallPiece]]
) -> None:
    """Floor, walls (each of its ``pieces``; a wall with none is left out) and ceiling, named
    ``<prefix><part>``, under ``parent``."""
    shell = room.model_dump_json()
    floor = _room_arrays(("floor", shell), lambda: floor_mesh(room))
    room_meshes: list[tuple[str, trimesh.Trimesh]] = [("floor", _painted(*floor, FLOOR_COLOR, name="floor"))]
    for w in room.walls:
        if pieces[w.id]:
            mine = pieces[w.id]
            key = ("wall", shell, w.id, repr([tuple(p) for p in mine]))
            wall = _room_arrays(key, functools.partial(wall_mesh, w, mine))
            room_meshes.append((w.id, _painted(*wall, WALL_COLOR, name="wall")))
        else:
            log.debug("glb_wall_left_out", wall=w.id)  # wholly open, or kept by a neighbour
    ceiling = _room_arrays(("ceiling", shell), lambda: ceiling_mesh(room))
    room_meshes.append(("ceiling", _painted(*ceiling, CEILING_COLOR, name="ceiling", alpha=CEILING_ALPHA)))
    for name, mesh in room_meshes:
        node = prefix + name
        out.add_geometry(mesh, node_name=node, geom_name=node, parent_node_name=parent)


def build_glb_scene(scene: Scene, base_dir: Path | None = None) -> trimesh.Scene:
    """The trimesh scene :func:`export_glb` writes (root node, object nodes, room nodes)."""
    out = _root()
    _add_objects(out, scene, GLB_ROOT_NODE, base_dir)
    room = scene.room
    if room is None:
        log.warning("glb_without_room", scene=scene.id)
        return out
    pieces = {w.id: wall_pieces(w, wall_ends(room, w)) for w in room.walls}
    _add_room(out, room, ROOM_NODE_PREFIX, GLB_ROOT_NODE, pieces)
    return out


def build_house_glb_scene(house: House, base_dir: Path | None = None) -> trimesh.Scene:
    """The trimesh scene :func:`export_glb` of a house writes: under the root node, a node per room
    (its id) holding the room's floor, walls and ceiling (``<room id>/<part>``) and its objects."""
    objects = {o.id for o in house.objects}
    clash = sorted(objects & set(house.room_ids))
    if clash:
        raise UsageError(f"object id(s) {clash} are also room ids: a GLB node name must be unique")
    out = _root()
    pieces = house_wall_pieces(house)
    for scene in house.rooms:
        out.graph.update(  # type: ignore[no-untyped-call]
            frame_from=GLB_ROOT_NODE, frame_to=scene.id, matrix=np.eye(4)
        )
        if scene.room is not None:
            mine = {w.id: pieces[(scene.id, w.id)] for w in scene.room.walls}
            _add_room(out, scene.room, f"{scene.id}/", scene.id, mine)
        _add_objects(out, scene, scene.id, base_dir)
    return out


def export_glb(scene: Scene | House, path: str | Path, base_dir: Path | None = None) -> Path:
    """Write the scene as a binary glTF file and return its path.

    One node per object, named by the object's id, whose matrix is the object's rigid pose
    (``pose.matrix(with_scale=False)``) applied to its already-scaled local mesh; the room as
    ``room/floor``, ``room/<wall id>`` and ``room/ceiling``; all under the root node
    :data:`GLB_ROOT_NODE` that turns our Z-up world into glTF's Y-up. ``base_dir`` is the
    scene folder that relative mesh paths resolve against. Equal scenes give identical bytes.
    """
    if isinstance(scene, House):  # a whole house: every room in one world
        return _export_house_glb(scene, path, base_dir)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data: bytes = build_glb_scene(scene, base_dir).export(file_type="glb")  # type: ignore[no-untyped-call]
    write_atomic(path, data)
    log.info("glb_exported", path=str(path), objects=len(scene.objects), bytes=len(data))
    return path


def _export_house_glb(house: House, path: str | Path, base_dir: Path | None = None) -> Path:
    """Write a whole house as one binary glTF file and return its path.

    Under the Z-up root node (:data:`GLB_ROOT_NODE`), one node per room, named by the room's id,
    holds ``<room id>/floor``, ``<room id>/<wall id>`` (openings cut out, each wall shared by two
    rooms kept once, with the first room that has it: :func:`scenemosaic.render.house_wall_pieces`),
    ``<room id>/ceiling`` and one node per object of the room, named by its id, whose matrix is the
    object's rigid pose (room nodes carry the identity, so it is also the pose in the world).
    ``base_dir`` resolves every room's relative mesh paths. Equal houses give identical bytes.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data: bytes = build_house_glb_scene(house, base_dir).export(file_type="glb")  # type: ignore[no-untyped-call]
    write_atomic(path, data)
    log.info(
        "glb_exported", path=str(path), rooms=len(house.rooms), objects=len(house.objects), bytes=len(data)
    )
    return path

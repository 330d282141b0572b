"""SceneEval ``sceneState`` export: ``scene_base.json`` plus one GLB per distinct asset.

Frames (the full statement is ``docs/exports.md``):

* The scene is Z-up, metres (``"up": [0, 0, 1]``, ``"unit": 1.0``); ``"front": [0, 1, 0]`` is
  the format's declared front axis. Arch points are world ``[x, y, z]``.
* Each asset GLB follows glTF: +Y up, +Z front, origin at the bottom centre of the footprint,
  metres, with the object's scale and mesh *baked in* (one per distinct baked mesh).
  Its vertices are our local-frame vertices mapped by ``Rx(-90°)``: ``(x, y, z) -> (x, z, -y)``,
  so our front (local -Y) becomes glTF +Z.
* Each object's ``transform`` is the rigid ``M = T(position) · R(pose) · Rx(+90°)``, written
  column-major; for an upright pose ``R = Rz(yaw)``, so yaw 0 faces world -Y. SceneEval reads it
  with ``np.asarray(data).reshape(4, 4).T`` and applies it to the GLB's raw vertices.

* An object of furniture that opens also has ``"parts"``: per drawer, door and lid its ``name``,
  ``kind``, ``joint`` (``slide`` or ``hinge``), ``axis`` and ``anchor`` in the asset GLB's frame
  (glTF, as its vertices) and ``limits`` (metres or radians; 0 is closed, as the asset GLB
  is), and ``value``, the joint value it is delivered at, when that is not 0 (``--open-state``;
  ``docs/articulation.md``). SceneEval itself ignores the key.

A whole house (:func:`export_sceneeval` of a house) is one sceneState: the format's ``arch`` is a list
of elements each naming its ``roomId`` (SceneEval builds one floor per ``roomId`` and every wall
with its holes), so every room's floor, walls and ceiling go into the one ``arch`` and every
object of every room into ``object``.

A room's door is architecture, as SceneEval reads it: its hole in the wall (``"type": "Door"``),
never an object (an evaluator would count a leaf standing in its own doorway as an object out of
bounds that blocks the door). The door the simulator exports hang there rides on the hole as
``"leaf"``: how many leaves, the room they swing into, each hinge's world ``[x, y]``, the angle each
is delivered at and its limit (degrees); SceneEval ignores the key.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import structlog
import trimesh

from scenemosaic._memo import Memo
from scenemosaic.assets import (
    PartSpec,
    asset_fingerprint,
    object_articulation,
    part_openings,
    procedural_articulation,
    room_door_leaves,
    room_door_values,
)
from scenemosaic.exchange._glb import with_visual
from scenemosaic.render import object_local_mesh
from scenemosaic.scene import CEILING, FLOOR, FloatArray, House, Room, Scene, SceneObject, write_atomic

__all__ = [
    "LOCAL_TO_GLTF",
    "MAX_OBJECT_NAME_BYTES",
    "MODEL_ID_PREFIX",
    "SupportType",
    "export_sceneeval",
    "gltf_to_world",
    "house_sceneeval_state",
    "sceneeval_state",
    "support_type",
]

log = structlog.get_logger(__name__)

SupportType = Literal["ground", "object", "wall", "ceiling"]

MODEL_ID_PREFIX = "scenemosaic."
"""``modelId`` = prefix + assetId; SceneEval picks the asset source by the part before the dot."""
MAX_OBJECT_NAME_BYTES = 63
"""SceneEval names each object ``idx<index>_<modelId>``; Blender truncates names beyond 63 bytes."""
ASSET_HASH_CHARS = 10
"""Hex digits of the baked-mesh hash kept in an assetId."""

LOCAL_TO_GLTF = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
"""``Rx(-90°)``: our object frame (Z up, front -Y) -> glTF asset frame (Y up, front +Z)."""
GLTF_TO_LOCAL = LOCAL_TO_GLTF.T.copy()
"""``Rx(+90°)``, the inverse, the right-most factor of every object transform."""

_ASSET_CHARS = re.compile(r"[^A-Za-z0-9_.\-]+")
_HOLE_TYPES = {"door": "Door", "window": "Window", "opening": "Opening"}


def support_type(scene: Scene, obj: SceneObject) -> SupportType:
    """SceneEval's support type of an object, from its support relation.

    ``ceiling`` when attached to (hanging from) the ceiling, ``wall`` when attached to a wall,
    ``object`` when on or in another object, else ``ground`` (floor, or no support stated).
    """
    rel = scene.support_of(obj.id)
    if rel is None or rel.parent == FLOOR:
        return "ground"
    if rel.parent == CEILING:
        return "ceiling"
    kind = scene.anchor_kind(rel.parent)
    if kind == "wall":
        return "wall"
    if kind == "object":
        return "object"
    return "ground"


def gltf_to_world(obj: SceneObject) -> FloatArray:
    """The object's sceneState transform: rigid ``T · R · Rx(+90°)`` (4x4, row-major array)."""
    m: FloatArray = obj.pose.matrix(with_scale=False) @ GLTF_TO_LOCAL
    return m


def _column_major(m: FloatArray) -> list[float]:
    return [float(x) for x in np.asarray(m, dtype=np.float64).T.reshape(-1)]


def _mesh_digest(mesh: trimesh.Trimesh) -> str:
    h = hashlib.sha256()
    h.update(np.round(np.asarray(mesh.vertices, dtype=np.float64), 6).tobytes())
    h.update(np.asarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def _asset_id(category: str, digest: str, budget: int) -> str:
    slug = _ASSET_CHARS.sub("_", category).strip("_.-") or "object"
    room = budget - ASSET_HASH_CHARS - 1
    if room < 1:
        return digest[: max(budget, 1)]
    return f"{slug[:room]}_{digest[:ASSET_HASH_CHARS]}"


def _arch(scene: Scene) -> dict[str, Any] | None:
    if scene.room is None:
        return None
    return _arch_of(scene.room.id, [(scene.room.id, scene.room)], _door_records(scene))


def _arch_of(arch_id: str, rooms: list[tuple[str, Room]], doors: list[_DoorRecord]) -> dict[str, Any]:
    elements: list[dict[str, Any]] = []
    for room_id, room in rooms:
        elements += _room_elements(room_id, room, doors)
    return {
        "version": "arch@1.0.2",
        "id": arch_id,
        "up": [0, 0, 1],
        "front": [0, 1, 0],
        "coords2d": [0, 1],
        "scaleToMeters": 1,
        "elements": elements,
    }


@dataclass(frozen=True)
class _DoorRecord:
    """A room door as a hole of the arch carries it: where its leaves hang, and the record."""

    centre: FloatArray
    """The door's position in the world, XY (the middle of its doorway)."""
    record: dict[str, Any]


DOOR_MATCH_M = 0.2
"""How near a door hole's middle (on one room's wall) a hung door must stand to be that hole's."""


def _door_records(scene: Scene | House) -> list[_DoorRecord]:
    """The doors the simulator exports hang (:func:`~scenemosaic.assets.room_door_leaves`), as the
    sceneState writes them on their holes: ``leaves`` (1 or 2), ``swingsInto`` (a room id),
    ``hinges`` (each leaf's hinge line as a world ``[x, y]``), ``openDeg`` (the angle each leaf is
    delivered at, degrees) and ``limitDeg`` (how far it turns)."""
    doors = room_door_leaves(scene)
    values = room_door_values(scene, doors)
    out = []
    for door in doors:
        obj = door.object
        m = obj.pose.matrix(with_scale=False)
        parts = procedural_articulation(obj.category, obj.asset.extents)
        hinges = [[round(float(v), 6) + 0.0 for v in (m[:3, :3] @ np.asarray(p.anchor) + m[:3, 3])[:2]] for p in parts]
        record = {
            "leaves": len(parts),
            "swingsInto": door.room_id,
            "hinges": hinges,
            "openDeg": [round(math.degrees(values.get(obj.id, {}).get(p.name, 0.0)), 3) + 0.0 for p in parts],
            "limitDeg": [round(math.degrees(p.limits[1]), 3) for p in parts],
        }
        out.append(_DoorRecord(np.asarray(obj.pose.position[:2], dtype=np.float64), record))
    return out


def _room_elements(room_id: str, room: Room, doors: list[_DoorRecord]) -> list[dict[str, Any]]:
    """A room's ``Floor``, ``Wall`` (holes and all) and ``Ceiling`` elements, ids ``<room id>|...``;
    a door hole whose doorway has a door hung carries it as ``leaf`` (:func:`_door_records`): the
    door is part of the architecture, not an object."""
    floor3 = [[float(x), float(y), 0.0] for x, y in room.floor]
    elements: list[dict[str, Any]] = [
        {"id": f"{room_id}|floor", "type": "Floor", "roomId": room_id, "points": floor3}
    ]
    for wall in room.walls:
        holes = []
        for k, op in enumerate(wall.openings):
            a, b = wall.span(op)
            top = min(op.bottom + op.height, wall.height)
            if b <= a or top <= op.bottom:
                log.warning("opening_outside_wall", wall=wall.id, opening=k)
                continue
            hole: dict[str, Any] = {
                "id": f"{room_id}|{wall.id}|{op.kind}_{k}",
                "type": _HOLE_TYPES[op.kind],
                "box": {"min": [a, op.bottom], "max": [b, top]},
            }
            if op.kind == "door" and op.leaf_count > 0:
                middle = np.asarray(wall.start, dtype=np.float64) + wall.direction * op.center
                near = [d for d in doors if float(np.linalg.norm(d.centre - middle)) <= DOOR_MATCH_M]
                if near:
                    hole["leaf"] = min(near, key=lambda d: float(np.linalg.norm(d.centre - middle))).record
            holes.append(hole)
        elements.append({
            "id": f"{room_id}|{wall.id}",
            "type": "Wall",
            "roomId": room_id,
            "points": [[wall.start[0], wall.start[1], 0.0], [wall.end[0], wall.end[1], 0.0]],
            "height": wall.height,
            "depth": wall.thickness,
            "holes": holes,
        })  # fmt: skip
    elements.append({
        "id": f"{room_id}|ceiling",
        "type": "Ceiling",
        "roomId": room_id,
        "points": [[p[0], p[1], room.ceiling_height] for p in floor3],
    })  # fmt: skip
    return elements


def _part_record(part: PartSpec, value: float = 0.0) -> dict[str, Any]:
    """A movable part as the sceneState lists it: axis and anchor in the asset GLB's (glTF) frame;
    ``value``, the joint value it is delivered at, only when it is not 0 (the asset is closed)."""
    turn = LOCAL_TO_GLTF[:3, :3]
    record: dict[str, Any] = {
        "name": part.name,
        "kind": part.kind,
        "joint": part.joint,
        "axis": [round(float(v), 9) + 0.0 for v in turn @ np.asarray(part.axis)],
        "anchor": [round(float(v), 9) + 0.0 for v in turn @ np.asarray(part.anchor)],
        "limits": [float(v) for v in part.limits],
    }
    if value != 0.0:
        record["value"] = value
    return record


def _gltf_mesh(obj: SceneObject, base_dir: Path | None) -> tuple[trimesh.Trimesh, str]:
    """``obj``'s local mesh in the glTF asset frame, and its baked-mesh digest."""
    gltf = object_local_mesh(obj, base_dir).copy()
    gltf.apply_transform(LOCAL_TO_GLTF)
    return gltf, _mesh_digest(gltf)


_GLTF_MESHES: Memo[str, tuple[trimesh.Trimesh, str]] = Memo(4096)
""":func:`_gltf_mesh` by asset fingerprint (what it is a function of; a house's variants share
their furniture). Shared: only read (painting copies it)."""

_ASSET_GLBS: Memo[tuple[str, str], bytes] = Memo(4096)
"""An asset GLB painted in its category's colour, by (asset fingerprint, category): the bytes
depend on nothing else, and exporting them was most of a house's sceneState export."""

GlbKeys = dict[str, tuple[str, str]]
"""assetId -> the key of :data:`_ASSET_GLBS` its GLB is kept under (painted assets only)."""


def _state(
    state_id: str, rooms: list[Scene], arch: dict[str, Any] | None, base_dir: Path | None
) -> tuple[dict[str, Any], dict[str, trimesh.Trimesh]]:
    """The sceneState of the objects of ``rooms`` (in order, indexed across all of them) with ``arch``."""
    state, assets, _ = _keyed_state(state_id, rooms, arch, base_dir)
    return state, assets


def _keyed_state(
    state_id: str, rooms: list[Scene], arch: dict[str, Any] | None, base_dir: Path | None
) -> tuple[dict[str, Any], dict[str, trimesh.Trimesh], GlbKeys]:
    """:func:`_state`, with the keys of the painted assets' GLBs."""
    glb_keys: GlbKeys = {}
    n = sum(len(scene.objects) for scene in rooms)
    longest_prefix = len(f"idx{max(n - 1, 0)}_{MODEL_ID_PREFIX}".encode())
    budget = MAX_OBJECT_NAME_BYTES - longest_prefix
    assets: dict[str, trimesh.Trimesh] = {}
    by_key: dict[tuple[str, str], str] = {}
    objects: list[dict[str, Any]] = []
    for scene in rooms:
        openings = part_openings(scene)
        for obj in scene.objects:
            fingerprint = asset_fingerprint(obj, base_dir)
            gltf, digest = _GLTF_MESHES.get(fingerprint, functools.partial(_gltf_mesh, obj, base_dir))
            key = (obj.category, digest)
            asset_id = by_key.get(key)
            if asset_id is None:
                asset_id = _asset_id(obj.category, key[1], budget)
                if asset_id in assets:  # a category slug collision; the full digest keeps ids distinct
                    asset_id = _asset_id(f"{obj.category}_{key[1][ASSET_HASH_CHARS:]}", key[1], budget)
                painted = with_visual(gltf, obj.category)
                if painted is gltf:  # its own texture: a mesh of its own, as it always had
                    painted = _gltf_mesh(obj, base_dir)[0]
                else:  # painted in the category colour: its GLB is the same for every such object
                    glb_keys[asset_id] = (fingerprint, obj.category)
                assets[asset_id] = painted
                by_key[key] = asset_id
            objects.append({
                "id": obj.id,
                "index": len(objects),
                "modelId": MODEL_ID_PREFIX + asset_id,
                "category": obj.category,
                "transform": {"rows": 4, "cols": 4, "data": _column_major(gltf_to_world(obj))},
                "sceneeval": {"supportType": support_type(scene, obj)},
            })  # fmt: skip
            parts = object_articulation(obj, base_dir)
            if parts:
                opened = openings.get(obj.id, {})
                objects[-1]["parts"] = [_part_record(p, p.clamped(opened.get(p.name, 0.0))) for p in parts]
    body: dict[str, Any] = {
        "version": "scene@1.0.2",
        "id": state_id,
        "up": [0, 0, 1],
        "front": [0, 1, 0],
        "unit": 1.0,
    }
    if arch is not None:
        body["arch"] = arch
    else:
        log.warning("sceneeval_without_room", scene=state_id)
    body["object"] = objects
    return {"format": "sceneState", "scene": body}, assets, glb_keys


def sceneeval_state(
    scene: Scene, base_dir: Path | None = None
) -> tuple[dict[str, Any], dict[str, trimesh.Trimesh]]:
    """The sceneState document and the asset meshes it names (assetId -> glTF-frame mesh).

    Objects whose baked meshes (vertices to 1 µm, faces) and categories are equal share one
    asset. Asset meshes keep their own UV texture, else carry a PBR material of the category colour.
    """
    return _state(scene.id, [scene], _arch(scene), base_dir)


def house_sceneeval_state(
    house: House, base_dir: Path | None = None
) -> tuple[dict[str, Any], dict[str, trimesh.Trimesh]]:
    """A whole house as one sceneState document, and the asset meshes it names.

    The ``arch`` (id: the house's) holds every room's ``Floor``, ``Wall`` and ``Ceiling``
    elements, ``roomId`` being the room scene's id and element ids ``<room id>|floor``,
    ``<room id>|<wall id>``, ``<room id>|ceiling``; each room keeps its own walls, so a wall between
    two rooms appears once per side, on each room's floor edge, as SceneEval's rooms have it.
    ``object`` lists every object of every room, in room order (``index`` counts across the
    house); each object's ``supportType`` comes from its own room. Assets are shared as in
    :func:`sceneeval_state`.
    """
    state, assets, _ = _house_state(house, base_dir)
    return state, assets


def _house_state(
    house: House, base_dir: Path | None
) -> tuple[dict[str, Any], dict[str, trimesh.Trimesh], GlbKeys]:
    rooms = [(scene.id, scene.room) for scene in house.rooms if scene.room is not None]
    return _keyed_state(house.id, list(house.rooms), _arch_of(house.id, rooms, _door_records(house)), base_dir)


def _write(
    out_dir: str | Path,
    state: dict[str, Any],
    assets: dict[str, trimesh.Trimesh],
    count: int,
    glb_keys: GlbKeys | None = None,
) -> Path:
    out_dir = Path(out_dir)
    asset_dir = out_dir / "assets"
    asset_dir.mkdir(parents=True, exist_ok=True)
    categories = {o["modelId"][len(MODEL_ID_PREFIX) :]: o["category"] for o in state["scene"]["object"]}
    metadata: dict[str, dict[str, Any]] = {}
    for asset_id, mesh in sorted(assets.items()):
        key = (glb_keys or {}).get(asset_id)
        export = functools.partial(_glb_bytes, mesh)
        data = export() if key is None else _ASSET_GLBS.get(key, export)
        write_atomic(asset_dir / f"{asset_id}.glb", data)
        ext = [float(e) for e in mesh.extents]
        # glTF extents are (x, y up, z front); report them as our (x width, y depth, z height)
        metadata[asset_id] = {"category": categories[asset_id], "extents_m": [ext[0], ext[2], ext[1]]}
    write_atomic(asset_dir / "metadata.json", json.dumps(metadata, indent=2, sort_keys=True) + "\n")
    path = write_atomic(out_dir / "scene_base.json", json.dumps(state, indent=2) + "\n")
    log.info("sceneeval_exported", path=str(path), objects=count, assets=len(assets))
    return path


def _glb_bytes(mesh: trimesh.Trimesh) -> bytes:
    return cast(bytes, mesh.export(file_type="glb"))


def export_sceneeval(scene: Scene | House, out_dir: str | Path, base_dir: Path | None = None) -> Path:
    """Write ``out_dir/scene_base.json`` and ``out_dir/assets/<assetId>.glb``; return the JSON path.

    Also writes ``out_dir/assets/metadata.json`` (assetId -> category and size in metres), which
    an asset source for SceneEval can read for descriptions. A scene without a room gets no
    ``arch`` (SceneEval then builds its simple rectangular room around the objects).
    """
    if isinstance(scene, House):  # a whole house: every room in one world
        return _export_house_sceneeval(scene, out_dir, base_dir)
    state, assets, glb_keys = _keyed_state(scene.id, [scene], _arch(scene), base_dir)
    return _write(out_dir, state, assets, len(scene.objects), glb_keys)


def _export_house_sceneeval(house: House, out_dir: str | Path, base_dir: Path | None = None) -> Path:
    """Write a whole house as one sceneState (:func:`house_sceneeval_state`): ``out_dir/scene_base.json``
    and ``out_dir/assets/`` as :func:`export_sceneeval` writes them; return the JSON path."""
    state, assets, glb_keys = _house_state(house, base_dir)
    return _write(out_dir, state, assets, len(house.objects), glb_keys)

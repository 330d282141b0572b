"""Frame recovery: a reconstruction in the camera frame -> an ordinary Z-up :class:`~scenemosaic.scene.Scene`.

The world frame is the one of ``docs/conventions.md``: Z up along the floor's normal (gravity
from the floor plane), the floor at z = 0, the room's dominant horizontal direction along the
world axes, metres. Its origin is the floor point below the camera; the camera's pose in it is
kept in ``scene.metadata["camera"]``. Each object keeps the id its inventory entry gave it, so
label, mask, mesh and pose stay one identity.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.perception._image import Camera
from scenemosaic.perception._reconstruct import Reconstruction
from scenemosaic.scene import (
    ROOM_MARGIN,
    WALL_SNAP_GAP,
    AssetRef,
    FloatArray,
    FootprintItem,
    Pose,
    Provenance,
    Relation,
    Room,
    Scene,
    SceneObject,
    dominant_orientation,
    footprint_items,
    quat_from_yaw,
    recovered_ceiling,
    room_rectangle,
)

__all__ = ["CAMERA_CLEARANCE", "IMPORTER", "recover_frame"]

IMPORTER = "scenemosaic.perception"
CAMERA_CLEARANCE = 0.3
"""The photograph was taken from inside the room: the recovered room holds the camera's foot
with this much floor (metres) around it."""


def _floor_from_reconstruction(rec: Reconstruction) -> tuple[FloatArray, float, str]:
    """The floor's up normal in the camera frame and the camera's height above it."""
    if rec.floor_up is not None and rec.camera_height is not None:
        up = np.asarray(rec.floor_up, dtype=np.float64)
        return up / np.linalg.norm(up), float(rec.camera_height), "reconstructor"
    floor = [o for o in rec.objects if o.placement == "floor"]
    if not floor:
        raise ImportFormatError(
            "no object stands on the floor, so the floor plane (and with it gravity) cannot be found; "
            "mark at least one floor object in the inventory"
        )
    ups = np.array([o.rotation[:, 2] for o in floor])
    up = ups.mean(axis=0)
    up /= np.linalg.norm(up)
    heights = [-float(up @ o.position) for o in floor]
    return up, float(np.median(heights)), "objects"


def at_camera_height(rec: Reconstruction, height: float) -> tuple[Reconstruction, float]:
    """``rec`` scaled about the camera so the camera stands ``height`` metres above the floor (a
    height the user measured: a tripod, a phone's AR session). A single view fixes the room only
    up to one scale, which the reconstructor reads from the objects' usual sizes; a known height
    replaces that reading. Every place and size is multiplied by the same factor, returned too."""
    if not (math.isfinite(height) and height > 0.0):
        raise UsageError(f"the camera's height must be a positive number of metres, got {height!r}")
    _up, measured, _source = _floor_from_reconstruction(rec)
    if measured <= 1e-6:
        raise ImportFormatError(f"the reconstruction puts the camera {measured:.3f} m above the floor: it cannot be scaled to {height} m")
    k = height / measured
    objects = [
        dataclasses.replace(o, position=np.asarray(o.position, dtype=np.float64) * k, extents=(o.extents[0] * k, o.extents[1] * k, o.extents[2] * k))
        for o in rec.objects
    ]
    return dataclasses.replace(rec, objects=objects, camera_height=height if rec.camera_height is not None else None), k


def recover_frame(
    rec: Reconstruction,
    camera: Camera,
    *,
    scene_id: str = "photo",
    source: str = "",
    mesh_uris: Mapping[str, str] | None = None,
    metadata: Mapping[str, Any] | None = None,
) -> Scene:
    """The scene of a reconstruction (see the module's docstring). ``mesh_uris`` maps object ids to
    the files their meshes were written to (relative to the scene's folder); an object without
    one gets the procedural model of its category at its reconstructed size. Objects are set
    upright (only their yaw is kept); floor objects stand at z = 0. What an object was seen
    resting on becomes an ``attach`` relation (evidence for the support agent, as importers' are)."""
    if not rec.objects:
        raise ImportFormatError("the reconstruction holds no object: nothing to build a scene from", path=source or None)
    up, height, floor_source = _floor_from_reconstruction(rec)
    ahead = np.array([0.0, 0.0, 1.0]) - up[2] * up  # the camera's optical axis, levelled
    if np.linalg.norm(ahead) < 1e-6:  # looking straight down: any horizontal direction will do
        ahead = np.array([0.0, 1.0, 0.0]) - up[1] * up
    ahead /= np.linalg.norm(ahead)
    right = np.cross(ahead, up)
    floor_from_camera = np.stack([right, ahead, up])  # rows: the floor frame's axes in camera coordinates

    def to_floor(p: FloatArray) -> FloatArray:
        out: FloatArray = floor_from_camera @ p + np.array([0.0, 0.0, height])
        return out

    # first pass in the floor frame, then turn so the room's direction lies along the axes
    staged: list[tuple[Any, FloatArray, float]] = []
    for o in rec.objects:
        pos = to_floor(o.position)
        r = floor_from_camera @ o.rotation
        front = r @ np.array([0.0, -1.0, 0.0])
        yaw = math.atan2(front[0], -front[1])  # yaw whose front (local -Y) is this heading
        if o.placement == "floor":
            pos[2] = 0.0
        staged.append((o, pos, yaw))
    if rec.yaw_hint is not None:
        turn = -float(rec.yaw_hint)
    else:
        provisional = [
            SceneObject(id=o.id, category=o.category, asset=AssetRef(kind="box", extents=o.extents), pose=Pose.from_yaw(tuple(p), y))
            for o, p, y in staged
        ]
        turn = -dominant_orientation(provisional)
    c, s = math.cos(turn), math.sin(turn)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    uris = dict(mesh_uris or {})
    objects: list[SceneObject] = []
    for o, pos, yaw in staged:
        p = rz @ pos
        if not np.all(np.isfinite(p)):
            raise ImportFormatError(f"object {o.id!r} was reconstructed at a position that is not finite: {p.tolist()}")
        uri = uris.get(o.id)
        asset = (
            AssetRef(kind="mesh", uri=uri, extents=o.extents)
            if uri
            else AssetRef(kind="procedural", category=o.category, extents=o.extents)
        )
        objects.append(
            SceneObject(
                id=o.id,
                category=o.category,
                description=o.description,
                asset=asset,
                pose=Pose(position=(float(p[0]), float(p[1]), float(p[2])), quaternion=quat_from_yaw(math.remainder(yaw + turn, 2 * math.pi))),
            )
        )
    camera_pos = rz @ np.array([0.0, 0.0, height])
    world_from_camera = np.eye(4)
    world_from_camera[:3, :3] = rz @ floor_from_camera
    world_from_camera[:3, 3] = camera_pos
    items = footprint_items(objects)
    k = CAMERA_CLEARANCE
    foot = np.array([[camera_pos[0] - k, camera_pos[1] - k], [camera_pos[0] + k, camera_pos[1] + k]])
    items.append(FootprintItem(points=foot, yaw=0.0, category="camera", top=0.0, area=0.0))
    polygon, _area = room_rectangle(items, 0.0, margin=ROOM_MARGIN, snap_gap=WALL_SNAP_GAP)
    try:
        room = Room.from_polygon(polygon, ceiling_height=recovered_ceiling(items))
    except ValueError as exc:
        raise ImportFormatError(f"the room recovered from the photograph is unusable: {exc}", path=source or None) from exc
    meta: dict[str, Any] = {
        "camera": {
            "width": camera.width,
            "height": camera.height,
            "fx": camera.fx,
            "fy": camera.fy,
            "cx": camera.cx,
            "cy": camera.cy,
            "hfov_deg": round(camera.hfov_deg, 4),
            "focal_source": camera.source,
            "world_from_camera": [round(float(v), 9) for v in world_from_camera.ravel()],
            "frame": "OpenCV (x right, y down, z forward); world_from_camera is row-major 4x4",
            "height_m": round(height, 4),
            "floor_from": floor_source,
        }
    }
    meta.update(metadata or {})
    ids = {o.id for o in objects}
    relations = [
        Relation(kind="attach", child=o.id, parent=o.parent, source=IMPORTER)
        for o in rec.objects
        if o.parent is not None and o.parent in ids and o.parent != o.id
    ]
    return Scene(
        id=scene_id,
        room=room,
        objects=objects,
        relations=relations,
        metadata=meta,
        provenance=Provenance(source_format="image", source_path=source or None, importer=IMPORTER),
    )

"""World-space meshes of a scene: each object's visual mesh, and the room's floor, walls and ceiling.

Shared by the views in this package and by :mod:`scenemosaic.exchange`. All meshes here are in
the world frame (Z up, metres) unless a function says it returns a local-frame mesh.

Room geometry:

* the floor is a slab of :data:`FLOOR_THICKNESS` whose *top* is at z = 0;
* each wall is a slab of its ``thickness`` standing *outside* the floor polygon (on the side
  of its outward normal), from z = 0 to its ``height``, extended by its thickness past both
  ends so neighbouring walls close the corners; openings are cut out exactly, the wall being
  assembled from axis-aligned panels around them;
* the ceiling is a slab of :data:`CEILING_THICKNESS` whose *bottom* is at ``ceiling_height``.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import cast

import numpy as np
import shapely
import structlog
import trimesh

from scenemosaic.assets import object_mesh
from scenemosaic.exceptions import SceneValidationError
from scenemosaic.scene import Room, SceneObject, Wall

__all__ = [
    "CEILING_THICKNESS",
    "FLOOR_THICKNESS",
    "ceiling_mesh",
    "floor_mesh",
    "object_local_mesh",
    "object_world_mesh",
    "wall_mesh",
    "wall_panels",
]

log = structlog.get_logger(__name__)

FLOOR_THICKNESS = 0.05
"""Thickness of the exported floor slab, metres (its top face is the floor plane z = 0)."""
CEILING_THICKNESS = 0.05
"""Thickness of the exported ceiling slab, metres (its bottom face is at the ceiling height)."""

def object_local_mesh(obj: SceneObject, base_dir: Path | None = None) -> trimesh.Trimesh:
    """The object's visual mesh in its local frame, scaled so its bounds equal ``obj.size``.

    Origin at the bottom centre of the footprint, +Z up, front along local -Y; a copy of
    :func:`scenemosaic.assets.object_mesh`, safe to transform.
    """
    return object_mesh(obj, base_dir).copy()


def object_world_mesh(obj: SceneObject, base_dir: Path | None = None) -> trimesh.Trimesh:
    """The object's visual mesh placed in the world by its pose (rotation and translation)."""
    mesh = object_local_mesh(obj, base_dir)
    mesh.apply_transform(obj.pose.matrix(with_scale=False))
    return mesh


def _prism(polygon: list[tuple[float, float]], z0: float, z1: float) -> trimesh.Trimesh:
    """A closed vertical prism over a simple polygon, between heights ``z0 < z1``."""
    poly = shapely.Polygon(polygon)
    if not poly.is_valid or poly.area <= 0:
        raise SceneValidationError(f"floor polygon is not a simple polygon: {polygon}")
    tris = shapely.constrained_delaunay_triangles(poly)
    pts = np.asarray(polygon, dtype=np.float64)
    n = len(pts)
    index = {(round(float(x), 9), round(float(y), 9)): i for i, (x, y) in enumerate(pts)}
    caps: list[list[int]] = []
    for tri in tris.geoms:
        coords = list(tri.exterior.coords)[:3]
        ids = [index[(round(x, 9), round(y, 9))] for x, y in coords]
        a, b, c = (pts[i] for i in ids)
        if (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) < 0:
            ids = [ids[0], ids[2], ids[1]]
        caps.append(ids)
    vertices = np.vstack([np.c_[pts, np.full(n, z0)], np.c_[pts, np.full(n, z1)]])
    faces: list[list[int]] = []
    for i, j, k in caps:
        faces.append([n + i, n + j, n + k])  # top, counter-clockwise seen from above
        faces.append([i, k, j])  # bottom, facing down
    ccw = shapely.Polygon(polygon).exterior.is_ccw
    for i in range(n):
        j = (i + 1) % n
        if ccw:
            faces += [[i, j, n + j], [i, n + j, n + i]]
        else:
            faces += [[j, i, n + i], [j, n + i, n + j]]
    return trimesh.Trimesh(vertices=vertices, faces=np.asarray(faces, dtype=np.int64), process=False)


def floor_mesh(room: Room) -> trimesh.Trimesh:
    """The floor slab: the floor polygon from z = -:data:`FLOOR_THICKNESS` to 0."""
    return _prism(list(room.floor), -FLOOR_THICKNESS, 0.0)


def ceiling_mesh(room: Room) -> trimesh.Trimesh:
    """The ceiling slab: the floor polygon from ``ceiling_height`` up by :data:`CEILING_THICKNESS`."""
    h = room.ceiling_height
    return _prism(list(room.floor), h, h + CEILING_THICKNESS)


def wall_panels(wall: Wall) -> list[tuple[float, float, float, float]]:
    """The solid parts of a wall as rectangles ``(s0, s1, z0, z1)`` in (distance along the wall, height).

    The wall runs from ``-thickness`` to ``length + thickness`` along its direction (so that
    neighbours close the corners) and from 0 to ``height``; each opening, clipped to the wall,
    is left out. Columns between consecutive opening edges are split into the height intervals
    no opening covers, which is exact for any set of rectangular openings.
    """
    s_lo, s_hi = -wall.thickness, wall.length + wall.thickness
    holes: list[tuple[float, float, float, float]] = []
    for op in wall.openings:
        a = max(op.center - op.width / 2.0, 0.0)
        b = min(op.center + op.width / 2.0, wall.length)
        lo, hi = op.bottom, min(op.bottom + op.height, wall.height)
        if b - a > 1e-9 and hi - lo > 1e-9:
            holes.append((a, b, lo, hi))
    cuts = sorted({s_lo, s_hi, *(h[0] for h in holes), *(h[1] for h in holes)})
    panels: list[tuple[float, float, float, float]] = []
    for a, b in itertools.pairwise(cuts):
        if b - a <= 1e-9:
            continue
        mid = 0.5 * (a + b)
        covering = sorted((h[2], h[3]) for h in holes if h[0] <= mid <= h[1])
        z = 0.0
        for lo, hi in covering:
            if lo > z + 1e-9:
                panels.append((a, b, z, lo))
            z = max(z, hi)
        if wall.height > z + 1e-9:
            panels.append((a, b, z, wall.height))
    return panels


def wall_mesh(wall: Wall) -> trimesh.Trimesh:
    """The wall slab (see the module docstring) with its openings cut out, in world coordinates."""
    d = np.array([*wall.direction, 0.0])
    inward = np.array([*wall.inward_normal, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    start = np.array([wall.start[0], wall.start[1], 0.0])
    rot = np.eye(4)
    rot[:3, :3] = np.column_stack([d, inward, up])  # right-handed: d x inward = +z
    pieces = []
    for s0, s1, z0, z1 in wall_panels(wall):
        box = trimesh.creation.box(extents=(s1 - s0, wall.thickness, z1 - z0))
        m = rot.copy()
        m[:3, 3] = start + d * (s0 + s1) / 2.0 - inward * wall.thickness / 2.0 + up * (z0 + z1) / 2.0
        box.apply_transform(m)
        pieces.append(box)
    if not pieces:
        raise SceneValidationError(f"wall {wall.id!r} is entirely open")
    return cast(trimesh.Trimesh, trimesh.util.concatenate(pieces))

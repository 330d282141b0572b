"""World-space meshes of a scene: each object's visual mesh, and the room's floor, walls and ceiling.

Shared by the views in this package and by :mod:`scenemosaic.exchange`. All meshes here are in
the world frame (Z up, metres) unless a function says it returns a local-frame mesh.

Room geometry:

* the floor is a slab of :data:`FLOOR_THICKNESS` whose *top* is at z = 0;
* each wall is a slab of its ``thickness`` standing *outside* the floor polygon (on the side
  of its outward normal), from z = 0 to its ``height``, extended by its thickness past both
  ends so neighbouring walls close the corners; openings are cut out exactly, the wall being
  assembled from axis-aligned panels around them. Given its room (:func:`wall_ends`), a wall
  reaches past an end only where the floor turns away (a convex corner): past a reflex corner
  the extension would stand inside the room;
* the ceiling is a slab of :data:`CEILING_THICKNESS` whose *bottom* is at ``ceiling_height``.

In a house (:func:`house_wall_pieces`) two rooms on either side of one wall each describe it,
standing outside their own floor: the same slab twice. It is kept once, from the first room
that has it; a later room keeps only the parts no earlier wall already covers. And no wall
stands on any room's floor.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple, cast

import numpy as np
import numpy.typing as npt
import shapely
import shapely.affinity
import structlog
import trimesh

from scenemosaic._memo import Memo
from scenemosaic.assets import object_mesh, object_mesh_arrays
from scenemosaic.exceptions import SceneValidationError
from scenemosaic.scene import FloatArray, House, Room, SceneObject, Wall

__all__ = [
    "CEILING_THICKNESS",
    "FLOOR_THICKNESS",
    "SHARED_WALL_TOLERANCE_M",
    "WallPanel",
    "WallPiece",
    "ceiling_mesh",
    "floor_mesh",
    "house_wall_pieces",
    "moved_arrays",
    "object_local_mesh",
    "object_world_arrays",
    "object_world_mesh",
    "polygon_rectangles",
    "subtract_panels",
    "wall_ends",
    "wall_mesh",
    "wall_panels",
    "wall_pieces",
]

log = structlog.get_logger(__name__)

FLOOR_THICKNESS = 0.05
"""Thickness of the exported floor slab, metres (its top face is the floor plane z = 0)."""
CEILING_THICKNESS = 0.05
"""Thickness of the exported ceiling slab, metres (its bottom face is at the ceiling height)."""
SHARED_WALL_TOLERANCE_M = 1e-3
"""Two walls are one slab when they are parallel and their slabs' faces lie this close (metres);
panel pieces thinner than this, left over where two descriptions of a wall differ by rounding,
are dropped."""

WallPanel = tuple[float, float, float, float]
"""A solid rectangle of a wall, ``(s0, s1, z0, z1)``: distance along the wall from its start,
and height above the floor, metres."""


class WallPiece(NamedTuple):
    """One solid box of a wall, in the wall's frame (metres): ``s`` along the wall from its start,
    ``z`` up from the floor, ``w`` outward from the wall's line (the room side is ``w < 0``; a
    whole slab runs from 0 to the wall's thickness)."""

    s0: float
    s1: float
    z0: float
    z1: float
    w0: float
    w1: float


def object_local_mesh(obj: SceneObject, base_dir: Path | None = None) -> trimesh.Trimesh:
    """The object's visual mesh in its local frame, scaled so its bounds equal ``obj.size``.

    Origin at the bottom centre of the footprint, +Z up, front along local -Y; what
    :func:`scenemosaic.assets.object_mesh` gives (a fresh mesh: safe to transform).
    """
    return object_mesh(obj, base_dir)


def object_world_mesh(obj: SceneObject, base_dir: Path | None = None) -> trimesh.Trimesh:
    """The object's visual mesh placed in the world by its pose (rotation and translation)."""
    mesh = object_local_mesh(obj, base_dir)
    mesh.apply_transform(obj.pose.matrix(with_scale=False))
    return mesh


def object_world_arrays(
    obj: SceneObject, base_dir: Path | None = None
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """The vertices and faces of :func:`object_world_mesh`, the same numbers, without making a
    mesh: the shared local arrays (:func:`~scenemosaic.assets.object_mesh_arrays`) moved by
    :func:`moved_arrays`. May return the shared read-only arrays themselves."""
    vertices, faces = object_mesh_arrays(obj, base_dir)
    return moved_arrays(vertices, faces, obj.pose.matrix(with_scale=False))


def moved_arrays(
    vertices: FloatArray, faces: npt.NDArray[np.int64], matrix: FloatArray
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """A mesh's vertices and faces as ``Trimesh.apply_transform(matrix)`` leaves them, the same
    numbers (trimesh's own tests and point transform; the faces turned when ``matrix`` mirrors),
    without a mesh to copy and transform. Returns the given arrays themselves for the identity."""
    matrix = np.asanyarray(matrix, order="C", dtype=np.float64)
    if trimesh.util.allclose(matrix, _IDENTITY4, 1e-8):
        return vertices, faces
    moved = trimesh.transformations.transform_points(vertices, matrix=matrix)
    rotates = not trimesh.util.allclose(matrix[:3, :3], _IDENTITY3, atol=1e-6)
    if rotates and trimesh.transformations.flips_winding(matrix):  # type: ignore[no-untyped-call]
        faces = np.ascontiguousarray(np.fliplr(faces))
    return moved, faces


_IDENTITY3 = np.eye(3, dtype=np.float64)
_IDENTITY4 = np.eye(4, dtype=np.float64)


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


def wall_ends(room: Room, wall: Wall) -> tuple[float, float]:
    """How far (metres) the slab of ``wall`` reaches past its start and past its end.

    Its thickness where the floor turns away from the wall (a convex corner): the slab then
    closes the corner with its neighbour's. Nothing where the floor goes on past the end: a
    reflex corner, where the neighbour's slab already covers the corner and reaching on would put
    wall inside the room, or a straight one (the floor's edge runs on along the wall's line: the
    next wall continues this one), where reaching on would fill the next wall's door or window
    beside the seam.
    """
    floor = shapely.Polygon(room.floor)
    t = wall.thickness
    d, out = wall.direction, wall.outward_normal
    start, end = np.asarray(wall.start, dtype=np.float64), np.asarray(wall.end, dtype=np.float64)

    def reach(corner: np.ndarray, away: np.ndarray) -> float:
        behind = corner + away * (t / 2.0) + out * (t / 2.0)  # past the corner, behind the wall
        before = corner + away * (t / 2.0) - out * (t / 2.0)  # past the corner, in front of it
        runs_on = floor.contains(shapely.Point(behind)) or floor.contains(shapely.Point(before))
        return 0.0 if runs_on else t

    return reach(start, -d), reach(end, d)


def wall_panels(wall: Wall, ends: tuple[float, float] | None = None) -> list[WallPanel]:
    """The solid parts of a wall as rectangles ``(s0, s1, z0, z1)`` in (distance along the wall, height).

    The wall runs from ``-ends[0]`` to ``length + ends[1]`` along its direction (by default
    its thickness at both ends, so that neighbours close the corners; :func:`wall_ends` gives
    the room-aware reach) and from 0 to ``height``; each opening, clipped to the wall, is left
    out. Columns between consecutive opening edges are split into the height intervals no
    opening covers, which is exact for any set of rectangular openings.
    """
    before, after = ends if ends is not None else (wall.thickness, wall.thickness)
    s_lo, s_hi = -before, wall.length + after
    holes: list[tuple[float, float, float, float]] = []
    for op in wall.openings:
        a, b = wall.span(op)
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


def wall_pieces(wall: Wall, ends: tuple[float, float] | None = None) -> list[WallPiece]:
    """:func:`wall_panels` as boxes through the wall's whole thickness."""
    return [WallPiece(s0, s1, z0, z1, 0.0, wall.thickness) for s0, s1, z0, z1 in wall_panels(wall, ends)]


def wall_mesh(wall: Wall, pieces: Sequence[WallPiece] | None = None) -> trimesh.Trimesh:
    """The wall slab (see the module docstring) with its openings cut out, in world coordinates:
    one box per piece of ``pieces`` (default :func:`wall_pieces` of the wall alone)."""
    d = np.array([*wall.direction, 0.0])
    inward = np.array([*wall.inward_normal, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    start = np.array([wall.start[0], wall.start[1], 0.0])
    rot = np.eye(4)
    rot[:3, :3] = np.column_stack([d, inward, up])  # right-handed: d x inward = +z
    boxes = []
    for piece in wall_pieces(wall) if pieces is None else pieces:
        s0, s1, z0, z1, w0, w1 = piece
        box = trimesh.creation.box(extents=(s1 - s0, w1 - w0, z1 - z0))
        m = rot.copy()
        m[:3, 3] = start + d * (s0 + s1) / 2.0 - inward * (w0 + w1) / 2.0 + up * (z0 + z1) / 2.0
        box.apply_transform(m)
        boxes.append(box)
    if not boxes:
        raise SceneValidationError(f"wall {wall.id!r} is entirely open")
    return cast(trimesh.Trimesh, trimesh.util.concatenate(boxes))


def _union(intervals: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    merged: list[tuple[float, float]] = []
    for lo, hi in sorted(intervals):
        if merged and lo <= merged[-1][1] + 1e-9:
            merged[-1] = (merged[-1][0], max(merged[-1][1], hi))
        else:
            merged.append((lo, hi))
    return merged


def _minus(solid: list[tuple[float, float]], holes: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for lo, hi in solid:
        z = lo
        for h_lo, h_hi in holes:
            if h_hi <= z or h_lo >= hi:
                continue
            if h_lo - z >= SHARED_WALL_TOLERANCE_M:
                out.append((z, h_lo))
            z = max(z, h_hi)
        if hi - z >= SHARED_WALL_TOLERANCE_M:
            out.append((z, hi))
    return out


def subtract_panels(panels: Sequence[WallPanel], cover: Sequence[WallPanel]) -> list[WallPanel]:
    """The parts of ``panels`` that no rectangle of ``cover`` covers, as rectangles (same frame).

    Columns are cut at every edge along the wall; in each, the solid height intervals less the
    covered ones remain, and equal intervals of neighbouring columns are joined again. Pieces
    thinner than :data:`SHARED_WALL_TOLERANCE_M` either way are dropped.
    """
    if not panels:
        return []
    lo = min(p[0] for p in panels)
    hi = max(p[1] for p in panels)
    edges = {p[0] for p in panels} | {p[1] for p in panels}
    edges |= {min(max(c[i], lo), hi) for c in cover for i in (0, 1)}
    columns: list[tuple[float, float, list[tuple[float, float]]]] = []
    for a, b in itertools.pairwise(sorted(edges)):
        if b - a <= 1e-9:
            continue
        mid = 0.5 * (a + b)
        solid = _union([(p[2], p[3]) for p in panels if p[0] <= mid <= p[1]])
        holes = _union([(c[2], c[3]) for c in cover if c[0] <= mid <= c[1]])
        columns.append((a, b, _minus(solid, holes)))
    out: list[WallPanel] = []
    open_runs: dict[tuple[float, float], float] = {}  # a height interval -> where its run began
    last_end: float | None = None
    for a, b, rest in columns:
        touching = last_end is not None and abs(a - last_end) <= 1e-9
        current = {(round(z0, 9), round(z1, 9)): (z0, z1) for z0, z1 in rest}
        for key, start in list(open_runs.items()):
            if not touching or key not in current:
                out.append((start, last_end if last_end is not None else a, key[0], key[1]))
                del open_runs[key]
        for key in current:
            open_runs.setdefault(key, a)
        last_end = b
    for key, start in open_runs.items():
        assert last_end is not None
        out.append((start, last_end, key[0], key[1]))
    return sorted(p for p in out if p[1] - p[0] >= SHARED_WALL_TOLERANCE_M)


def _same_slab(first: Wall, second: Wall) -> tuple[float, float] | None:
    """``(offset, sign)`` with ``s_second = offset + sign * s_first`` when the two walls' slabs
    are one (parallel, faces within :data:`SHARED_WALL_TOLERANCE_M`), else ``None``."""
    cos = float(np.dot(first.direction, second.direction))
    if abs(cos) < 1.0 - 1e-6:
        return None
    gap = float(np.dot(np.subtract(first.start, second.start), second.outward_normal))
    facing = float(np.dot(first.outward_normal, second.outward_normal))
    # the first slab's band, in distances outward from the second wall's line
    band = (gap, gap + first.thickness) if facing > 0 else (gap - first.thickness, gap)
    tol = SHARED_WALL_TOLERANCE_M
    if abs(band[0]) > tol or abs(band[1] - second.thickness) > tol:
        return None
    offset = float(np.dot(np.subtract(first.start, second.start), second.direction))
    return offset, 1.0 if cos > 0 else -1.0


def polygon_rectangles(
    polygon: shapely.Geometry, strip: float = 0.1
) -> list[tuple[float, float, float, float]]:
    """Axis-aligned rectangles ``(x0, y0, x1, y1)`` inside ``polygon`` (or the polygons of a
    collection; lines and points are ignored) that cover it.

    The polygon is cut into vertical strips at its corners' x; a strip's piece bounded by
    horizontal edges is one exact rectangle. A piece under a slanted edge is cut into strips at
    most ``strip`` metres wide, each giving the largest rectangle inside it, so the cover stops
    just short of a slanted edge (never past it). Rectangles of neighbouring strips with equal
    heights are joined. Exact for rectilinear polygons (every ProcTHOR and Holodeck floor).
    """
    parts = [g for g in getattr(polygon, "geoms", [polygon]) if g.geom_type == "Polygon" and not g.is_empty]
    polygon = shapely.union_all(parts)
    xs = sorted({round(float(x), 9) for part in parts for x, _ in part.exterior.coords})
    rects: list[tuple[float, float, float, float]] = []

    def span(piece: shapely.Geometry, x: float) -> tuple[float, float] | None:
        cut = piece.intersection(shapely.LineString([(x, -1e9), (x, 1e9)]))
        if cut.is_empty:
            return None
        _, y0, _, y1 = cut.bounds
        return y0, y1

    for x0, x1 in itertools.pairwise(xs):
        band = polygon.intersection(shapely.box(x0, -1e9, x1, 1e9))
        for piece in getattr(band, "geoms", [band]):
            if piece.is_empty or piece.geom_type != "Polygon" or piece.area <= 1e-12:
                continue
            _, by0, _, by1 = piece.bounds
            if abs(piece.area - (x1 - x0) * (by1 - by0)) <= 1e-9:
                rects.append((x0, by0, x1, by1))
                continue
            n = max(1, math.ceil((x1 - x0) / strip))
            for k in range(n):
                a, b = x0 + (x1 - x0) * k / n, x0 + (x1 - x0) * (k + 1) / n
                left, right = span(piece, a), span(piece, b)
                if (
                    left is not None
                    and right is not None
                    and min(left[1], right[1]) - max(left[0], right[0]) > 1e-6
                ):
                    rects.append((a, max(left[0], right[0]), b, min(left[1], right[1])))
    rects.sort(key=lambda r: (round(r[1], 9), round(r[3], 9), r[0]))
    joined: list[tuple[float, float, float, float]] = []
    for r in rects:
        last = joined[-1] if joined else None
        if last is not None and max(abs(last[1] - r[1]), abs(last[3] - r[3]), abs(last[2] - r[0])) <= 1e-9:
            joined[-1] = (last[0], last[1], r[2], last[3])
        else:
            joined.append(r)
    return sorted(joined)


def _off_floors(wall: Wall, panels: list[WallPanel], floors: shapely.Geometry) -> list[WallPiece]:
    """The panels as boxes through the wall's thickness, less whatever stands on ``floors``.

    The slab's footprint, in the wall's ``(s, w)`` frame, minus the floors is cut into rectangles
    (:func:`polygon_rectangles`); each panel keeps its part over each rectangle.
    """
    t = wall.thickness
    whole = [WallPiece(s0, s1, z0, z1, 0.0, t) for s0, s1, z0, z1 in panels]
    if not panels:
        return whole
    lo, hi = min(p[0] for p in panels), max(p[1] for p in panels)
    start, d, out = np.asarray(wall.start, dtype=np.float64), wall.direction, wall.outward_normal
    corners = [start + d * s + out * w for s, w in ((lo, 0.0), (hi, 0.0), (hi, t), (lo, t))]
    footprint = shapely.Polygon([tuple(c) for c in corners])
    if footprint.intersection(floors).area <= SHARED_WALL_TOLERANCE_M**2:
        return whole
    # world -> wall frame: s = (p - start) . d, w = (p - start) . out
    a, b = float(d[0]), float(d[1])
    c, e = float(out[0]), float(out[1])
    x0 = -(a * start[0] + b * start[1])
    y0 = -(c * start[0] + e * start[1])
    rest = shapely.affinity.affine_transform(footprint.difference(floors), [a, b, c, e, x0, y0])
    pieces: list[WallPiece] = []
    for s0, w0, s1, w1 in polygon_rectangles(rest):
        if w1 - w0 < SHARED_WALL_TOLERANCE_M:
            continue
        for p0, p1, z0, z1 in panels:
            a0, a1 = max(s0, p0), min(s1, p1)
            if a1 - a0 >= SHARED_WALL_TOLERANCE_M:
                pieces.append(WallPiece(a0, a1, z0, z1, w0, w1))
    return sorted(pieces)


def house_wall_pieces(house: House) -> dict[tuple[str, str], list[WallPiece]]:
    """The walls of every room of a house as boxes: openings cut, each shared wall once, none on a floor.

    Keys are ``(room scene id, wall id)``, in the house's room order and each room's wall order.
    Each wall starts as its solid panels (:func:`wall_panels` with the room-aware
    :func:`wall_ends`, openings cut) and

    * keeps only what no earlier wall on the same slab already holds (:func:`subtract_panels`):
      a shared wall is kept from the first room that has it, solid where either room's wall is
      solid and open where both cut it (a doorway both rooms know); a wall wholly covered by an
      earlier one keeps nothing;
    * stands on no room's floor: where the slab reaches over another room's floor (at the small
      corners where three rooms meet) that part is cut away, through the wall's whole height.

    The pieces depend only on the rooms' shells, which a house's variants share: they are worked
    out once per process for each set of shells.
    """
    key = tuple((scene.id, scene.room.model_dump_json() if scene.room is not None else "") for scene in house.rooms)
    known = _HOUSE_WALL_PIECES.get(key, lambda: _house_wall_pieces(house))
    return {k: list(v) for k, v in known.items()}


_HOUSE_WALL_PIECES: Memo[tuple[tuple[str, str], ...], dict[tuple[str, str], list[WallPiece]]] = Memo(64)


def _house_wall_pieces(house: House) -> dict[tuple[str, str], list[WallPiece]]:
    floors = shapely.union_all([shapely.Polygon(s.room.floor) for s in house.rooms if s.room is not None])
    kept: list[tuple[Wall, list[WallPanel]]] = []
    out: dict[tuple[str, str], list[WallPiece]] = {}
    for scene in house.rooms:
        room = scene.room
        if room is None:
            continue
        for wall in room.walls:
            panels = wall_panels(wall, wall_ends(room, wall))
            lo = min((p[0] for p in panels), default=0.0)
            hi = max((p[1] for p in panels), default=0.0)
            cover: list[WallPanel] = []
            for other, other_panels in kept:
                mapping = _same_slab(other, wall)
                if mapping is None:
                    continue
                offset, sign = mapping
                for s0, s1, z0, z1 in other_panels:
                    a, b = sorted((offset + sign * s0, offset + sign * s1))
                    if b > lo + 1e-9 and a < hi - 1e-9:
                        cover.append((a, b, z0, z1))
            if cover:
                panels = subtract_panels(panels, cover)
            kept.append((wall, panels))
            out[(scene.id, wall.id)] = _off_floors(wall, panels, floors)
    return out

"""Collision shapes of scene objects: convex pieces in the object's local frame.

Pieces come from :func:`scenemosaic.assets.object_hulls` (procedural furniture gives exact
convex primitives, mesh assets CoACD pieces from the disk cache, ``box`` assets one box of the
object's size). Callers may also pass precomputed pieces per object id.

Each piece is reduced once to its convex-hull vertices and volume and kept in an
in-process cache keyed by the hash of its vertex bytes, so rebuilding a unit world for the
same objects costs no geometry work. Axis-aligned box pieces are recognized so that the
world builder can use MuJoCo's box primitive (much cheaper contacts than a mesh).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import structlog
import trimesh
from scipy.spatial import ConvexHull, QhullError

from scenemosaic._memo import Memo
from scenemosaic.assets import (
    PART_TAG,
    HullCache,
    PartSpec,
    asset_fingerprint,
    declared_tolerance,
    object_articulation,
    object_hulls,
    with_pieces,
)
from scenemosaic.scene import FloatArray, SceneObject

__all__ = ["BASE_BAND_M", "HullPiece", "ObjectShape", "hull_mesh", "object_shape", "piece_from_vertices"]

log = structlog.get_logger(__name__)

HullInput = Mapping[str, Sequence[Any]]
"""Precomputed pieces per object id: arrays of (n, 3) vertices or objects with ``.vertices``."""


@dataclass(frozen=True)
class HullPiece:
    """One convex piece in the object's local frame (already scaled)."""

    key: str
    """Hash of the piece's hull vertices (hex); names the MuJoCo mesh asset."""
    vertices: FloatArray
    """Convex-hull vertices, shape (n, 3)."""
    volume: float
    """Volume in m^3."""
    box: tuple[FloatArray, FloatArray] | None
    """``(centre, half_extents)`` when the piece is an axis-aligned box, else ``None``."""

    def mesh(self) -> trimesh.Trimesh:
        """The piece as a closed triangle mesh: :func:`hull_mesh` of its vertices."""
        return hull_mesh(self.vertices)


BASE_BAND_M = 0.02
"""Pieces whose bottom lies within this height of an object's lowest point are what it stands on (m)."""


@dataclass(frozen=True)
class ObjectShape:
    """All convex pieces of one object, with the local bounds they span."""

    pieces: tuple[HullPiece, ...]
    lower: FloatArray
    upper: FloatArray
    articulation: tuple[PartSpec, ...] = ()
    """The object's movable parts (:func:`scenemosaic.assets.object_articulation`), their
    ``pieces`` indexing :attr:`pieces`; empty for a rigid object. Worlds built with
    ``articulated=True`` give each part its own body on its joint; every other use (collision and
    bounds checks, unit settling) sees the pieces as they stand, closed."""

    def moving_pieces(self) -> set[int]:
        """Indices of the pieces that belong to a movable part."""
        return {i for part in self.articulation for i in part.pieces}

    @property
    def volume(self) -> float:
        return float(sum(p.volume for p in self.pieces))

    def world_vertices(self, matrix: FloatArray) -> list[FloatArray]:
        """Each piece's vertices under a 4x4 local-to-world transform (rotation + translation)."""
        r, t = matrix[:3, :3], matrix[:3, 3]
        return [p.vertices @ r.T + t for p in self.pieces]

    def base_vertices(self, band: float = BASE_BAND_M) -> FloatArray:
        """Local vertices of the pieces the object stands on: those reaching within ``band`` of
        its lowest point (a television's foot, a lamp's base, a whole box for a box)."""
        low = float(self.lower[2])
        base = [p.vertices for p in self.pieces if float(p.vertices[:, 2].min()) <= low + band]
        return np.concatenate(base) if base else np.concatenate([p.vertices for p in self.pieces])


def hull_mesh(vertices: Any) -> trimesh.Trimesh:
    """The convex hull of a point set as a triangle mesh: the solid a simulator makes of a
    vertex-only collision mesh (MuJoCo for mesh geoms, a "convexHull" approximation in USD)."""
    points = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    key = hashlib.sha1(points.tobytes()).hexdigest()
    hull_vertices, faces = _HULL_MESHES.get(key, lambda: _hull_arrays(points))
    return trimesh.Trimesh(vertices=hull_vertices.copy(), faces=faces.copy(), process=False)


def _hull_arrays(points: FloatArray) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """The hull's vertices (the input points it keeps, in their order) and its triangles wound
    outward (each turned to face away from the area-weighted centre of the triangles), zero-area
    triangles of a triangulated facet left out: what ``trimesh``'s ``convex_hull`` gives for
    distinct points, without building and repairing a mesh. Repeated points, or a set that qhull
    cannot take as it is, go through ``trimesh``."""
    try:
        if len(np.unique(np.round(points, _MERGE_DIGITS), axis=0)) != len(points):
            raise ValueError("repeated points")  # trimesh would merge them first
        hull = ConvexHull(points, qhull_options="QbB Pp Qt")
    except (QhullError, ValueError):
        mesh = trimesh.Trimesh(vertices=points).convex_hull
        return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
    kept = np.sort(hull.vertices)
    index = np.zeros(len(points), dtype=np.int64)
    index[kept] = np.arange(len(kept))
    faces = index[hull.simplices]
    hull_vertices = points[kept]
    corners = hull_vertices[faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = np.linalg.norm(cross, axis=1)
    solid = area > 0
    faces, cross, area, corners = faces[solid], cross[solid], area[solid], corners[solid]
    centres = corners.mean(axis=1)
    centroid = np.average(centres, weights=area, axis=0)
    inward = np.einsum("ij,ij->i", cross, centres - centroid) < 0
    faces[inward] = faces[inward][:, ::-1]
    return hull_vertices, faces


_MERGE_DIGITS = 8
"""Points equal to this many decimals are one point to ``trimesh`` (its merge tolerance, 1e-8 m)."""
_HULL_MESHES: Memo[str, tuple[FloatArray, npt.NDArray[np.int64]]] = Memo(8192)
"""Hull meshes (vertices, triangles) by their points' hash: the exporters ask again for every
variant of a scene."""
_PIECES: Memo[str, HullPiece] = Memo(1 << 16)
"""Convex pieces by their raw vertices' hash."""


def _as_box(v: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    lo, hi = v.min(axis=0), v.max(axis=0)
    if len(v) != 8 or np.any(hi - lo < 1e-9):
        return None
    on_faces = (np.abs(v - lo) < 1e-7) | (np.abs(v - hi) < 1e-7)
    if not bool(on_faces.all()):
        return None
    corners = {tuple(np.round((p - lo) / (hi - lo)).astype(int)) for p in v}
    if len(corners) != 8:
        return None
    return (lo + hi) / 2, (hi - lo) / 2


def piece_from_vertices(vertices: Any) -> HullPiece:
    """Reduce raw vertices to a cached convex piece (hull vertices, volume, box detection)."""
    v = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64).reshape(-1, 3))
    key = hashlib.sha1(v.tobytes()).hexdigest()[:16]
    return _PIECES.get(key, lambda: _reduce(v, key))


def _reduce(v: FloatArray, key: str) -> HullPiece:
    try:
        hull = ConvexHull(v)
        hv = v[hull.vertices]
        volume = float(hull.volume)
    except (QhullError, ValueError):  # flat or degenerate piece: keep its points, no volume
        hv = v
        volume = 0.0
    box = _as_box(hv)
    if box is not None:
        volume = float(np.prod(2 * box[1]))
    return HullPiece(key=key, vertices=hv, volume=volume, box=box)


def object_shape(
    obj: SceneObject,
    base_dir: str | Path | None = None,
    *,
    cache: HullCache | None = None,
    hulls: HullInput | None = None,
) -> ObjectShape:
    """The convex pieces of ``obj`` (local frame, scaled): ``hulls[obj.id]`` when given, else
    :func:`scenemosaic.assets.object_hulls` (which uses ``cache`` for mesh assets), with the
    object's movable parts (:func:`scenemosaic.assets.object_articulation`; dropped when the
    given pieces are not as many as the asset's own, since nothing then says which move)."""
    raw: Sequence[Any] | None = hulls.get(obj.id) if hulls is not None else None
    if not raw:
        key = (asset_fingerprint(obj, base_dir), "" if cache is None else str(cache.root))
        return _SHAPES.get(key, lambda: _own_shape(obj, base_dir, cache))
    pieces = tuple(piece_from_vertices(getattr(r, "vertices", r)) for r in raw)
    allv = np.concatenate([p.vertices for p in pieces])
    parts = _parts(obj, base_dir, pieces)
    if parts and len(raw) != len(object_shape(obj, base_dir, cache=cache).pieces):
        parts = ()  # pieces given that are not the asset's own: nothing says which of them move
    return ObjectShape(pieces=pieces, lower=allv.min(axis=0), upper=allv.max(axis=0), articulation=parts)


def _parts(
    obj: SceneObject,
    base_dir: str | Path | None,
    pieces: tuple[HullPiece, ...],
    owners: Sequence[str | None] | None = None,
) -> tuple[PartSpec, ...]:
    """The object's movable parts; those a mesh asset declares given their pieces: the ones
    ``owners`` (each piece's part, from the decomposition) names, else the ones in their boxes."""
    parts = object_articulation(obj, base_dir)
    if any(not part.pieces for part in parts):
        bounds = [(p.vertices.min(axis=0), p.vertices.max(axis=0)) for p in pieces]
        found = with_pieces(parts, bounds, declared_tolerance(obj.size), owners)
        for part in {p.name for p in parts} - {p.name for p in found}:
            log.warning("declared_part_without_pieces", object_id=obj.id, part=part)
        parts = found
    return tuple(parts)


def _own_shape(obj: SceneObject, base_dir: str | Path | None, cache: HullCache | None) -> ObjectShape:
    """The object's shape from its asset's own pieces (:func:`scenemosaic.assets.object_hulls`)."""
    raw = object_hulls(obj, base_dir, cache=cache)
    pieces = tuple(piece_from_vertices(r.vertices) for r in raw)
    allv = np.concatenate([p.vertices for p in pieces])
    parts = _parts(obj, base_dir, pieces, [r.metadata.get(PART_TAG) for r in raw])
    return ObjectShape(pieces=pieces, lower=allv.min(axis=0), upper=allv.max(axis=0), articulation=parts)


_SHAPES: Memo[tuple[str, str], ObjectShape] = Memo(4096)
"""Shapes from the assets' own pieces by (:func:`~scenemosaic.assets.asset_fingerprint`, hull
cache folder): every variant of a house, every stage and every export asks again for the same
furniture. An :class:`ObjectShape` is frozen and its arrays are shared: never modify them."""

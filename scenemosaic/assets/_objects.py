"""Visual meshes and convex collision pieces of scene objects, in the object's local frame.

Both are scaled so their bounds equal ``obj.size`` (``asset.extents * pose.scale``): x in
``[-w/2, w/2]``, y in ``[-d/2, d/2]``, z in ``[0, h]``, front toward -Y.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic.assets._articulation import PartSpec
from scenemosaic.assets._canonical import load_mesh, load_source_mesh, mesh_hash
from scenemosaic.assets._hulls import CoacdParams, HullCache
from scenemosaic.assets._procedural import procedural_articulation, procedural_mesh, procedural_parts
from scenemosaic.exceptions import AssetError, UnsafePathError
from scenemosaic.scene import SceneObject, confined_path, missing_file, real_path

__all__ = [
    "default_hull_cache",
    "object_articulation",
    "object_hulls",
    "object_mesh",
    "object_part_meshes",
]

log = structlog.get_logger(__name__)

FloatArray = npt.NDArray[np.float64]

_default_cache: HullCache | None = None


def default_hull_cache() -> HullCache:
    """The process-wide :class:`HullCache` used when none is passed (``default_cache_dir()/hulls``)."""
    global _default_cache
    if _default_cache is None:
        _default_cache = HullCache()
    return _default_cache


def _size(obj: SceneObject) -> tuple[float, float, float]:
    s = obj.size
    return (float(s[0]), float(s[1]), float(s[2]))


def _box_mesh(size: tuple[float, float, float]) -> trimesh.Trimesh:
    w, d, h = size
    box: trimesh.Trimesh = trimesh.creation.box(bounds=[[-w / 2, -d / 2, 0.0], [w / 2, d / 2, h]])
    return box


def _resolve(uri: str, base_dir: str | Path | None, obj: SceneObject) -> Path:
    """The mesh file of ``obj``: a relative uri must stay inside ``base_dir`` (symlinks followed);
    an absolute one is taken as it is, since the reader that produced it checked it."""
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    try:
        path = confined_path(base, uri) if not Path(uri).is_absolute() else real_path(uri)
    except UnsafePathError as exc:
        raise UnsafePathError(f"object {obj.id!r}: mesh uri {exc}", reference=uri, resolved=exc.resolved) from exc
    if path.is_dir():
        raise AssetError(f"object {obj.id!r}: mesh uri {uri!r} names a directory, not a file: {path}")
    if not path.is_file():  # false for a FIFO or a device too: never opened (a FIFO would wait for a writer)
        raise AssetError(f"object {obj.id!r}: mesh file {missing_file(path)}")
    return path


@functools.lru_cache(maxsize=32)
def _canonical_cached(
    path: str, mtime_ns: int, size: int, transform: tuple[float, ...] | None
) -> tuple[trimesh.Trimesh, str]:
    del mtime_ns, size  # cache key only
    if transform is None:
        canonical = load_mesh(path)
        return canonical.mesh, canonical.sha256
    mesh = load_source_mesh(path).copy()
    mesh.apply_transform(np.asarray(transform, dtype=np.float64).reshape(4, 4))
    return mesh, mesh_hash(mesh)


def _canonical(obj: SceneObject, base_dir: str | Path | None) -> trimesh.Trimesh:
    """The object's asset mesh in the canonical frame, unscaled (shared by a cache: do not modify)."""
    asset = obj.asset
    assert asset.uri is not None  # the scene model requires a uri for kind "mesh"
    path = _resolve(asset.uri, base_dir, obj)
    stat = path.stat()
    transform = (
        tuple(float(v) for v in asset.source_transform) if asset.source_transform is not None else None
    )
    mesh, digest = _canonical_cached(str(path), stat.st_mtime_ns, stat.st_size, transform)
    if asset.sha256 is not None and asset.sha256 != digest:
        log.warning(
            "asset_hash_mismatch", object_id=obj.id, path=str(path), expected=asset.sha256, actual=digest
        )
    return mesh


def _box_map(bounds: FloatArray, size: tuple[float, float, float]) -> tuple[FloatArray, FloatArray]:
    """Per-axis ``scale`` and ``offset`` taking ``bounds`` onto the object's box: ``v * scale + offset``."""
    lo, hi = np.asarray(bounds[0], dtype=np.float64), np.asarray(bounds[1], dtype=np.float64)
    target_lo = np.array([-size[0] / 2, -size[1] / 2, 0.0])
    target_hi = np.array([size[0] / 2, size[1] / 2, size[2]])
    extent = hi - lo
    if np.any(extent <= 0):
        raise AssetError(f"cannot scale a flat mesh (extents {extent.tolist()}) to {list(size)}")
    scale = (target_hi - target_lo) / extent
    return scale, target_lo - lo * scale


def object_mesh(obj: SceneObject, base_dir: str | Path | None = None) -> trimesh.Trimesh:
    """The object's visual mesh in its local frame, scaled so its bounds equal ``obj.size``.

    * ``asset.kind == "procedural"``: :func:`procedural_mesh` of ``asset.category or obj.category``.
    * ``"box"``: a box.
    * ``"mesh"``: the file ``asset.uri`` (relative to ``base_dir``, else the working directory, unless
      absolute), mapped by ``asset.source_transform`` when given or canonicalized by
      :func:`load_mesh` otherwise, then scaled per axis onto the object's box. Loaded files are
      cached in-process by path and modification time.

    Returns a fresh mesh (safe to modify).

    Raises:
        AssetError: the mesh file is missing, unreadable or degenerate.
    """
    size = _size(obj)
    kind = obj.asset.kind
    if kind == "procedural":
        return procedural_mesh(obj.asset.category or obj.category, size)
    if kind == "box":
        return _box_mesh(size)
    canonical = _canonical(obj, base_dir)
    scale, offset = _box_map(canonical.bounds, size)
    mesh = canonical.copy()
    matrix = np.diag([*scale, 1.0])
    matrix[:3, 3] = offset
    mesh.apply_transform(matrix)
    return mesh


def _clamp_piece(vertices: FloatArray, lo: FloatArray, hi: FloatArray) -> trimesh.Trimesh | None:
    """A convex piece clipped to the object's box (its hull re-taken), or ``None`` if nothing is left."""
    try:
        hull: trimesh.Trimesh = trimesh.convex.convex_hull(np.clip(vertices, lo, hi))
    except Exception:  # flattened against a face of the box
        return None
    return hull if float(hull.volume) > 0 else None


def object_hulls(
    obj: SceneObject,
    base_dir: str | Path | None = None,
    *,
    cache: HullCache | None = None,
    params: CoacdParams | None = None,
) -> list[trimesh.Trimesh]:
    """Convex collision pieces in the same local, scaled frame as :func:`object_mesh`.

    * ``"procedural"``: the library's parts, which are convex by construction (no CoACD), so their
      union's bounds equal ``obj.size`` exactly.
    * ``"box"``: one box.
    * ``"mesh"``: CoACD pieces of the canonical, *unscaled* mesh through ``cache`` (default
      :func:`default_hull_cache`), mapped by the same per-axis scale as the visual mesh and clipped
      to the object's box. Their union approximates the mesh, so its bounds may fall slightly short
      of ``obj.size``.

    Raises:
        AssetError: the mesh file is missing, unreadable or degenerate.
    """
    size = _size(obj)
    kind = obj.asset.kind
    if kind == "procedural":
        return procedural_parts(obj.asset.category or obj.category, size)
    if kind == "box":
        return [_box_mesh(size)]
    canonical = _canonical(obj, base_dir)
    pieces = (cache or default_hull_cache()).get(canonical, params or CoacdParams())
    scale, offset = _box_map(canonical.bounds, size)
    lo = np.array([-size[0] / 2, -size[1] / 2, 0.0])
    hi = np.array([size[0] / 2, size[1] / 2, size[2]])
    out: list[trimesh.Trimesh] = []
    for piece in pieces:
        clipped = _clamp_piece(np.asarray(piece.vertices) * scale + offset, lo, hi)
        if clipped is not None:
            out.append(clipped)
    if not out:
        log.warning("hulls_empty_using_box", object_id=obj.id)
        return [_box_mesh(size)]
    return out


def object_articulation(obj: SceneObject) -> list[PartSpec]:
    """The movable parts of ``obj`` (drawers, doors, lids) in its local, scaled frame, closed.

    A procedural asset's parts come from its builder (:func:`procedural_articulation`, for the
    object's size), their ``pieces`` indexing :func:`object_hulls`' list. A box has none. A mesh
    asset has none unless it declares them (not read from files yet: see ``docs/articulation.md``).
    """
    if obj.asset.kind != "procedural":
        return []
    return procedural_articulation(obj.asset.category or obj.category, _size(obj))


def object_part_meshes(
    obj: SceneObject, base_dir: str | Path | None = None
) -> dict[str | None, trimesh.Trimesh]:
    """The visual mesh of ``obj`` split by its movable parts: ``None`` -> what does not move (the
    carcass), each part's name -> its pieces, all in the object's local frame, closed. An object
    without movable parts gives ``{None: object_mesh(obj)}``.
    """
    parts = object_articulation(obj)
    if not parts:
        return {None: object_mesh(obj, base_dir)}
    pieces = procedural_parts(obj.asset.category or obj.category, _size(obj))
    moving = {i for part in parts for i in part.pieces}
    groups: dict[str | None, list[int]] = {None: [i for i in range(len(pieces)) if i not in moving]}
    for part in parts:
        groups[part.name] = list(part.pieces)
    out: dict[str | None, trimesh.Trimesh] = {}
    for name, indices in groups.items():
        if not indices:
            continue
        mesh = trimesh.util.concatenate([pieces[i] for i in indices])
        assert isinstance(mesh, trimesh.Trimesh)
        out[name] = mesh
    return out

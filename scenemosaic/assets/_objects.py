"""Visual meshes and convex collision pieces of scene objects, in the object's local frame.

Both are scaled so their bounds equal ``obj.size`` (``asset.extents * pose.scale``): x in
``[-w/2, w/2]``, y in ``[-d/2, d/2]``, z in ``[0, h]``, front toward -Y.
"""

from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic._memo import Memo
from scenemosaic.assets._articulation import PartSpec, declared_part
from scenemosaic.assets._canonical import load_mesh, load_source_mesh, mesh_hash
from scenemosaic.assets._files import PARTS_FILE_SUFFIX
from scenemosaic.assets._hulls import CoacdParams, HullCache
from scenemosaic.assets._procedural import procedural_articulation, procedural_mesh, procedural_parts
from scenemosaic.exceptions import AssetError, UnsafePathError
from scenemosaic.scene import SceneObject, confined_path, missing_file, real_path

__all__ = [
    "PART_TAG",
    "asset_fingerprint",
    "default_hull_cache",
    "object_articulation",
    "object_hulls",
    "object_mesh",
    "object_mesh_arrays",
    "object_part_arrays",
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


@functools.lru_cache(maxsize=256)
def _file_digest(path: str, mtime_ns: int, size: int) -> str:
    del mtime_ns, size  # cache key only: a rewritten file is read again
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def asset_fingerprint(obj: SceneObject, base_dir: str | Path | None = None) -> str:
    """A key (hex SHA-1) for everything the object's local geometry depends on: its asset
    reference (for a mesh, the file's content instead of its path), its category and its size.

    Two objects with equal fingerprints have equal :func:`object_mesh`, :func:`object_hulls` and
    :func:`object_articulation`, wherever their folders are: a house's variants share one
    fingerprint per piece of furniture, so what is derived from it (collision shapes, exported
    mesh files) is computed once. The pose, the id and the physical attributes are not part of it.

    Raises:
        AssetError: a mesh asset's file is missing or unreadable.
    """
    asset = obj.asset
    fields = [asset.model_dump_json(exclude={"uri"}), obj.category, repr(_size(obj))]
    if asset.kind == "mesh":
        assert asset.uri is not None  # the scene model requires a uri for kind "mesh"
        path = _resolve(asset.uri, base_dir, obj)
        stat = path.stat()
        fields.append(_file_digest(str(path), stat.st_mtime_ns, stat.st_size))
        declared = path.with_suffix(PARTS_FILE_SUFFIX)
        if declared.is_file():  # the parts it declares (object_articulation)
            fields.append(_file_digest(str(declared), declared.stat().st_mtime_ns, declared.stat().st_size))
    return hashlib.sha1("\n".join(fields).encode()).hexdigest()


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
      of ``obj.size``. A mesh that declares parts (``<stem>.parts.json``) is split first: the faces
      in each part's box are decomposed apart from the rest, so no piece spans a part and its
      carcass, each part's pieces tagged ``metadata["scenemosaic_part"]`` with its name.

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
    declared = _declared_parts(obj, base_dir)
    if declared:
        hulls = cache or default_hull_cache()
        return _declared_hulls(obj, canonical, declared, hulls, params or CoacdParams())
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


MAX_DECLARED_PARTS = 32
"""Most parts a mesh asset may declare (as many as a procedural model may have pieces)."""


@functools.lru_cache(maxsize=256)
def _declared_cached(
    path: str, mtime_ns: int, size: int, scale: tuple[float, float, float]
) -> tuple[PartSpec, ...]:
    del mtime_ns  # cache key only: a rewritten file is read again
    if size > 1_000_000:
        raise AssetError(f"{path}: a parts declaration of {size} bytes is too large (at most 1 MB)")
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AssetError(f"{path}: cannot read the parts declaration ({exc})") from exc
    records = data.get("parts") if isinstance(data, dict) else None
    if not isinstance(records, list) or not all(isinstance(r, dict) for r in records):
        raise AssetError(f"{path}: a parts declaration is an object whose 'parts' is a list of objects")
    if len(records) > MAX_DECLARED_PARTS:
        raise AssetError(f"{path}: {len(records)} parts declared, at most {MAX_DECLARED_PARTS}")
    try:
        specs = tuple(declared_part(record, scale) for record in records)
    except AssetError as exc:
        raise AssetError(f"{path}: {exc}") from exc
    names = [spec.name for spec in specs]
    if len(set(names)) != len(names):
        raise AssetError(f"{path}: two parts share a name ({', '.join(sorted(names))})")
    return specs


def _declared_parts(obj: SceneObject, base_dir: str | Path | None) -> list[PartSpec]:
    """The parts a mesh asset's ``<stem>.parts.json`` declares (``[]`` without one, or when the
    mesh itself cannot be found: reading the mesh reports that)."""
    assert obj.asset.uri is not None  # the scene model requires a uri for kind "mesh"
    try:
        mesh = _resolve(obj.asset.uri, base_dir, obj)
    except AssetError:
        return []
    if not mesh.with_suffix(PARTS_FILE_SUFFIX).is_file():
        return []
    # a link must not lead out of the mesh's folder
    path = confined_path(mesh.parent, mesh.with_suffix(PARTS_FILE_SUFFIX).name)
    stat = path.stat()
    sx, sy, sz = (float(v) for v in _size(obj) / np.asarray(obj.asset.extents, dtype=np.float64))
    return list(_declared_cached(str(path), stat.st_mtime_ns, stat.st_size, (sx, sy, sz)))


def object_articulation(obj: SceneObject, base_dir: str | Path | None = None) -> list[PartSpec]:
    """The movable parts of ``obj`` (drawers, doors, lids) in its local, scaled frame, closed.

    A procedural asset's parts come from its builder (:func:`procedural_articulation`, for the
    object's size), their ``pieces`` indexing :func:`object_hulls`' list. A box has none. A mesh
    asset has those its ``<stem>.parts.json`` declares beside the mesh file (``base_dir``
    resolves a relative uri, as for :func:`object_mesh`; see ``docs/articulation.md``), scaled
    with the object and with no ``pieces`` yet: :func:`~scenemosaic.assets.with_pieces` picks
    them among the convex pieces.

    Raises:
        AssetError: the declaration is malformed.
    """
    if obj.asset.kind == "mesh":
        return _declared_parts(obj, base_dir)
    if obj.asset.kind != "procedural":
        return []
    return procedural_articulation(obj.asset.category or obj.category, _size(obj))


def object_part_meshes(
    obj: SceneObject, base_dir: str | Path | None = None
) -> dict[str | None, trimesh.Trimesh]:
    """The visual mesh of ``obj`` split by its movable parts: ``None`` -> what does not move (the
    carcass), each part's name -> its pieces, all in the object's local frame, closed. An object
    without movable parts gives ``{None: object_mesh(obj)}``; a mesh asset's faces go to the
    first part whose box holds their centre.
    """
    parts = object_articulation(obj, base_dir)
    if not parts:
        return {None: object_mesh(obj, base_dir)}
    if obj.asset.kind == "mesh":
        return _split_by_boxes(object_mesh(obj, base_dir), parts, FACE_TOLERANCE_M)
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


MeshArrays = tuple[FloatArray, npt.NDArray[np.int64]]
"""A mesh as its vertices ``(V, 3)`` and triangles ``(F, 3)``, read-only (shared)."""

_MESH_ARRAYS: Memo[str, MeshArrays] = Memo(4096)
_PART_ARRAYS: Memo[str, dict[str | None, MeshArrays]] = Memo(4096)


def _frozen(mesh: trimesh.Trimesh) -> MeshArrays:
    vertices = np.array(mesh.vertices, dtype=np.float64)
    faces = np.array(mesh.faces, dtype=np.int64)
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


def object_mesh_arrays(obj: SceneObject, base_dir: str | Path | None = None) -> MeshArrays:
    """The vertices and faces of :func:`object_mesh` (the same numbers), read-only: made once per
    process for each :func:`asset_fingerprint`, so the exports that only read a mesh share one
    copy of it across a house's objects and variants instead of a fresh mesh each."""
    return _MESH_ARRAYS.get(asset_fingerprint(obj, base_dir), lambda: _frozen(object_mesh(obj, base_dir)))


def object_part_arrays(obj: SceneObject, base_dir: str | Path | None = None) -> dict[str | None, MeshArrays]:
    """:func:`object_part_meshes` as read-only vertices and faces (a new dict of shared arrays),
    made once per process for each :func:`asset_fingerprint` as :func:`object_mesh_arrays` is."""

    def make() -> dict[str | None, MeshArrays]:
        return {name: _frozen(mesh) for name, mesh in object_part_meshes(obj, base_dir).items()}

    return dict(_PART_ARRAYS.get(asset_fingerprint(obj, base_dir), make))


FACE_TOLERANCE_M = 1e-3
"""How far a face's centre may lie outside a declared part's box and still be the part's, metres."""
PART_TAG = "scenemosaic_part"
"""The ``metadata`` key of a mesh asset's convex piece that belongs to a declared part (its name)."""


def _declared_hulls(
    obj: SceneObject,
    canonical: trimesh.Trimesh,
    parts: list[PartSpec],
    cache: HullCache,
    params: CoacdParams,
) -> list[trimesh.Trimesh]:
    """The convex pieces of a mesh asset that declares ``parts``: its scaled mesh split by the
    parts' boxes, what does not move and each part decomposed apart, carcass first."""
    size = _size(obj)
    scale, offset = _box_map(canonical.bounds, size)
    vertices = np.asarray(canonical.vertices) * scale + offset
    mapped = trimesh.Trimesh(vertices=vertices, faces=np.asarray(canonical.faces), process=False)
    lo = np.array([-size[0] / 2, -size[1] / 2, 0.0])
    hi = np.array([size[0] / 2, size[1] / 2, size[2]])
    out: list[trimesh.Trimesh] = []
    for name, group in _split_by_boxes(mapped, parts, FACE_TOLERANCE_M).items():
        for piece in cache.get(group, params):
            clipped = _clamp_piece(np.asarray(piece.vertices), lo, hi)
            if clipped is not None:
                if name is not None:
                    clipped.metadata[PART_TAG] = name
                out.append(clipped)
    if not out:
        log.warning("hulls_empty_using_box", object_id=obj.id)
        return [_box_mesh(size)]
    return out


def _split_by_boxes(
    mesh: trimesh.Trimesh, parts: list[PartSpec], tol: float
) -> dict[str | None, trimesh.Trimesh]:
    """``mesh``'s faces by the first part whose box (grown by ``tol``) holds their centre; the
    rest under ``None``."""
    centres = np.asarray(mesh.triangles_center)
    owner = np.full(len(centres), -1)
    for k, part in enumerate(parts):
        x0, x1, y0, y1, z0, z1 = part.box
        lo, hi = np.array([x0, y0, z0]) - tol, np.array([x1, y1, z1]) + tol
        inside = np.all((centres >= lo) & (centres <= hi), axis=1)
        owner[inside & (owner == -1)] = k
    out: dict[str | None, trimesh.Trimesh] = {}
    for k, name in [(-1, None), *enumerate(part.name for part in parts)]:
        faces = np.flatnonzero(owner == k)
        if len(faces):
            piece = mesh.submesh([faces], append=True)
            assert isinstance(piece, trimesh.Trimesh)
            out[name] = piece
    return out

"""Mesh loading, canonicalization and content hashes.

The canonical frame of an asset is the object's local frame (``docs/assets.md``):
**Z up**, metres, origin at the **bottom centre of the XY footprint**, front along **-Y**.
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic.assets._files import MESH_SUFFIXES, referenced_files
from scenemosaic.exceptions import AssetError
from scenemosaic.scene import MAX_MESH_FACES, real_path

__all__ = [
    "GLTF_TO_Z_UP",
    "HASH_DECIMALS",
    "CanonicalMesh",
    "canonical_transform",
    "load_mesh",
    "load_source_mesh",
    "mesh_hash",
]

log = structlog.get_logger(__name__)

FloatArray = npt.NDArray[np.float64]

HASH_DECIMALS = 6
"""Vertices are rounded to 10**-6 (a micrometre for metric meshes) before hashing, so float noise
from loading or transforming does not change the hash."""

GLTF_TO_Z_UP: FloatArray = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
"""+90 degrees about X: ``(x, y, z) -> (x, -z, y)``. Y-up becomes Z-up and glTF's front (+Z) becomes -Y."""

_MIN_EXTENT = 1e-9
_Y_UP_SUFFIXES = frozenset({".gltf", ".glb"})
_LOAD_CACHE_SIZE = 32


@dataclass(frozen=True)
class CanonicalMesh:
    """A mesh in the canonical asset frame plus how it got there.

    Attributes:
        mesh: The mesh in the canonical frame: Z up, metres, origin at the bottom centre of
            its XY footprint, front along -Y.
        transform: 4x4 matrix mapping source-file coordinates to canonical coordinates.
        sha256: :func:`mesh_hash` of ``mesh`` (hex digest).
        extents: Size of ``mesh`` along x (width), y (depth), z (height), metres.
    """

    mesh: trimesh.Trimesh
    transform: FloatArray
    sha256: str
    extents: tuple[float, float, float]


def mesh_hash(mesh: trimesh.Trimesh) -> str:
    """A stable SHA-256 hex digest of a mesh's geometry (vertices and faces, in order).

    Vertices are rounded to ``HASH_DECIMALS`` decimals (as integers, so ``-0.0`` and ``0.0``
    agree); visuals, normals and metadata are ignored. Equal geometry loaded twice gives
    the same digest on every platform (little-endian fixed-width integers are hashed).
    """
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if not np.all(np.isfinite(vertices)):
        raise AssetError("cannot hash a mesh with non-finite vertices")
    quantized = np.rint(vertices * 10.0**HASH_DECIMALS).astype("<i8")
    digest = hashlib.sha256()
    digest.update(f"mesh-v1:{quantized.shape[0]}:{faces.shape[0]}:".encode())
    digest.update(np.ascontiguousarray(quantized).tobytes())
    digest.update(np.ascontiguousarray(faces.astype("<i8")).tobytes())
    return digest.hexdigest()


def _concatenate(loaded: object, path: Path) -> trimesh.Trimesh:
    """One Trimesh from whatever trimesh loaded: a mesh, or a scene flattened with its node transforms."""
    if isinstance(loaded, trimesh.Trimesh):
        return loaded
    if isinstance(loaded, trimesh.Scene):
        pieces: list[trimesh.Trimesh] = []
        for node in loaded.graph.nodes_geometry:
            matrix, geometry_name = loaded.graph[node]
            geometry = loaded.geometry.get(geometry_name)
            if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces) > 0:
                piece = geometry.copy()
                piece.apply_transform(matrix)
                pieces.append(piece)
        if not pieces:
            raise AssetError(f"{path}: file holds no triangle mesh")
        if len(pieces) == 1:
            return pieces[0]
        combined = trimesh.util.concatenate(pieces)
        if not isinstance(combined, trimesh.Trimesh):  # pragma: no cover - concatenate of meshes is a mesh
            raise AssetError(f"{path}: could not combine the meshes of the scene")
        return combined
    raise AssetError(f"{path}: file holds no triangle mesh (got {type(loaded).__name__})")


def _validate(mesh: trimesh.Trimesh, path: Path) -> None:
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if len(mesh.faces) == 0 or len(vertices) == 0:
        raise AssetError(f"{path}: mesh has no faces")
    if not np.all(np.isfinite(vertices)):
        raise AssetError(f"{path}: mesh has non-finite (NaN or inf) vertices")
    extents = np.ptp(vertices[np.unique(np.asarray(mesh.faces))], axis=0)
    if float(extents.min()) <= _MIN_EXTENT:
        raise AssetError(f"{path}: mesh is flat (extents {extents.round(9).tolist()})")
    if not float(mesh.area) > 0.0:
        raise AssetError(f"{path}: mesh has zero surface area")


@functools.lru_cache(maxsize=_LOAD_CACHE_SIZE)
def _load_cached(path: str, mtime_ns: int, size: int) -> trimesh.Trimesh:
    del mtime_ns, size  # part of the cache key only: an edited file is loaded again
    file = Path(path)
    # before trimesh opens anything: it would follow a texture uri wherever it points
    referenced_files(file)
    try:
        loaded = trimesh.load(file, process=False)
    except AssetError:
        raise
    except Exception as exc:  # trimesh raises many kinds on malformed input
        raise AssetError(f"{file}: cannot read mesh ({type(exc).__name__}: {exc})") from exc
    mesh = _concatenate(loaded, file)
    if len(mesh.faces) > MAX_MESH_FACES:
        raise AssetError(f"{file}: {len(mesh.faces)} faces; meshes may have at most {MAX_MESH_FACES}")
    _validate(mesh, file)
    mesh.remove_unreferenced_vertices()
    return mesh


def load_source_mesh(path: str | Path) -> trimesh.Trimesh:
    """The file's triangles in *source* coordinates, scenes flattened; validated, cached.

    The result is shared by an in-process LRU cache keyed by path, modification time and
    size: do not modify it in place (copy it first). Symlinks are followed; the files the mesh
    references (glTF buffers and images, OBJ materials and textures) must lie in its folder.

    Raises:
        AssetError: naming the file, when it is missing, a directory, empty, not a mesh type
            read here (:data:`MESH_SUFFIXES`), unreadable, degenerate, larger than
            ``MAX_MESH_FACES``, or references a file outside its folder
            (:class:`~scenemosaic.exceptions.UnsafePathError`, also for a symlink loop).
    """
    file = real_path(Path(path).expanduser())
    try:
        stat = file.stat()
    except OSError as exc:
        raise AssetError(f"{file}: cannot open mesh file ({exc.strerror or exc})") from exc
    if file.is_dir():
        raise AssetError(f"{file}: is a directory, not a mesh file")
    if not file.is_file():
        raise AssetError(f"{file}: not a regular file")
    if stat.st_size == 0:
        raise AssetError(f"{file}: empty mesh file (0 bytes)")
    if file.suffix.lower() not in MESH_SUFFIXES:
        kinds = ", ".join(sorted(MESH_SUFFIXES))
        raise AssetError(f"{file}: unsupported mesh file type {file.suffix or '(none)'!r}; use one of {kinds}")
    return _load_cached(str(file), stat.st_mtime_ns, stat.st_size)


def _resolve_up_axis(path: Path, up_axis: Literal["auto", "y", "z"]) -> Literal["y", "z"]:
    if up_axis == "auto":
        return "y" if path.suffix.lower() in _Y_UP_SUFFIXES else "z"
    if up_axis not in ("y", "z"):
        raise AssetError(f"{path}: up_axis must be 'auto', 'y' or 'z', got {up_axis!r}")
    return up_axis


def canonical_transform(
    vertices: FloatArray, *, up_axis: Literal["y", "z"] = "z", unit_scale: float = 1.0
) -> FloatArray:
    """The 4x4 source->canonical transform for these source vertices.

    Scales by ``unit_scale``, rotates Y-up to Z-up when ``up_axis == "y"`` (see
    :data:`GLTF_TO_Z_UP`), then translates so the bottom centre of the XY footprint is the origin.
    """
    rotate_scale = np.diag([unit_scale, unit_scale, unit_scale, 1.0])
    if up_axis == "y":
        rotate_scale = GLTF_TO_Z_UP @ rotate_scale
    moved = vertices @ rotate_scale[:3, :3].T
    lo, hi = moved.min(axis=0), moved.max(axis=0)
    translate = np.eye(4)
    translate[:3, 3] = [-(lo[0] + hi[0]) / 2.0, -(lo[1] + hi[1]) / 2.0, -lo[2]]
    return translate @ rotate_scale


def load_mesh(
    path: str | Path, *, up_axis: Literal["auto", "y", "z"] = "auto", unit_scale: float = 1.0
) -> CanonicalMesh:
    """Load a GLB/glTF/OBJ/PLY file and bring it into the canonical asset frame.

    Args:
        path: The mesh file. Scenes (glTF, multi-object OBJ) are flattened with their node transforms.
        up_axis: The file's up axis. ``"auto"`` means ``"y"`` for ``.gltf``/``.glb`` (Y-up by the
            glTF spec) and ``"z"`` otherwise. A Y-up file is turned by +90 degrees about X,
            ``(x, y, z) -> (x, -z, y)``, so its +Z front becomes our -Y front.
        unit_scale: Metres per source unit (0.01 for a file in centimetres).

    Returns:
        The canonical mesh (a fresh copy, safe to modify), the transform, its hash and extents.

    Raises:
        AssetError: naming the file: missing, a directory, empty, unreadable, no faces, NaN
            vertices, zero extent on an axis, too many faces, or a referenced file outside its
            folder (see :func:`load_source_mesh`).
    """
    file = real_path(Path(path).expanduser())
    if not (np.isfinite(unit_scale) and unit_scale > 0):
        raise AssetError(f"{file}: unit_scale must be a positive number, got {unit_scale!r}")
    axis = _resolve_up_axis(file, up_axis)
    source = load_source_mesh(file)
    transform = canonical_transform(
        np.asarray(source.vertices, dtype=np.float64), up_axis=axis, unit_scale=unit_scale
    )
    mesh = source.copy()
    mesh.apply_transform(transform)
    extents = mesh.extents
    log.debug(
        "mesh_loaded", path=str(file), up_axis=axis, faces=len(mesh.faces), extents=extents.round(4).tolist()
    )
    return CanonicalMesh(
        mesh=mesh,
        transform=transform,
        sha256=mesh_hash(mesh),
        extents=(float(extents[0]), float(extents[1]), float(extents[2])),
    )

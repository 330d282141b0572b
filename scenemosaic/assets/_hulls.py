"""Convex decomposition with CoACD, run in worker processes and cached on disk.

Cache layout (see ``docs/assets.md``)::

    <root>/<key[:2]>/<key>.npz      vertices_<i>, faces_<i> per convex piece, plus a JSON "meta" entry

``key = sha256(CACHE_FORMAT_VERSION, mesh_hash(mesh), params.cache_token())``. Files are written
to a temporary name in the same folder and renamed into place, so readers never see half a file.
A file that cannot be read back is logged, deleted and recomputed.

Processes share the cache: a computation holds an exclusive lock on ``<key>.lock`` (``fcntl.flock``,
POSIX only; elsewhere there is no lock and two processes may both compute), so a second process
asking for the same key waits, then reads the first one's result instead of computing it again.

Meshes with more than ``COACD_MAX_FACES`` triangles are decimated to that many before CoACD
whatever the parameters say; meshes beyond ``MAX_MESH_FACES`` are refused.

After CoACD the pieces are checked: when their union spans less than ``MIN_COVERAGE`` of the
mesh's extent on some axis (open, shell-like scans come back as slivers missing half the
object) or they number more than ``max(MAX_PIECES, params.max_convex_hull)``, the mesh's
single convex hull is used instead, with a logged warning. That outcome is deterministic for a
given key, so it is stored like any other result. The single hull is cut down to at most
``MAX_HULL_VERTICES`` vertices (a scan's hull can have hundreds of thousands).
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import io
import json
import os
import sys
import threading
import weakref
import zipfile
from concurrent.futures import Future
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import structlog
import trimesh

from scenemosaic._processes import WorkerError, WorkerExecutor
from scenemosaic.assets._canonical import mesh_hash
from scenemosaic.assets._coacd_worker import MODULE, RawPiece, decode_reply, encode_job
from scenemosaic.exceptions import AssetError
from scenemosaic.scene import COACD_MAX_FACES, MAX_HULL_VERTICES, MAX_MESH_FACES, write_atomic

__all__ = [
    "CACHE_FORMAT_VERSION",
    "MAX_PIECES",
    "MIN_COVERAGE",
    "CoacdParams",
    "HullCache",
    "default_cache_dir",
    "shutdown_workers",
]

log = structlog.get_logger(__name__)

FloatArray = npt.NDArray[np.float64]

CACHE_FORMAT_VERSION = "hulls-v3"
"""Part of every cache key: bump it when the stored format or the post-processing changes.

v2: the coverage / piece-count check after CoACD (see :func:`_quality_problem`).
v3: the single-hull fallback capped at ``MAX_HULL_VERTICES`` vertices; inputs above
``COACD_MAX_FACES`` decimated whatever ``simplify_faces`` says."""

MIN_COVERAGE = 0.9
"""Least fraction of the mesh's bounding-box extent, on every axis, that the union of the pieces'
bounds must span; below it the decomposition is replaced by the mesh's single convex hull."""

MAX_PIECES = 32
"""Most pieces accepted (or ``params.max_convex_hull`` when that is larger); each piece becomes a
physics geom, so dozens of them mean a decomposition gone wrong."""

_MIN_PIECE_VOLUME = 1e-12
"""Pieces with less volume (cubic metres for metric meshes) are dropped as degenerate slivers."""


def default_cache_dir() -> Path:
    """Root of scenemosaic's on-disk caches.

    ``$SCENEMOSAIC_CACHE`` when set, else ``$XDG_CACHE_HOME/scenemosaic``, else
    ``~/.cache/scenemosaic``. The hull cache lives in its ``hulls/`` folder.
    """
    env = os.environ.get("SCENEMOSAIC_CACHE")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "scenemosaic"


@dataclass(frozen=True)
class CoacdParams:
    """Settings of one CoACD decomposition; every field is part of the cache key.

    Attributes:
        threshold: Concavity threshold (0.01-1). Lower gives more, tighter pieces and runs longer;
            0.08 keeps furniture recognisable in about a dozen pieces.
        max_convex_hull: Most pieces to keep after merging (-1 = no limit). Each piece becomes a
            physics geom, so 16 keeps contact checks cheap.
        preprocess_resolution: Voxel resolution of CoACD's manifold pre-processing. 30 is enough
            for image-to-3D meshes, which are closed once their UV seams are merged.
        simplify_faces: Meshes with more faces are first reduced to about this many by quadric
            decimation (fast-simplification); 0 disables it. 40k-face meshes take minutes otherwise.
        seed: Seed of CoACD's random search, so results are reproducible.
        preprocess_mode: ``"auto"`` (remesh only non-manifold input), ``"on"`` or ``"off"``.
        resolution: Surface samples CoACD uses to measure concavity (CoACD's default, 2000).
        mcts_nodes: Children explored per node of the cutting-plane tree search (CoACD default 20).
        mcts_iterations: Tree-search iterations per cut (CoACD default 150); lower is faster and coarser.
        mcts_max_depth: Depth of the tree search (CoACD default 3).
        max_ch_vertex: Most vertices per convex piece (CoACD default 256; MuJoCo accepts more).
    """

    threshold: float = 0.08
    max_convex_hull: int = 16
    preprocess_resolution: int = 30
    simplify_faces: int = 4000
    seed: int = 0
    preprocess_mode: Literal["auto", "on", "off"] = "auto"
    resolution: int = 2000
    mcts_nodes: int = 20
    mcts_iterations: int = 150
    mcts_max_depth: int = 3
    max_ch_vertex: int = 256

    @classmethod
    def fast(cls) -> CoacdParams:
        """Coarser settings for previews and tests: a 1500-face input, half the surface samples and a
        shallower, narrower search. About 2.5x faster cold than the defaults on the shared SAM3D
        meshes (36 s instead of 92 s for all five on the 2-core machine), with the same piece cap."""
        return cls(simplify_faces=1500, resolution=1000, mcts_nodes=10, mcts_iterations=60, mcts_max_depth=2)

    def cache_token(self) -> str:
        """A canonical text of every field (sorted JSON), used in the cache key."""
        return json.dumps(asdict(self), sort_keys=True, separators=(",", ":"))


# --------------------------------------------------------------------------------------------
# worker processes: each cache's own, started on its first miss
# --------------------------------------------------------------------------------------------
def _worker_count() -> int:
    env = os.environ.get("SCENEMOSAIC_COACD_WORKERS")
    if env and env.isdigit() and int(env) > 0:
        return int(env)
    return max(1, min(4, (os.cpu_count() or 2) // 2))


_open_caches: weakref.WeakSet[HullCache] = weakref.WeakSet()


def shutdown_workers(*, wait: bool = False) -> None:
    """Stop the CoACD worker processes of every hull cache of this process, cancelling their jobs
    (a cache starts new ones on its next miss). For a process about to leave at once (the CLI on
    a signal); a run closes its own cache's workers itself (:meth:`HullCache.close`)."""
    del wait  # the workers are gone when this returns
    for cache in list(_open_caches):
        cache.close(cancel=True)


# --------------------------------------------------------------------------------------------
# cross-process lock: one lock file per cache key
# --------------------------------------------------------------------------------------------
if sys.platform == "win32":  # pragma: no cover - no flock; processes may then compute twice

    def _flock(fd: int) -> None:
        del fd

    def _funlock(fd: int) -> None:
        del fd

else:
    import fcntl

    def _flock(fd: int) -> None:
        fcntl.flock(fd, fcntl.LOCK_EX)  # blocks until the holder releases it or exits

    def _funlock(fd: int) -> None:
        fcntl.flock(fd, fcntl.LOCK_UN)


class _KeyLock:
    """An exclusive advisory lock on a file, held by this process while it computes one key.

    The kernel drops a ``flock`` when its holder dies, so a crashed computation never leaves
    the key locked. The lock file stays (deleting it would race with a process opening it).
    """

    def __init__(self, fd: int | None) -> None:
        self._fd = fd

    @classmethod
    def acquire(cls, path: Path) -> _KeyLock:
        """Wait for and take the lock; a cache folder that cannot be written gives a no-op lock."""
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            log.debug("hull_lock_unavailable", path=str(path), error=str(exc))
            return cls(None)
        try:
            _flock(fd)
        except BaseException:
            os.close(fd)
            raise
        return cls(fd)

    def release(self) -> None:
        """Let the next process in; safe to call more than once."""
        fd, self._fd = self._fd, None
        if fd is not None:
            try:
                _funlock(fd)
            finally:
                os.close(fd)


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------
def _geometry_only(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Vertices and faces only, with UV/normal seams merged: image-to-3D meshes are triangle soups
    split at every seam, which CoACD would treat as thousands of separate bodies."""
    out = trimesh.Trimesh(
        vertices=np.asarray(mesh.vertices, dtype=np.float64).copy(),
        faces=np.asarray(mesh.faces, dtype=np.int64).copy(),
        process=False,
    )
    out.merge_vertices(merge_tex=True, merge_norm=True)
    out.remove_unreferenced_vertices()
    return out


def _check_mesh(mesh: trimesh.Trimesh) -> None:
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if len(mesh.faces) == 0 or len(vertices) == 0:
        raise AssetError("cannot decompose a mesh without faces")
    if len(mesh.faces) > MAX_MESH_FACES:
        raise AssetError(f"cannot decompose a mesh of {len(mesh.faces)} faces; the maximum is {MAX_MESH_FACES}")
    if not np.all(np.isfinite(vertices)):
        raise AssetError("cannot decompose a mesh with non-finite vertices")
    extents = np.ptp(vertices, axis=0)
    if float(extents.min()) <= 1e-9:
        raise AssetError(f"cannot decompose a flat mesh (extents {extents.round(9).tolist()})")


def _clean(raw: list[RawPiece]) -> list[RawPiece]:
    """Re-hull every piece (closed, consistently wound, convex) and drop slivers."""
    out: list[RawPiece] = []
    for vertices, _faces in raw:
        if len(vertices) < 4 or not np.all(np.isfinite(vertices)):
            continue
        try:
            hull = trimesh.convex.convex_hull(vertices)
        except Exception:  # qhull refuses flat or duplicate point sets
            continue
        if float(hull.volume) > _MIN_PIECE_VOLUME:
            out.append((np.asarray(hull.vertices, dtype=np.float64), np.asarray(hull.faces, dtype=np.int64)))
    return out


def _quality_problem(pieces: list[RawPiece], mesh: trimesh.Trimesh, params: CoacdParams) -> str | None:
    """Why ``pieces`` are no usable stand-in for ``mesh`` (too few axes covered, too many pieces), or ``None``."""
    cap = max(MAX_PIECES, params.max_convex_hull)
    if len(pieces) > cap:
        return f"{len(pieces)} pieces, more than {cap}"
    points = np.concatenate([v for v, _ in pieces])
    extent = np.ptp(np.asarray(mesh.vertices, dtype=np.float64), axis=0)
    coverage = np.ptp(points, axis=0) / extent
    if float(coverage.min()) < MIN_COVERAGE:
        shown = ", ".join(f"{a} {c:.0%}" for a, c in zip("xyz", coverage, strict=True))
        return f"pieces span only {shown} of the mesh's extent (need {MIN_COVERAGE:.0%} on every axis)"
    return None


def _decimation_target(params: CoacdParams) -> int:
    """The face count CoACD's input is reduced to: ``params.simplify_faces``, but never above
    ``COACD_MAX_FACES`` (``simplify_faces=0`` would otherwise hand CoACD a whole scan)."""
    if 0 < params.simplify_faces <= COACD_MAX_FACES:
        return params.simplify_faces
    return COACD_MAX_FACES


def _spread_points(points: FloatArray, count: int) -> FloatArray:
    """``count`` of ``points`` spread over them: the extremes on each axis, then farthest-point
    sampling. Deterministic, and the chosen set keeps the points' bounding box."""
    chosen = list(dict.fromkeys(int(i) for i in (*points.argmin(axis=0), *points.argmax(axis=0))))
    nearest = np.full(len(points), np.inf)
    for i in chosen:  # one pass per point: no (n, k, 3) temporary for a million-vertex hull
        nearest = np.minimum(nearest, np.linalg.norm(points - points[i], axis=1))
    while len(chosen) < count:
        far = int(np.argmax(nearest))
        if nearest[far] <= 0.0:
            break
        chosen.append(far)
        nearest = np.minimum(nearest, np.linalg.norm(points - points[far], axis=1))
    picked: FloatArray = points[np.sort(np.asarray(chosen))]
    return picked


def _single_hull(mesh: trimesh.Trimesh) -> list[RawPiece]:
    """The mesh's convex hull as one piece, with at most ``MAX_HULL_VERTICES`` vertices.

    A bigger hull (a smooth scan's can have one vertex per input vertex) is replaced by the hull
    of that many of its vertices, spread over it: a little inside the exact hull, same bounds.
    """
    hull = mesh.convex_hull
    vertices = np.asarray(hull.vertices, dtype=np.float64)
    if len(vertices) > MAX_HULL_VERTICES:
        hull = trimesh.convex.convex_hull(_spread_points(vertices, MAX_HULL_VERTICES))
        log.info("fallback_hull_simplified", vertices_before=len(vertices), vertices_after=len(hull.vertices))
    return [(np.asarray(hull.vertices, dtype=np.float64), np.asarray(hull.faces, dtype=np.int64))]


def _to_meshes(raw: list[RawPiece]) -> list[trimesh.Trimesh]:
    return [trimesh.Trimesh(vertices=v.copy(), faces=f.copy(), process=False) for v, f in raw]


def _parse(data: object, key: str) -> list[RawPiece]:
    """The pieces stored in a loaded cache file; ``ValueError`` when anything is off."""
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ValueError("not an npz archive")
    with data:
        meta = json.loads(str(data["meta"]))  # JSONDecodeError is a ValueError
        if not isinstance(meta, dict) or meta.get("key") != key:
            raise ValueError("key recorded in the file does not match its name")
        count = int(meta["pieces"])
        if count < 1:
            raise ValueError("no pieces")
        pieces: list[RawPiece] = []
        for i in range(count):
            v = np.asarray(data[f"vertices_{i}"], dtype=np.float64)
            f = np.asarray(data[f"faces_{i}"], dtype=np.int64)
            if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
                raise ValueError(f"piece {i} has bad array shapes")
            if not np.all(np.isfinite(v)) or f.min() < 0 or f.max() >= len(v):
                raise ValueError(f"piece {i} has bad values")
            pieces.append((v, f))
    return pieces


# --------------------------------------------------------------------------------------------
# the cache
# --------------------------------------------------------------------------------------------
class HullCache:
    """Convex decompositions keyed by mesh content and CoACD settings, stored on disk.

    A miss runs CoACD in a worker *process* (never in the caller's thread, never on the event
    loop); concurrent requests for the same key share one computation, in this process through
    a shared future and across processes through a lock file per key (POSIX ``flock``): the
    second process waits for the first and reads its result. Degenerate meshes (no faces, NaN
    vertices, zero extent, more than ``MAX_MESH_FACES`` faces) raise
    :class:`~scenemosaic.exceptions.AssetError`. When
    CoACD itself fails (an error, a crashed worker, no usable piece) the result is the mesh's
    single convex hull, with a logged warning; that fallback is not stored, so a later run retries.
    When CoACD succeeds but its pieces cover less than :data:`MIN_COVERAGE` of the mesh's extent
    on some axis, or exceed the piece cap (:data:`MAX_PIECES`), the single convex hull is used as
    well (warning ``coacd_poor_pieces_using_convex_hull``) and stored, since CoACD would give the
    same pieces again.

    Attributes:
        root: Folder of the cache files.
        computations: Decompositions this instance started in a worker (misses that ran CoACD).
        disk_hits: Requests answered from a cache file (including one another process wrote
            while this one waited for its lock).
        fallbacks: Decompositions that fell back to the single convex hull.
        failures: Why CoACD failed, by cache key: each mesh whose decomposition fell back to the
            convex hull because CoACD could not run or gave nothing (not stored, so asked again
            later; :meth:`take_failures` hands each mesh over once).
    """

    def __init__(self, root: Path | None = None) -> None:
        self.root = Path(root) if root is not None else default_cache_dir() / "hulls"
        self.computations = 0
        self.disk_hits = 0
        self.fallbacks = 0
        self.failures: dict[str, str] = {}
        self._failures_taken: set[str] = set()
        self._lock = threading.Lock()
        self._inflight: dict[str, Future[list[RawPiece]]] = {}
        self._workers: WorkerExecutor | None = None
        self._workers_pid = 0
        self._finalizer: weakref.finalize[Any, HullCache] | None = None
        _open_caches.add(self)

    # -- worker processes ----------------------------------------------------------------------
    def _submit(self, vertices: FloatArray, faces: npt.NDArray[np.int64], options: dict[str, Any]) -> Future[list[RawPiece]]:
        """Hand one decomposition to this cache's CoACD workers (started on the first miss)."""
        with self._lock:
            if self._workers is None or self._workers_pid != os.getpid():  # a forked child starts its own
                self._workers, self._workers_pid = WorkerExecutor(MODULE, workers=_worker_count(), orphan="kill"), os.getpid()
                # a cache dropped without close() still lets its processes go
                self._finalizer = weakref.finalize(self, self._workers.close, cancel=True)
            workers = self._workers
        reply = workers.submit(encode_job(vertices, faces, options))
        pieces: Future[list[RawPiece]] = Future()
        pieces.set_running_or_notify_cancel()

        def decoded(done: Future[bytes]) -> None:
            try:
                pieces.set_result(decode_reply(done.result()))
            except BaseException as exc:
                pieces.set_exception(exc)

        reply.add_done_callback(decoded)
        return pieces

    def take_failures(self) -> list[str]:
        """Why CoACD failed, for each mesh not handed over by an earlier call: a run turns them
        into warnings (a mesh that fails again in a later stage is not counted twice)."""
        with self._lock:
            new = [k for k in self.failures if k not in self._failures_taken]
            self._failures_taken.update(new)
            return [self.failures[k] for k in new]

    def close(self, *, cancel: bool = False) -> None:
        """Let this cache's CoACD worker processes go (when their jobs are done, or at once with
        ``cancel``: those jobs then end as a convex-hull fallback). The cache stays usable: a later
        miss starts new workers. A run closes its cache when it ends."""
        with self._lock:
            workers, self._workers = self._workers, None
            finalizer, self._finalizer = self._finalizer, None
        if finalizer is not None:
            finalizer.detach()
        if workers is not None:
            workers.close(cancel=cancel)

    def __enter__(self) -> HullCache:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- keys and files ------------------------------------------------------------------------
    def key(self, mesh: trimesh.Trimesh, params: CoacdParams = CoacdParams()) -> str:
        """The cache key of ``mesh`` decomposed with ``params`` (hex SHA-256)."""
        text = f"{CACHE_FORMAT_VERSION}\n{mesh_hash(mesh)}\n{params.cache_token()}"
        return hashlib.sha256(text.encode()).hexdigest()

    def path_for(self, key: str) -> Path:
        """Where the decomposition with this key is stored."""
        return self.root / key[:2] / f"{key}.npz"

    def lock_path(self, key: str) -> Path:
        """The file a process locks while it computes the decomposition with this key."""
        return self.root / key[:2] / f"{key}.lock"

    def _read(self, key: str) -> list[RawPiece] | None:
        path = self.path_for(key)
        if not path.is_file():
            return None
        try:
            # our own handle: np.load leaks the one it opens when the zip directory is truncated
            with open(path, "rb") as fh:
                pieces = _parse(np.load(fh, allow_pickle=False), key)
        except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
            log.warning("hull_cache_corrupt", path=str(path), error=f"{type(exc).__name__}: {exc}")
            with contextlib.suppress(OSError):
                path.unlink()
            return None
        return pieces

    def _write(self, key: str, pieces: list[RawPiece], meta: dict[str, Any]) -> None:
        path = self.path_for(key)
        arrays: dict[str, Any] = {"meta": np.array(json.dumps({**meta, "key": key, "pieces": len(pieces)}))}
        for i, (v, f) in enumerate(pieces):
            arrays[f"vertices_{i}"] = v
            arrays[f"faces_{i}"] = f.astype(np.int32)
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **arrays)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(path, buffer.getvalue())
        except OSError as exc:  # a read-only or full disk costs a recomputation later, nothing more
            log.warning("hull_cache_write_failed", path=str(path), error=str(exc))

    # -- computing -----------------------------------------------------------------------------
    def _lookup(self, mesh: trimesh.Trimesh, params: CoacdParams) -> tuple[str, list[RawPiece] | None]:
        _check_mesh(mesh)
        key = self.key(mesh, params)
        pieces = self._read(key)
        if pieces is not None:
            with self._lock:
                self.disk_hits += 1
        return key, pieces

    def _start(self, key: str, mesh: trimesh.Trimesh, params: CoacdParams) -> Future[list[RawPiece]]:
        with self._lock:
            running = self._inflight.get(key)
            if running is not None:
                return running
            outer: Future[list[RawPiece]] = Future()
            outer.set_running_or_notify_cancel()  # waiters cannot cancel a computation others share
            self._inflight[key] = outer
        try:
            # another process may be computing this key: wait for it, then take its result
            file_lock = _KeyLock.acquire(self.lock_path(key))
            try:
                pieces = self._read(key)
            except BaseException:
                file_lock.release()
                raise
        except BaseException as exc:
            self._settle(key, outer, error=exc)
            return outer
        if pieces is not None:
            file_lock.release()
            with self._lock:
                self.disk_hits += 1
            self._settle(key, outer, pieces=pieces)
            return outer
        with self._lock:
            self.computations += 1
        try:
            geometry = _geometry_only(mesh)
            options = {**asdict(params), "simplify_faces": _decimation_target(params)}
            log.info("coacd_start", key=key[:16], faces=len(geometry.faces), params=options)
        except BaseException as exc:
            file_lock.release()
            self._settle(key, outer, error=exc)
            return outer
        try:
            work = self._submit(np.asarray(geometry.vertices), np.asarray(geometry.faces), options)
        except (WorkerError, OSError) as exc:  # no worker could start: the convex hull, said below
            self._finish(key, geometry, params, None, outer, file_lock, error=exc)
            return outer
        except BaseException as exc:
            file_lock.release()
            self._settle(key, outer, error=exc)
            return outer
        work.add_done_callback(lambda done: self._finish(key, geometry, params, done, outer, file_lock))
        return outer

    def _settle(
        self,
        key: str,
        outer: Future[list[RawPiece]],
        *,
        pieces: list[RawPiece] | None = None,
        error: BaseException | None = None,
    ) -> None:
        """Give the shared future its result (or error) and forget the key as in flight."""
        with self._lock:
            self._inflight.pop(key, None)
        if error is not None:
            outer.set_exception(error)
        else:
            outer.set_result(pieces if pieces is not None else [])

    def _finish(
        self,
        key: str,
        geometry: trimesh.Trimesh,
        params: CoacdParams,
        done: Future[list[RawPiece]] | None,
        outer: Future[list[RawPiece]],
        file_lock: _KeyLock,
        *,
        error: BaseException | None = None,
    ) -> None:
        try:
            pieces: list[RawPiece] = []
            if done is not None and done.cancelled():
                error = RuntimeError("the CoACD job was cancelled (its workers were closed)")
            elif done is not None:
                error = done.exception()
                if error is None:
                    pieces = _clean(done.result())
                    if not pieces:
                        error = AssetError("CoACD returned no usable convex piece")
            if error is None:
                meta: dict[str, Any] = {"params": asdict(params), "source_faces": len(geometry.faces)}
                problem = _quality_problem(pieces, geometry, params)
                if problem is not None:
                    with self._lock:
                        self.fallbacks += 1
                    log.warning("coacd_poor_pieces_using_convex_hull", key=key[:16], problem=problem)
                    pieces = _single_hull(geometry)
                    meta["fallback"] = problem
                self._write(key, pieces, meta)
                log.info("coacd_done", key=key[:16], pieces=len(pieces))
            else:
                with self._lock:
                    self.fallbacks += 1
                    self.failures.setdefault(key, f"{type(error).__name__}: {error}")
                log.warning(
                    "coacd_failed_using_convex_hull",
                    key=key[:16],
                    error=f"{type(error).__name__}: {error}",
                )
                pieces = _single_hull(geometry)
            outer.set_result(pieces)
        except BaseException as exc:
            outer.set_exception(exc)
        finally:
            file_lock.release()  # after the write: a waiting process then finds the file
            with self._lock:
                self._inflight.pop(key, None)

    # -- public --------------------------------------------------------------------------------
    def get(self, mesh: trimesh.Trimesh, params: CoacdParams = CoacdParams()) -> list[trimesh.Trimesh]:
        """Convex pieces of ``mesh`` (in its own coordinates): from disk, or computed in a worker.

        Blocks until the pieces are ready. Returns fresh meshes (safe to modify).

        Raises:
            AssetError: when the mesh is degenerate (no faces, NaN vertices, zero extent).
        """
        key, pieces = self._lookup(mesh, params)
        if pieces is None:
            pieces = self._start(key, mesh, params).result()
        return _to_meshes(pieces)

    async def aget(self, mesh: trimesh.Trimesh, params: CoacdParams = CoacdParams()) -> list[trimesh.Trimesh]:
        """Like :meth:`get`, without blocking the event loop.

        Hashing and disk reads run in a thread; CoACD runs in a worker process.
        """
        key, pieces = await asyncio.to_thread(self._lookup, mesh, params)
        if pieces is None:
            outer = await asyncio.to_thread(self._start, key, mesh, params)
            pieces = await asyncio.wrap_future(outer)
        return _to_meshes(pieces)

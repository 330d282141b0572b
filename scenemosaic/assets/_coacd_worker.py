"""The code that runs inside a CoACD worker process.

Kept apart from the cache so the worker imports only numpy, coacd and fast-simplification.
Everything here is a plain function of arrays, so it pickles across the process boundary.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["decompose"]

RawPiece = tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Send file descriptor 1 to /dev/null: CoACD's C++ logger writes there directly.

    Only used inside the worker process, whose stdout nobody reads.
    """
    try:
        saved = os.dup(1)
    except OSError:  # no stdout at all
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def _simplify(
    vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], target_faces: int
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    if target_faces <= 0 or len(faces) <= target_faces:
        return vertices, faces
    import fast_simplification

    reduction = 1.0 - target_faces / len(faces)
    out_v, out_f = fast_simplification.simplify(
        vertices.astype(np.float32), faces.astype(np.int64), target_reduction=reduction
    )[:2]
    if len(out_f) < 4:  # simplification collapsed the mesh: decompose the original instead
        return vertices, faces
    return np.asarray(out_v, dtype=np.float64), np.asarray(out_f, dtype=np.int64)


def decompose(
    vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], options: dict[str, Any]
) -> list[RawPiece]:
    """Simplify (when ``options["simplify_faces"]`` is exceeded) and run CoACD; return raw pieces.

    ``options`` holds the :class:`~scenemosaic.assets.CoacdParams` fields.
    """
    import coacd

    coacd.set_log_level("error")
    v, f = _simplify(vertices, faces, int(options["simplify_faces"]))
    with _quiet_stdout():
        result = coacd.run_coacd(
            coacd.Mesh(np.ascontiguousarray(v, dtype=np.float64), np.ascontiguousarray(f, dtype=np.int32)),
            threshold=float(options["threshold"]),
            max_convex_hull=int(options["max_convex_hull"]),
            preprocess_mode=str(options["preprocess_mode"]),
            preprocess_resolution=int(options["preprocess_resolution"]),
            resolution=int(options["resolution"]),
            mcts_nodes=int(options["mcts_nodes"]),
            mcts_iterations=int(options["mcts_iterations"]),
            mcts_max_depth=int(options["mcts_max_depth"]),
            max_ch_vertex=int(options["max_ch_vertex"]),
            seed=int(options["seed"]),
        )
    return [(np.asarray(pv, dtype=np.float64), np.asarray(pf, dtype=np.int64)) for pv, pf in result]

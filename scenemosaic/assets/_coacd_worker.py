"""The code that runs inside a CoACD worker process: ``python -m scenemosaic.assets._coacd_worker REPLY_FD PARENT_PID``.

The hull cache (``assets/_hulls.py``) hands each decomposition to a worker of the package's own
(``scenemosaic._processes.WorkerExecutor``): a fresh interpreter that runs this module, never the
caller's ``__main__`` (a user's script without an ``if __name__ == "__main__":`` guard runs once),
and that dies with the process that started it. One job a line on stdin, one reply a line:
:func:`encode_job` / :func:`decode_job` and :func:`encode_reply` / :func:`decode_reply` carry the
arrays (``npz``, base64) and the CoACD options.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["MODULE", "decode_job", "decode_reply", "decompose", "encode_job", "encode_reply"]

MODULE = "scenemosaic.assets._coacd_worker"
"""The module a CoACD worker process runs (``python -m``)."""

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


def _pack(arrays: dict[str, npt.NDArray[np.generic]]) -> str:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)  # type: ignore[arg-type]
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _unpack(text: str) -> dict[str, npt.NDArray[np.generic]]:
    with np.load(io.BytesIO(base64.b64decode(text)), allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def encode_job(vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], options: dict[str, Any]) -> bytes:
    """One decomposition as the line a worker reads."""
    mesh = _pack({"vertices": np.asarray(vertices, dtype=np.float64), "faces": np.asarray(faces, dtype=np.int64)})
    return json.dumps({"mesh": mesh, "options": options}).encode()


def decode_job(line: bytes) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], dict[str, Any]]:
    """The arrays and options of a job line (:func:`encode_job`)."""
    job = json.loads(line)
    arrays = _unpack(job["mesh"])
    return np.asarray(arrays["vertices"], np.float64), np.asarray(arrays["faces"], np.int64), dict(job["options"])


def encode_reply(pieces: list[RawPiece] | None = None, error: str | None = None) -> bytes:
    """A worker's reply line: the pieces, or why there are none."""
    if error is not None:
        return json.dumps({"error": error}).encode()
    arrays: dict[str, npt.NDArray[np.generic]] = {}
    for i, (v, f) in enumerate(pieces or []):
        arrays[f"v{i}"], arrays[f"f{i}"] = v, f
    return json.dumps({"pieces": len(pieces or []), "arrays": _pack(arrays)}).encode()


def decode_reply(line: bytes) -> list[RawPiece]:
    """The pieces of a reply line (:func:`encode_reply`); ``RuntimeError`` with the worker's error."""
    reply = json.loads(line)
    if "error" in reply:
        raise RuntimeError(str(reply["error"]))
    arrays = _unpack(reply["arrays"])
    return [
        (np.asarray(arrays[f"v{i}"], np.float64), np.asarray(arrays[f"f{i}"], np.int64)) for i in range(int(reply["pieces"]))
    ]


def _answer(line: bytes) -> bytes:
    try:
        return encode_reply(decompose(*decode_job(line)))
    except Exception as exc:  # the parent falls back to the convex hull and says why
        return encode_reply(error=f"{type(exc).__name__}: {exc}")


def main(argv: list[str]) -> int:
    """The worker's loop (see the module docstring)."""
    from scenemosaic._processes import serve_lines

    serve_lines(argv, _answer, orphan="kill")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

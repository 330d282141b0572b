"""Two processes asking for the same decomposition: one computes, the other waits for its lock file
and reads the result (POSIX ``flock``)."""

from __future__ import annotations

import multiprocessing
import sys
from pathlib import Path
from typing import Any

import pytest
import trimesh

# coarse settings: the test is about who computes, not about the pieces
PARAMS: dict[str, Any] = {
    "threshold": 0.2,
    "max_convex_hull": 4,
    "preprocess_resolution": 20,
    "simplify_faces": 300,
    "resolution": 300,
    "mcts_nodes": 8,
    "mcts_iterations": 30,
    "seed": 41,
}


def _table() -> trimesh.Trimesh:
    """A small non-convex mesh: a top on four legs."""
    parts = [trimesh.creation.box(bounds=[[-0.6, -0.4, 0.7], [0.6, 0.4, 0.75]])]
    for x in (-0.55, 0.55):
        for y in (-0.35, 0.35):
            parts.append(trimesh.creation.box(bounds=[[x - 0.05, y - 0.05, 0.0], [x + 0.05, y + 0.05, 0.7]]))
    mesh: trimesh.Trimesh = trimesh.util.concatenate(parts)
    return mesh


def _decompose_in_a_process(root: str, barrier: Any, results: Any) -> None:
    """Runs in a spawned process: wait for the sibling, then ask the shared cache for the table."""
    from scenemosaic.assets import CoacdParams, HullCache, shutdown_workers

    cache = HullCache(Path(root))
    mesh = _table()
    barrier.wait(timeout=120)
    try:
        pieces = cache.get(mesh, CoacdParams(**PARAMS))
        results.put((cache.computations, cache.disk_hits, cache.fallbacks, len(pieces)))
    finally:
        shutdown_workers(wait=True)  # a multiprocessing child skips the interpreter's executor shutdown


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="the cross-process lock is POSIX flock")
def test_two_processes_decompose_the_same_mesh_once(tmp_path: Path) -> None:
    ctx = multiprocessing.get_context("spawn")
    barrier = ctx.Barrier(2)
    results = ctx.Queue()
    # plain processes, not a Pool: pool workers are daemons, which may not start CoACD workers
    procs = [ctx.Process(target=_decompose_in_a_process, args=(str(tmp_path), barrier, results)) for _ in range(2)]
    for p in procs:
        p.start()
    try:
        outcomes = [results.get(timeout=240) for _ in procs]
    finally:
        for p in procs:
            p.join(timeout=60)
            if p.is_alive():
                p.kill()
                p.join()
        results.close()
        results.join_thread()
    assert [p.exitcode for p in procs] == [0, 0]
    computations = sorted(o[0] for o in outcomes)
    disk_hits = sorted(o[1] for o in outcomes)
    assert computations == [0, 1], outcomes  # CoACD ran once ...
    assert disk_hits == [0, 1], outcomes  # ... and the other process read its result
    assert all(o[2] == 0 for o in outcomes)
    assert outcomes[0][3] == outcomes[1][3]  # both got the same pieces
    assert len(list(tmp_path.rglob("*.npz"))) == 1 and len(list(tmp_path.rglob("*.lock"))) == 1

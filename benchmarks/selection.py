"""Selection benchmark: the dynamic max-min greedy over large candidate pools.

A synthetic 20-object scene in 4 groups of 5 objects (random poses, seeded), each group with V
variants, so the pool holds V^4 candidates: V = 18 gives 104,976 (about 10^5), V = 32 gives
1,048,576 (about 10^6, scored in chunks of ``CHUNK``). m = 5, alpha = 0.1, no scene-level check
(geometry is not the point here: the distance tables and the greedy are).

Figures (last line, one JSON object): ``select_1e5_s``, ``select_1e5_peak_mb`` (Python heap peak
of the selection, tracemalloc), ``select_1e5_candidates``, ``select_1e6_s``,
``select_1e6_candidates``, ``select_1e6_peak_mb``. Targets (issue 12): <= 5 s and <= 2 GB for 10^5.

Run: ``.venv/bin/python benchmarks/selection.py``.
"""

from __future__ import annotations

import json
import math
import time
import tracemalloc

import numpy as np

from scenemosaic.compose import CandidatePool, GroupVariants, select_diverse
from scenemosaic.scene import quat_from_yaw, quat_to_matrix


def _group(rng: np.random.Generator, name: str, n: int, variants: int) -> GroupVariants:
    pos = rng.uniform(-3, 3, size=(variants, n, 3))
    pos[..., 2] = 0.0
    yaws = rng.uniform(-math.pi, math.pi, size=(variants, n))
    q = np.array([[quat_from_yaw(y) for y in row] for row in yaws])
    r = np.array([[quat_to_matrix(x) for x in row] for row in q])
    return GroupVariants(name, tuple(f"{name}_{i}" for i in range(n)), pos, r, q)


def _run(variants: int) -> tuple[float, float, int]:
    rng = np.random.default_rng(0)
    pool = CandidatePool([_group(rng, f"g{i}", 5, variants) for i in range(4)])
    tracemalloc.start()
    t0 = time.perf_counter()
    sel = select_diverse(pool, m=5)
    seconds = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert len(sel.picked) == 6
    return seconds, peak / 2**20, sel.considered


def main() -> None:
    t0 = time.perf_counter()
    s5, mb5, n5 = _run(18)
    s6, mb6, n6 = _run(32)
    print(json.dumps({
        "select_1e5_s": round(s5, 2), "select_1e5_peak_mb": round(mb5, 1), "select_1e5_candidates": n5,
        "select_1e6_s": round(s6, 2), "select_1e6_peak_mb": round(mb6, 1), "select_1e6_candidates": n6,
        "seconds": round(time.perf_counter() - t0, 1),
    }))  # fmt: skip


if __name__ == "__main__":
    main()

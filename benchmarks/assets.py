"""Benchmark of the CoACD hull cache: cold vs warm decomposition, and a cold 40k-face SAM3D bed.

Run from the repository root::

    .venv/bin/python benchmarks/assets.py [--skip-bed]

Every figure is measured in a fresh temporary cache. The worker process is started (and timed)
before the cold runs, so ``coacd_cold_s`` is the decomposition itself (plus the trip to the worker
and the write of the cache file), not Python start-up. The last line printed is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import trimesh

from scenemosaic.assets import CoacdParams, HullCache, load_mesh, shutdown_workers

KING_BED = (
    Path(__file__).resolve().parents[1]
    / "data/sam3d_objects/generated_assets/sdf/king_bed_1761578419/king_bed.gltf"
)
WARM_REPEATS = 7


def _simple_mesh() -> trimesh.Trimesh:
    """A thick ring: small (192 faces) but not convex, so CoACD must cut it."""
    mesh: trimesh.Trimesh = trimesh.creation.annulus(r_min=0.2, r_max=0.4, height=0.3, sections=24)
    return mesh


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-bed", action="store_true", help="skip the slow king-bed decomposition")
    args = parser.parse_args()
    results: dict[str, float | int | None] = {}

    with tempfile.TemporaryDirectory(prefix="scenemosaic-bench-") as tmp:
        root = Path(tmp)
        params = CoacdParams()

        # start the worker process with a throw-away job, so the cold figure is CoACD alone
        start = time.perf_counter()
        HullCache(root / "warmup").get(trimesh.creation.box(), params)
        results["worker_start_s"] = round(time.perf_counter() - start, 3)

        ring = _simple_mesh()
        cold_cache = HullCache(root / "hulls")
        start = time.perf_counter()
        pieces = cold_cache.get(ring, params)
        cold = time.perf_counter() - start
        assert cold_cache.computations == 1

        warm_times = []
        for _ in range(WARM_REPEATS):
            warm_cache = HullCache(root / "hulls")  # a new instance: nothing held in memory
            start = time.perf_counter()
            warm_pieces = warm_cache.get(ring, params)
            warm_times.append(time.perf_counter() - start)
            assert warm_cache.computations == 0 and len(warm_pieces) == len(pieces)
        warm = statistics.median(warm_times)
        print(f"simple mesh: {len(ring.faces)} faces -> {len(pieces)} convex pieces")
        print(
            f"  cold {cold:.3f} s, warm {warm * 1000:.2f} ms (median of {WARM_REPEATS}), speedup {cold / warm:.0f}x"
        )
        results.update(
            coacd_cold_s=round(cold, 4),
            coacd_warm_s=round(warm, 6),
            coacd_cache_speedup=round(cold / warm, 1),
            simple_pieces=len(pieces),
        )

        results["king_bed_cold_s"] = None
        if not args.skip_bed:
            start = time.perf_counter()
            bed = load_mesh(KING_BED)
            load_s = time.perf_counter() - start
            bed_cache = HullCache(root / "bed")
            start = time.perf_counter()
            bed_pieces = bed_cache.get(bed.mesh, params)
            bed_s = time.perf_counter() - start
            start = time.perf_counter()
            HullCache(root / "bed").get(bed.mesh, params)
            bed_warm = time.perf_counter() - start
            print(
                f"king bed: {len(bed.mesh.faces)} faces, simplified to ~{params.simplify_faces}, "
                f"{len(bed_pieces)} pieces; load {load_s:.2f} s, cold CoACD {bed_s:.1f} s, warm {bed_warm:.3f} s"
            )
            results.update(
                king_bed_load_s=round(load_s, 3),
                king_bed_cold_s=round(bed_s, 2),
                king_bed_warm_s=round(bed_warm, 4),
                king_bed_pieces=len(bed_pieces),
            )
    shutdown_workers()
    print(json.dumps(results))
    return 0


if __name__ == "__main__":  # the guard matters: CoACD workers are spawned and re-import this file
    sys.exit(main())

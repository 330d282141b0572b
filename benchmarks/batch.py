"""Batch benchmark: throughput of the local executor over the shipped PhyScene rooms.

The 7 rooms of ``data/layouts/physcene`` with ``--variants 5``, the ``rules`` model and seed 0,
run by :func:`scenemosaic.batch.run_batch` once with 1 worker and once with 2 workers (local
executor), each into a fresh output folder. A scene is a delivered ``base/`` or ``variant_<i>/``;
the rate is scenes per minute of the batch's wall time (worker start-up included).

Figures (last line, one JSON object): ``scenes_per_min_1w``, ``scenes_per_min_2w``,
``speedup_2w`` (2-worker rate / 1-worker rate), ``scenes`` (per run), ``wall_s_1w``,
``wall_s_2w``, ``failed`` (jobs not ok or degraded, both runs), ``cpus`` (``os.cpu_count()``: the
speed-up cannot pass it, and other work on the machine lowers it), and ``identical`` (whether
both runs wrote byte-identical ``scene.json`` files).

Run: ``.venv/bin/python benchmarks/batch.py [--variants 5] [--workers 1 2] [--keep DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from scenemosaic.batch import BatchSummary, run_batch

ROOMS = Path(__file__).resolve().parents[1] / "data" / "layouts" / "physcene"


def _scene_files(out: Path) -> dict[str, bytes]:
    return {
        p.relative_to(out).as_posix(): p.read_bytes()
        for p in sorted(out.glob("*/*/scene.json"))
        if p.parent.name == "base" or p.parent.name.startswith("variant_")
    }


def _run(manifest: Path, out: Path, workers: int) -> tuple[BatchSummary, float]:
    t0 = time.perf_counter()
    summary = run_batch(manifest, out, executor="local", workers=workers)
    return summary, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--variants", type=int, default=5)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--keep", type=Path, default=None, help="write the runs here instead of a temporary folder")
    args = parser.parse_args()

    rooms = sorted(ROOMS.glob("*.json"))
    with tempfile.TemporaryDirectory(prefix="scenemosaic-batch-bench-") as tmp:
        root = args.keep or Path(tmp)
        manifest = root / "physcene.jsonl"
        root.mkdir(parents=True, exist_ok=True)
        manifest.write_text(
            "".join(json.dumps({"input": str(p), "variants": args.variants, "seed": 0, "model": "rules"}) + "\n" for p in rooms),
            encoding="utf-8",
        )
        figures: dict[str, object] = {"rooms": len(rooms), "variants": args.variants, "cpus": os.cpu_count()}
        rates: dict[int, float] = {}
        outputs: list[dict[str, bytes]] = []
        failed = 0
        for workers in args.workers:
            out = root / f"out_{workers}w_{time.time_ns()}"  # fresh: nothing to skip
            summary, wall = _run(manifest, out, workers)
            bad = [j for j in summary.jobs if j.status not in ("ok", "degraded")]
            failed += len(bad)
            for job in summary.jobs:
                print(f"{workers}w {job.id:<36} {job.status:<8} {job.wall_s:6.1f} s  {job.scenes_written} scenes")
            rates[workers] = summary.scenes_written / (wall / 60.0)
            figures[f"scenes_{workers}w"] = summary.scenes_written
            figures[f"wall_s_{workers}w"] = round(wall, 2)
            figures[f"scenes_per_min_{workers}w"] = round(rates[workers], 2)
            outputs.append(_scene_files(out))
        figures["scenes"] = figures.get(f"scenes_{args.workers[0]}w")
        if 1 in rates and 2 in rates:
            figures["speedup_2w"] = round(rates[2] / rates[1], 3)
        figures["identical"] = all(files == outputs[0] for files in outputs[1:])
        figures["failed"] = failed
    print(json.dumps(figures))


if __name__ == "__main__":
    main()

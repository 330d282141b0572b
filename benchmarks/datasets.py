"""Dataset benchmark: a file of 1,000 houses is streamed, never held whole (issue 54).

Builds a ``.jsonl.gz`` of ``--houses`` lines (default 1,000) from the shipped ProcTHOR houses,
taken in turn, in a temporary folder; then measures the resident memory of this process (``VmRSS``)
before and after the three things a user does with such a file: the batch's job list
(``batch.load_manifest``: one job a house), counting it (``exchange.dataset_size``) and reading
its last house (``exchange.load_scene(path, index=N-1)``, which streams every line before it);
house 0 is read first, so that the readers' imports and tables are not counted.

Figures (last line, one JSON object): ``houses``, ``file_mb`` (compressed), ``text_mb`` (what the
lines hold uncompressed), ``rss_before_mb``, ``rss_after_jobs_mb``, ``rss_after_last_mb``,
``rss_growth_mb`` (the most the RSS rose over the three, against the file's text: a file read whole
would add about ``text_mb`` and more for its parsed JSON), ``jobs``, ``jobs_s``, ``count_s``,
``last_house_s``, ``last_house_rooms``.

Run: ``.venv/bin/python benchmarks/datasets.py [--houses 1000]``.
"""

from __future__ import annotations

import argparse
import gc
import gzip
import json
import tempfile
import time
from pathlib import Path

from scenemosaic.batch import load_manifest
from scenemosaic.exchange import dataset_size, load_scene
from scenemosaic.scene import House

HOUSES = Path(__file__).resolve().parents[1] / "data" / "houses" / "procthor"


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--houses", type=int, default=1000)
    args = parser.parse_args()
    sources = [json.dumps(json.loads(p.read_text())) for p in sorted(HOUSES.glob("procthor*.json"))]
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / "houses.jsonl.gz"
        text_bytes = 0
        with gzip.open(path, "wt", encoding="utf-8") as handle:
            for i in range(args.houses):
                line = sources[i % len(sources)] + "\n"
                text_bytes += len(line.encode())
                handle.write(line)
        del sources
        load_scene(path, index=0)  # the readers' own imports and tables load once, before the measure
        gc.collect()
        before = _rss_mb()
        t0 = time.perf_counter()
        jobs = load_manifest(path)
        jobs_s = time.perf_counter() - t0
        after_jobs = _rss_mb()
        t0 = time.perf_counter()
        count = dataset_size(path)
        count_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        last = load_scene(path, index=count - 1)
        last_s = time.perf_counter() - t0
        after_last = _rss_mb()
        rooms = len(last.rooms) if isinstance(last, House) else 1
        figures = {
            "houses": count,
            "file_mb": round(path.stat().st_size / 1e6, 2),
            "text_mb": round(text_bytes / 1e6, 1),
            "rss_before_mb": round(before, 1),
            "rss_after_jobs_mb": round(after_jobs, 1),
            "rss_after_last_mb": round(after_last, 1),
            "rss_growth_mb": round(max(after_jobs, after_last) - before, 1),
            "jobs": len(jobs),
            "jobs_s": round(jobs_s, 2),
            "count_s": round(count_s, 2),
            "last_house_s": round(last_s, 2),
            "last_house_rooms": rooms,
        }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()

"""Import cost of the package: ``import scenemosaic`` and ``scenemosaic --help`` stay light.

Runs each command in a fresh interpreter (best of N wall times) and lists heavy backends
(MuJoCo, CoACD, trimesh) that got imported. Last line: one JSON object of named figures.

Run: ``python benchmarks/imports.py [--repeats 7]``
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

HEAVY = ("mujoco", "coacd", "trimesh")


def _timed(code: str, repeats: int) -> tuple[float, list[str]]:
    best = float("inf")
    loaded: list[str] = []
    probe = f"{code}; import sys; print(','.join(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))))"
    for _ in range(repeats):
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
        best = min(best, time.perf_counter() - t0)
        loaded = [m for m in done.stdout.strip().split(",") if m]
    return best, loaded


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    baseline, _ = _timed("pass", args.repeats)
    package, heavy_pkg = _timed("import scenemosaic", args.repeats)
    cli, heavy_cli = _timed("import scenemosaic.cli", args.repeats)
    full, heavy_full = _timed("import scenemosaic; scenemosaic.generate", args.repeats)
    figures = {
        "python_startup_s": round(baseline, 4),
        "import_scenemosaic_s": round(package - baseline, 4),
        "import_cli_s": round(cli - baseline, 4),
        "import_with_pipeline_s": round(full - baseline, 4),
        "heavy_modules_on_import": heavy_pkg,
        "heavy_modules_on_cli": heavy_cli,
        "heavy_modules_after_generate_lookup": heavy_full,
    }
    print(json.dumps(figures, sort_keys=True))


if __name__ == "__main__":
    main()

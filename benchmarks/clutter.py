"""Clutter benchmark: every room of every shipped ProcTHOR house, one room at a time (issue 23).

Each room of each house in ``data/houses/procthor/`` is generated on its own, as a user would
with ``scenemosaic generate <house>.json --room <id> --model rules`` (``variants=0``), and its
``report.json`` is read back:

* ``status`` — ``ok``, ``degraded`` or ``failed`` (an exception is counted as ``failed``);
* ``validation.collisions.pairs`` — colliding pairs left in the delivered base scene;
* ``validation.out_of_bounds.objects`` — objects outside their room or their anchor's bounds;
* re-parentings — the moves the structure stage lists in its ``reparented`` (verification's
  re-homing of implausible items and of what a crowded top cannot take).

One line per room comes first (house, room id, status, objects, collision pairs, objects out of
bounds, seconds, the first warning's first 100 characters), then ONE JSON line of figures:
``rooms``, ``objects`` (input objects over all rooms), ``rooms_ok``, ``rooms_degraded``,
``rooms_failed``, ``collision_pairs``, ``out_of_bounds``, ``reparented``, ``seconds_per_room``
(mean wall time of one room's run), ``seconds`` (the whole benchmark) and ``houses``.

Target (issue 23): every room ``ok``, 0 collision pairs, 0 out of bounds.

Run: ``.venv/bin/python benchmarks/clutter.py`` (several minutes on 2 cores). ``--house NAME``
(repeatable; a file stem) limits it to some houses, ``--keep DIR`` keeps every run's folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import structlog

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import load_scenes

REPO = Path(__file__).resolve().parents[1]
HOUSES = REPO / "data" / "houses" / "procthor"


def houses(names: list[str] | None = None) -> list[Path]:
    """Every house file shipped in ``data/houses/procthor/`` (not ``SOURCES.json``), sorted."""
    found = sorted(p for p in HOUSES.glob("*.json") if p.name != "SOURCES.json")
    if names:
        found = [p for p in found if p.stem in names]
    return found


def count_reparented(report: dict[str, Any]) -> int:
    """Re-parentings the structure stage lists (``detail.reparented``: verification's moves)."""
    for stage in report.get("stages") or []:
        if isinstance(stage, dict) and stage.get("name") == "structure":
            return len((stage.get("detail") or {}).get("reparented") or [])
    return 0


def run_room(house: Path, room_id: str, out: Path) -> dict[str, Any]:
    """Generate one room; read its report. An exception is a ``failed`` room."""
    t0 = time.perf_counter()
    report: dict[str, Any] = {}
    error = ""
    try:
        generate(house, out, GenerateConfig(room=room_id, model="rules", variants=0))
    except Exception as exc:  # a benchmark records a failure and goes on
        error = f"{type(exc).__name__}: {exc}"
    seconds = time.perf_counter() - t0
    report_path = out / "report.json"
    if report_path.is_file():
        report = json.loads(report_path.read_text(encoding="utf-8"))
    validation = report.get("validation") or {}
    pairs = ((validation.get("collisions") or {}).get("pairs")) or []
    oob = ((validation.get("out_of_bounds") or {}).get("objects")) or []
    warnings = [str(w) for w in report.get("warnings") or []]
    status = "failed" if error else str(report.get("status", "failed"))
    reparented = count_reparented(report)
    return {
        "house": house.stem,
        "room": room_id,
        "status": status,
        "collision_pairs": len(pairs),
        "out_of_bounds": len(oob),
        "reparented": reparented,
        "seconds": seconds,
        "first_warning": (error or (warnings[0] if warnings else ""))[:100],
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--house", action="append", help="only this house (file stem); repeatable")
    parser.add_argument("--keep", type=Path, help="keep every run's output folder here")
    args = parser.parse_args(argv)
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(40))

    t_start = time.perf_counter()
    rows: list[dict[str, Any]] = []
    n_objects = 0
    selected = houses(args.house)
    with tempfile.TemporaryDirectory(prefix="scenemosaic-clutter-") as tmp:
        base = args.keep if args.keep is not None else Path(tmp)
        for house in selected:
            for scene in load_scenes(house):
                room_id = str(scene.metadata["procthor"]["room_id"])
                n = len(scene.objects)
                n_objects += n
                out = base / house.stem / room_id.replace("|", "_")
                row = run_room(house, room_id, out)
                row["objects"] = n
                rows.append(row)
                print(
                    f"{row['house']:<34} {row['room']:<8} {row['status']:<8} objects {n:>3}  "
                    f"collisions {row['collision_pairs']:>2}  out of bounds {row['out_of_bounds']:>2}  "
                    f"{row['seconds']:6.1f} s  {row['first_warning']}",
                    flush=True,
                )
    seconds = time.perf_counter() - t_start
    figures = {
        "rooms": len(rows),
        "objects": n_objects,
        "rooms_ok": sum(r["status"] == "ok" for r in rows),
        "rooms_degraded": sum(r["status"] == "degraded" for r in rows),
        "rooms_failed": sum(r["status"] == "failed" for r in rows),
        "collision_pairs": sum(r["collision_pairs"] for r in rows),
        "out_of_bounds": sum(r["out_of_bounds"] for r in rows),
        "reparented": sum(r["reparented"] for r in rows),
        "seconds_per_room": round(sum(r["seconds"] for r in rows) / max(len(rows), 1), 2),
        "seconds": round(seconds, 1),
        "houses": len(selected),
    }
    print(json.dumps(figures))
    sys.stdout.flush()


if __name__ == "__main__":
    main()

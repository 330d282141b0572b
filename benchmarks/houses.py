"""Houses benchmark: does every shipped house come out valid, whatever its source?

Every house file under ``data/houses/<folder>/`` (each folder a group: ``procthor`` the houses the
solvers were shaped on, the others held out and reported apart), one-room houses included (run as
a room: one room, no house-level figures), runs
``generate --variants 5`` offline (rules model, seed 0), as a user would. Per house:

* ``status`` — the run's (``ok``, ``degraded``, ``failed``; an exception counts as ``failed``);
* ``rooms_ok`` / ``rooms`` — rooms that ended without an error, whose base and every variant hold
  COL 0 and OOB 0 (``metrics.rooms``) and which every one of them reaches from the rest of the house;
* ``house_nav_min`` — the lowest house NAV over base and variants (``metrics.house``);
* ``door_blockers`` — pieces in a door's way, summed over base and variants;
* ``unreachable`` — rooms not reachable from the rest of the house, summed likewise;
* ``wall_crossings`` — objects across a wall, summed likewise;
* ``variants``, ``warnings`` (the first two), ``seconds``.

The last line is one JSON object: ``houses_ok`` / ``houses``, ``rooms_ok`` / ``rooms``,
``house_nav_min`` (the worst house), ``door_blockers``, ``unreachable``, ``wall_crossings``, the
same per group (``groups``), the houses that are not ``ok`` (``not_ok``) and ``seconds``.

Target (issue 37): every house ``ok``, every room ok, house NAV >= 0.99, no door blocked, every
room reachable, no wall crossing.

Run: ``.venv/bin/python benchmarks/houses.py [--only NAME] [--group FOLDER] [--keep DIR] [--reuse DIR]``
(about 25 minutes for the shipped houses on two cores). ``--reuse DIR`` reads the reports of runs
already made the same way (5 variants, rules model, seed 0; ``benchmarks/house_diversity.py``
leaves one folder per house stem in its temporary folder) instead of running those houses again;
``reused`` in a house's line says which.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

from scenemosaic import GenerateConfig, generate

REPO = Path(__file__).resolve().parents[1]
HOUSES = REPO / "data" / "houses"
VARIANTS = 5


def _count(value: Any) -> int:
    """A figure stored either as a count or as the list it counts."""
    if isinstance(value, list):
        return len(value)
    return int(value or 0)


def _house(path: Path, out: Path, group: str, reuse: Path | None) -> dict[str, Any]:
    t0 = time.perf_counter()
    row: dict[str, Any] = {"house": path.stem, "group": group}
    done = reuse / path.stem / "report.json" if reuse is not None else None
    if done is not None and done.is_file():  # the same run made by another benchmark: read, not redone
        report = json.loads(done.read_text())
        if (report.get("config") or {}).get("variants") != VARIANTS:
            raise SystemExit(f"{done}: not a run with {VARIANTS} variants")
        status, variants, seconds = report["status"], int(report.get("variants_written") or 0), report.get("total_seconds")
    else:
        try:
            result = generate(path, out, GenerateConfig(variants=VARIANTS))
        except Exception as exc:  # a benchmark records the failure and goes on to the next house
            return {**row, "status": "failed", "error": f"{type(exc).__name__}: {exc}"[:200], "seconds": round(time.perf_counter() - t0, 1)}
        report, status, variants, seconds = result.report, result.status, len(result.variants), None
    metrics = report.get("metrics", {})
    house = metrics.get("house", {})
    house_rows = [house.get("base", {}), *house.get("variants", [])]
    unreachable_rooms = {str(u) for r in house_rows for u in r.get("unreachable_rooms") or []}
    rooms = report.get("rooms") or {}
    room_metrics = metrics.get("rooms", {})
    if not rooms:  # a one-room house runs as a room: its report and metrics are a room's
        rooms, room_metrics = {"room": {"error": report.get("error")}}, {"room": metrics}
    ok = 0
    for rid, rec in rooms.items():
        rm = room_metrics.get(rid, {})
        rows = [rm.get("base", {}), *rm.get("variants", [])]
        clean = all(float(x.get("COL", 0.0)) == 0.0 and float(x.get("OOB", 0.0)) == 0.0 for x in rows)
        if rec.get("error") is None and clean and rid not in unreachable_rooms:
            ok += 1
    return {
        **row,
        "status": status,
        "rooms": len(rooms),
        "rooms_ok": ok,
        "variants": variants,
        "house_nav_min": min((float(r.get("house_nav", 1.0)) for r in house_rows), default=1.0),
        "door_blockers": sum(_count(r.get("door_blockers")) for r in house_rows),
        "unreachable": sum(_count(r.get("unreachable_rooms")) for r in house_rows),
        "wall_crossings": sum(_count(r.get("wall_crossings")) for r in house_rows),
        "warnings": [str(w)[:120] for w in report.get("warnings", [])[:2]],
        "seconds": round(float(seconds), 1) if seconds is not None else round(time.perf_counter() - t0, 1),
        "reused": done is not None and done.is_file(),
    }


def _pool(rows: list[dict[str, Any]]) -> dict[str, Any]:
    done = [r for r in rows if "rooms" in r]
    return {
        "houses": len(rows),
        "houses_ok": sum(1 for r in rows if r["status"] == "ok"),
        "rooms": sum(r["rooms"] for r in done),
        "rooms_ok": sum(r["rooms_ok"] for r in done),
        "house_nav_min": min((r["house_nav_min"] for r in done), default=None),
        "door_blockers": sum(r["door_blockers"] for r in done),
        "unreachable": sum(r["unreachable"] for r in done),
        "wall_crossings": sum(r["wall_crossings"] for r in done),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=None, help="run only houses whose name contains this")
    parser.add_argument("--group", action="append", default=[], help="run only this folder of data/houses (repeatable)")
    parser.add_argument("--keep", type=Path, default=None, help="keep every run's folder here")
    parser.add_argument(
        "--reuse", type=Path, default=None,
        help="a folder of runs already made the same way (benchmarks/house_diversity.py's, one per house stem): read their reports",
    )  # fmt: skip
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    work = args.keep or Path(tempfile.mkdtemp(prefix="houses_"))
    rows = []
    for folder in sorted(p for p in HOUSES.iterdir() if p.is_dir()):
        if args.group and folder.name not in args.group:
            continue
        for path in sorted(folder.glob("*.json")):
            if path.name == "SOURCES.json" or (args.only and args.only not in path.stem):
                continue
            row = _house(path, work / folder.name / path.stem, folder.name, args.reuse)
            print(json.dumps(row), flush=True)
            rows.append(row)
    groups = {g: _pool([r for r in rows if r["group"] == g]) for g in sorted({r["group"] for r in rows})}
    print(json.dumps({
        **_pool(rows),
        "groups": groups,
        "not_ok": {r["house"]: r.get("warnings") or r.get("error") for r in rows if r["status"] != "ok"},
        "seconds": round(time.perf_counter() - t0, 1),
    }))  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

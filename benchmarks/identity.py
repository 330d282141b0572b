"""Output identity: digests of every file a run delivers, for the shipped rooms and houses, to hold a
refactoring to "the same bytes as before".

Each case (a shipped input x ``--clutter keep|vary|fill``, two variants, seed 0, the ``rules``
model) is generated into a fresh folder, and every delivered file is hashed (SHA-256): the scenes,
meshes, hulls, MJCF/URDF/USD/SDF/GLB/SceneEval exports and pictures, that is everything but
``report.json`` (it holds timings), the checkpoint and the run lock. ``--save FILE`` writes the
digests; ``--compare FILE`` runs the same cases and lists each file whose bytes differ, or that is
new or gone (both: compare, then save the new digests). ``--keep DIR`` keeps the outputs (to read
a difference, not only count it). ``--room-workers N`` runs the houses with N room processes (the output must not
depend on it).

Figures (last line, one JSON object): ``cases``, ``files``, ``seconds`` and, with ``--compare``,
``differing`` (files whose bytes changed), ``missing``, ``extra`` and ``identical`` (true when
all three are zero).

Run: ``.venv/bin/python benchmarks/identity.py --save /tmp/before.json`` on the old commit, then
``--compare /tmp/before.json`` on the new one (about ten minutes on two cores; ``--quick``: one
room and one house, each with every clutter mode).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import tempfile
import time
from pathlib import Path

from scenemosaic.pipeline import GenerateConfig, generate

DATA = Path(__file__).resolve().parents[1] / "data"
ROOMS = [*sorted((DATA / "layouts" / "physcene").glob("*.json")), DATA / "layouts" / "holodeck" / "holodeck_living_room.json"]
HOUSES = [
    DATA / "houses" / "procthor" / name
    for name in (
        "procthor_1room_bedroom.json",
        "procthor10k_house3703_2room.json",
        "procthor_4room.json",
        "procthor10k_train4_4room.json",
        "procthor_6room.json",
        "procthor10k_train1_10room.json",
    )
]
CLUTTER = ("keep", "vary", "fill")
_SKIPPED_NAMES = {"report.json", ".lock"}
_SKIPPED_DIRS = {".checkpoint"}


def digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every delivered file under ``folder``, by its path relative to it."""
    out: dict[str, str] = {}
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder)
        if not path.is_file() or path.name in _SKIPPED_NAMES or _SKIPPED_DIRS & set(rel.parts):
            continue
        out[rel.as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def run_cases(quick: bool, room_workers: int | None, cache: Path, keep: Path | None = None) -> dict[str, dict[str, str]]:
    rooms, houses = (ROOMS[:1], HOUSES[2:3]) if quick else (ROOMS, HOUSES)
    results: dict[str, dict[str, str]] = {}
    with tempfile.TemporaryDirectory() as scratch:
        tmp = keep if keep is not None else Path(scratch)
        for source in [*rooms, *houses]:
            for clutter in CLUTTER:
                name = f"{source.stem}/{clutter}"
                out = tmp / source.stem / clutter
                config = GenerateConfig(
                    model="rules", seed=0, variants=2, clutter=clutter, cache_dir=cache,
                    **({"room_workers": room_workers} if room_workers and source in houses else {}),
                )  # fmt: skip
                start = time.perf_counter()
                generate(source, out, config)
                results[name] = digests(out)
                print(f"{name}: {len(results[name])} files, {time.perf_counter() - start:.1f} s", flush=True)
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", type=Path, help="write the digests to this JSON file")
    parser.add_argument("--compare", type=Path, help="compare with the digests saved in this JSON file")
    parser.add_argument("--quick", action="store_true", help="one room and one house only")
    parser.add_argument("--room-workers", type=int, default=None, help="room processes of a house run")
    parser.add_argument("--cache", type=Path, default=Path(".scenemosaic-cache"), help="the hull cache folder")
    parser.add_argument("--keep", type=Path, default=None, help="keep every run's output under this folder")
    args = parser.parse_args()
    if args.save is None and args.compare is None:
        parser.error("give --save FILE, --compare FILE or both")
    start = time.perf_counter()
    results = run_cases(args.quick, args.room_workers, args.cache, args.keep)
    figures: dict[str, object] = {"cases": len(results), "files": sum(len(d) for d in results.values())}
    if args.save is not None:
        args.save.write_text(json.dumps(results, indent=1, sort_keys=True))
    if args.compare is not None:
        before: dict[str, dict[str, str]] = json.loads(args.compare.read_text())
        differing, missing, extra = [], [], []
        for case, now in results.items():
            old = before.get(case)
            if old is None:
                print(f"{case}: not in {args.compare}")
                continue
            differing += [f"{case}:{p}" for p in sorted(now.keys() & old.keys()) if now[p] != old[p]]
            missing += [f"{case}:{p}" for p in sorted(old.keys() - now.keys())]
            extra += [f"{case}:{p}" for p in sorted(now.keys() - old.keys())]
        for label, paths in (("differs", differing), ("missing", missing), ("new", extra)):
            for path in paths:
                print(f"{label}: {path}")
        figures |= {
            "differing": len(differing), "missing": len(missing), "extra": len(extra),
            "identical": not (differing or missing or extra),
        }  # fmt: skip
    figures["seconds"] = round(time.perf_counter() - start, 1)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()

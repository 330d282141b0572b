"""CLI start-up: ``scenemosaic --help``, ``scenemosaic inspect`` and ``sm.load_scene`` in a fresh process.

Each command runs in a fresh interpreter, ``--repeats`` times (the median wall time is the
figure), in two settings:

* compiled: bytecode may be written, and a first unmeasured run writes what is missing;
* ``PYTHONDONTWRITEBYTECODE=1`` (as in many containers): nothing is written, so whatever the
  install left without bytecode is compiled again by every command. These runs come first, before
  the compiled runs could write anything, so they measure the environment as it was installed
  (``make demo`` leaves it compiled: see the Makefile).

Commands: ``--help``; ``inspect`` of a house run folder and of a room run folder (made by a quick
``generate`` into a temporary folder: rules model, no stabilization, no evolution; or the folders
of ``--reuse DIR``: ``DIR/house`` and ``DIR/room``); ``python -c "import scenemosaic as sm;
sm.load_scene(HOUSE_RUN)"``. One more run of ``inspect`` on the house, in-process, lists the
heavy backends it imported (none expected) and counts the modules it loaded that have no bytecode
on disk (``modules_without_bytecode``; 0 after ``make demo``).

Figures are wall times; ``cpu`` holds each command's CPU time (user + system, median), which a
busy machine changes far less: ``load_average`` says how busy it was.

Targets (issue 38, item 4): ``--help`` <= 0.5 s, ``inspect`` <= 1.5 s, each at most twice that with
``PYTHONDONTWRITEBYTECODE=1``. The last line is one JSON object of named figures.

Run: ``.venv/bin/python benchmarks/cli.py [--repeats 5] [--reuse DIR] [--keep DIR]``
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
HOUSE = REPO / "data" / "houses" / "procthor" / "procthor10k_house3703_2room.json"
ROOM = REPO / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
HELP_TARGET_S = 0.5
INSPECT_TARGET_S = 1.5
NO_BYTECODE_FACTOR = 2.0
"""How much slower a command may be with ``PYTHONDONTWRITEBYTECODE=1``."""
HEAVY = ("mujoco", "coacd", "trimesh", "scipy", "httpx")

# inspect run in-process: the heavy backends it loaded, and the loaded modules with no bytecode on disk
PROBE = """
import json, os, sys
from scenemosaic.cli import main
target, backends = sys.argv[1], set(json.loads(sys.argv[2]))
sys.argv = ["scenemosaic", "inspect", target]
try:
    main()
except SystemExit as exc:
    if exc.code:
        raise
heavy = sorted({m.split(".")[0] for m in sys.modules} & backends)
missing = sorted(
    name for name, m in list(sys.modules.items())
    if getattr(m, "__cached__", None) and str(getattr(m, "__file__", "")).endswith(".py") and not os.path.exists(m.__cached__)
)
print("PROBE " + json.dumps({"heavy": heavy, "missing": missing}))
"""


def _cli() -> list[str]:
    """The ``scenemosaic`` console script beside this Python, else ``python -m scenemosaic.cli``."""
    script = Path(sys.executable).parent / "scenemosaic"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "scenemosaic.cli"]


def _env(no_bytecode_writes: bool) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if no_bytecode_writes:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def _median_s(cmd: list[str], env: dict[str, str], repeats: int) -> tuple[float, float]:
    """The median wall time of ``cmd`` and the median CPU time (user + system) of its process."""
    walls, cpus = [], []
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(cmd, env=env, cwd=REPO, capture_output=True, check=True, timeout=600)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return round(statistics.median(walls), 3), round(statistics.median(cpus), 3)


def _run_folders(work: Path, reuse: Path | None) -> tuple[Path, Path]:
    """A house run folder and a room run folder: those of ``reuse``, else made by a quick generate."""
    if reuse is not None:
        return reuse / "house", reuse / "room"
    from scenemosaic import GenerateConfig, configure_logging, generate

    configure_logging("error")  # a quick run is degraded (no stabilization): no need to say so
    quick = GenerateConfig(model="rules", stabilize=False, evolve=False, overwrite=True)
    for source, name in ((HOUSE, "house"), (ROOM, "room")):
        t0 = time.perf_counter()
        generate(source, work / name, quick)
        print(f"made the {name} run folder {work / name} ({time.perf_counter() - t0:.0f} s)", flush=True)
    return work / "house", work / "room"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs per command and setting (the median counts)")
    parser.add_argument("--reuse", type=Path, default=None, help="a folder holding the run folders house/ and room/")
    parser.add_argument("--keep", type=Path, default=None, help="make the run folders here and keep them")
    args = parser.parse_args(argv)
    work = args.keep or Path(tempfile.mkdtemp(prefix="cli_bench_"))
    try:
        house, room = _run_folders(work, args.reuse)
        commands = {
            "help": [*_cli(), "--help"],
            "inspect_house": [*_cli(), "inspect", str(house)],
            "inspect_room": [*_cli(), "inspect", str(room)],
            "load_scene": [sys.executable, "-c", f"import scenemosaic as sm; sm.load_scene({str(house)!r})"],
        }
        targets = {"help": HELP_TARGET_S, "inspect_house": INSPECT_TARGET_S, "inspect_room": INSPECT_TARGET_S}
        load = os.getloadavg()[0]
        probe = subprocess.run(
            [sys.executable, "-c", PROBE, str(house), json.dumps(HEAVY)],
            env=_env(no_bytecode_writes=True), cwd=REPO, capture_output=True, text=True, check=True, timeout=600,
        )  # fmt: skip
        found = json.loads(next(line for line in probe.stdout.splitlines() if line.startswith("PROBE "))[6:])
        figures: dict[str, Any] = {"python_startup_s": _median_s([sys.executable, "-c", "pass"], _env(False), args.repeats)[0]}
        cpu: dict[str, float] = {}
        for no_bytecode_writes in (True, False):  # the environment as installed first: nothing written yet
            env = _env(no_bytecode_writes)
            suffix = "_no_bytecode_writes_s" if no_bytecode_writes else "_s"
            for name, cmd in commands.items():
                if not no_bytecode_writes:
                    subprocess.run(cmd, env=env, cwd=REPO, capture_output=True, check=True, timeout=600)  # writes bytecode
                figures[name + suffix], cpu[name + suffix] = _median_s(cmd, env, args.repeats)
        met = {}
        for name, target in targets.items():
            met[name] = figures[name + "_s"] <= target
            met[name + "_no_bytecode_writes"] = figures[name + "_no_bytecode_writes_s"] <= NO_BYTECODE_FACTOR * target
        for name in commands:
            limit = targets.get(name)
            goal = f"  (target {limit} s; {NO_BYTECODE_FACTOR * limit} s without bytecode writes)" if limit else ""
            print(
                f"{name:<14} {figures[name + '_s']:6.2f} s, without bytecode writes {figures[name + '_no_bytecode_writes_s']:6.2f} s{goal}",
                flush=True,
            )
        print(json.dumps({
            **figures,
            "cpu": cpu,
            "heavy_modules_on_inspect": found["heavy"],
            "modules_without_bytecode": len(found["missing"]),
            "modules_without_bytecode_first": found["missing"][:5],
            "targets_s": targets,
            "no_bytecode_factor": NO_BYTECODE_FACTOR,
            "met": met,
            "all_met": all(met.values()),
            "load_average": round(load, 2),
            "repeats": args.repeats,
        }, sort_keys=True))  # fmt: skip
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

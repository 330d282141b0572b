"""Function benchmark: does every drawer, door, lid and room door of a delivered world open, pulled in
plain MuJoCo (``physics.pull_parts``, issue 53)?

Each case (a shipped input x ``--clutter``, seed 0, the ``rules`` model, ``--variants N``) is
generated into a fresh folder, and every delivered world (``base/`` and each ``variant_<i>/``) is
loaded from its ``scene.xml`` the way a user loads it and each part pulled on its own: a hinge
passes at 90 degrees (or its whole range), a slide at 80 % of its travel, with nothing else moved
more than 2 cm and no body faster than 5 m/s. Room-door leaves are swung from shut the same way and
counted apart.

Run: ``.venv/bin/python benchmarks/functional.py`` (the 4-room ProcTHOR house and two PhyScene
bedrooms, clutter keep and vary, 2 variants: a few minutes on two cores); ``--all`` every shipped
room and house with clutter keep, vary and fill; ``--variants N``; ``INPUT ...`` instead of the
default inputs. The failures are printed one a line (world, joint, how far it got, what blocked
it); the last line is one JSON object: ``parts``, ``parts_open`` and ``open_share`` (furniture),
``leaves`` and ``leaves_swing`` (room doors), ``fastest_m_s``, ``blocked_by`` (failures by the kind
of what blocked them: a wall, furniture, a small object, the part pushing something) and ``seconds``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections import Counter
from pathlib import Path

from scenemosaic.exchange import load_scene
from scenemosaic.metrics import furniture
from scenemosaic.physics import PartPull, pull_parts
from scenemosaic.pipeline import GenerateConfig, generate
from scenemosaic.scene import House

DATA = Path(__file__).resolve().parents[1] / "data"
DEFAULT = [
    DATA / "houses" / "procthor" / "procthor_4room.json",
    DATA / "layouts" / "physcene" / "Bedroom-33922_bedroom.json",
    DATA / "layouts" / "physcene" / "Bedroom-11659_bedroom.json",
]
EVERY = [
    *sorted((DATA / "layouts" / "physcene").glob("*.json")),
    *sorted((DATA / "houses" / "procthor").glob("*.json")),
    *sorted((DATA / "houses" / "held_out").glob("*.json")),
]


def _kind(blocker: str | None, small: set[str]) -> str:
    if blocker is None:
        return "none"
    if "wall" in blocker or blocker == "world":
        return "wall"
    return "small object" if blocker in small else "furniture"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", nargs="*", type=Path)
    parser.add_argument("--all", action="store_true", help="every shipped room and house, clutter keep, vary and fill")
    parser.add_argument("--variants", type=int, default=2)
    args = parser.parse_args()
    inputs = args.inputs or (EVERY if args.all else DEFAULT)
    clutters = ("keep", "vary", "fill") if args.all else ("keep", "vary")
    started = time.perf_counter()
    pulls: list[PartPull] = []
    kinds: Counter[str] = Counter()
    with tempfile.TemporaryDirectory() as scratch:
        for path in inputs:
            for clutter in clutters:
                out = Path(scratch) / f"{path.stem}_{clutter}"
                config = GenerateConfig(variants=args.variants, clutter=clutter, seed=0, allow_orphans=True)
                generate(path, out, config)
                for world in sorted(p for p in out.iterdir() if p.is_dir() and (p / "scene.xml").is_file()):
                    loaded = load_scene(world)
                    rooms = loaded.rooms if isinstance(loaded, House) else [loaded]
                    big = {oid for r in rooms for oid in furniture(r)}
                    small = {o.id for r in rooms for o in r.objects if o.id not in big}
                    found = pull_parts(world / "scene.xml")
                    pulls += found
                    for p in found:
                        if not p.passed:
                            kinds[_kind(p.blocked_by, small)] += 1
                            print(
                                f"{path.stem}/{clutter}/{world.name}: {p.joint} {p.kind} reached {p.reached_share:.0%} "
                                f"blocked by {p.blocked_by} (pushed {p.pushed_m * 100:.1f} cm)",
                                flush=True,
                            )
    parts = [p for p in pulls if not p.room_door]
    leaves = [p for p in pulls if p.room_door]
    figures = {
        "parts": len(parts),
        "parts_open": sum(p.passed for p in parts),
        "open_share": round(sum(p.passed for p in parts) / max(len(parts), 1), 4),
        "leaves": len(leaves),
        "leaves_swing": sum(p.passed for p in leaves),
        "fastest_m_s": round(max((p.fastest_m_s for p in pulls), default=0.0), 3),
        "blocked_by": dict(sorted(kinds.items())),
        "seconds": round(time.perf_counter() - started, 1),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()

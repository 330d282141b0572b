"""Plausibility benchmark: would a person arrange the variants this way?

For every shipped PhyScene room, the 22-object test bedroom and the SAM3D office, ``generate``
runs offline (rules model) with ``--variants 5``; the base and its variants are then judged with
the metrics package's seating judge (written apart from the evolution's rules) and RelKeep per
kind. Figures per room and pooled (the last line is one JSON object):

* ``seats_square`` — fraction of seat placements (base and variants) square to their table side
  within 5 degrees; ``seats_on_side`` — of those, centre within the side's extent;
* ``sides_balanced`` — fraction of table placements whose long sides hold seats evenly (counts
  differ by at most one; tables with a long side against a wall are not judged);
* ``lamps_kept`` — fraction of (lamp, variant) pairs in which a lamp that hung over a group in the
  base still hangs over it (centre inside the group's footprints grown by 0.3 m);
* ``relkeep_min`` — the lowest RelKeep of any kind over the variants;
* ``div_iou`` / ``div_n`` — diversity of the five variants (``div_iou_max`` pooled);
* ``col_max`` / ``oob_max`` / ``nav_min`` — the physical metrics over base and variants;
* ``plausibility`` — per rule of ``metrics.plausibility`` (a TV faces its stand, is not on a bed's
  headboard wall nor behind a sofa, seats square), the lowest over the base and its variants.

Houses too: every shipped multi-room house (``data/houses/procthor`` and ``data/houses/held_out``)
runs the same way, and each rule's lowest figure over every room of the base and its five
whole-house variants is reported per house (``--no-houses`` skips them).

Run: ``.venv/bin/python benchmarks/plausibility.py [--only NAME] [--no-houses]``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import write_sam3d_example
from scenemosaic.metrics import PLAUSIBILITY_RULES, plausibility, seating_figures
from scenemosaic.scene import House, Scene, functional_holds, functional_relations

REPO = Path(__file__).resolve().parents[1]
PHYSCENE = sorted((REPO / "data" / "layouts" / "physcene").glob("*.json"))
BEDROOM22 = REPO / "tests" / "fixtures" / "bedroom_22.json"
HOUSES = [
    p for folder in ("procthor", "held_out") for p in sorted((REPO / "data" / "houses" / folder).glob("*.json"))
    if p.name != "SOURCES.json" and len(json.loads(p.read_text()).get("rooms", [])) > 1
]  # fmt: skip


def _rules(scenes: list[Scene]) -> dict[str, float]:
    """Each plausibility rule's lowest figure over ``scenes``."""
    rows = [plausibility(s) for s in scenes]
    return {k: min(r[k] for r in rows) for k in PLAUSIBILITY_RULES}


def _house(source: Path, out: Path) -> dict[str, Any]:
    t0 = time.perf_counter()
    result = generate(source, out, GenerateConfig(variants=5))
    base = result.scene
    assert isinstance(base, House)
    houses = [base, *(v for v in result.variants if isinstance(v, House))]
    rules = _rules([room for h in houses for room in h.rooms])
    return {"house": source.stem, "plausibility": rules, "plausibility_min": min(rules.values()), "variants": len(houses) - 1, "status": result.status, "seconds": round(time.perf_counter() - t0, 1)}


def _room(name: str, source: Path, out: Path) -> dict[str, Any]:
    t0 = time.perf_counter()
    result = generate(source, out, GenerateConfig(variants=5))
    base = result.scene
    assert isinstance(base, Scene)
    variants = [v for v in result.variants if isinstance(v, Scene)]
    metrics: dict[str, Any] = result.report.get("metrics", {})
    seating = seating_figures(base, [base, *variants])
    lamps = [r for r in functional_relations(base) if r.kind == "over" and "lamp" in base.get(r.subject).category]
    kept = [functional_holds(v, r) for r in lamps for v in variants]
    rels = functional_relations(base)
    broken = sorted({f"{r.kind}: {r.subject} -> {r.leader}" for r in rels for v in variants if not functional_holds(v, r)})
    by_kind = metrics.get("RelKeep_by_kind", {})
    rk = [v for v in by_kind.values() if v is not None]
    rows = [metrics.get("base", {}), *metrics.get("variants", [])]
    div = metrics.get("diversity", {})
    return {
        "room": name,
        **seating,
        "lamps": len(lamps),
        "lamps_kept": round(sum(kept) / len(kept), 4) if kept else 1.0,
        "relkeep_by_kind": by_kind,
        "relkeep_min": min(rk) if rk else 1.0,
        "broken": broken,
        "div_iou": div.get("Div-IoU"),
        "div_n": div.get("Div-N"),
        "col_max": max(r.get("COL", 0.0) for r in rows),
        "oob_max": max(r.get("OOB", 0.0) for r in rows),
        "nav_min": min(r.get("NAV", 1.0) for r in rows),
        "plausibility": _rules([base, *variants]),
        "variants": len(variants),
        "status": result.status,
        "seconds": round(time.perf_counter() - t0, 1),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=None, help="run only rooms (and houses) whose name contains this")
    parser.add_argument("--no-houses", action="store_true", help="judge the rooms only")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="plausibility_"))
    inputs: dict[str, Path] = {p.stem: p for p in PHYSCENE}
    inputs["bedroom_22"] = BEDROOM22
    inputs["sam3d_office"] = write_sam3d_example(work / "sam3d_input", REPO / "data" / "sam3d_objects")
    rooms = [_room(n, p, work / n) for n, p in inputs.items() if not args.only or args.only in n]
    for r in rooms:
        print(json.dumps(r))
    houses = [] if args.no_houses else [_house(p, work / p.stem) for p in HOUSES if not args.only or args.only in p.stem]
    for h in houses:
        print(json.dumps(h))
    seats = sum(r["seats"] for r in rooms)
    tables = sum(r["tables"] for r in rooms)
    lamps = sum(r["lamps"] * r["variants"] for r in rooms)
    divs = [r["div_iou"] for r in rooms if r["div_iou"] is not None and r["room"] in {p.stem for p in PHYSCENE}]

    def pooled(key: str, weight: str) -> float:
        total = sum(r[weight] for r in rooms)
        return round(sum(r[key] * r[weight] for r in rooms) / total, 4) if total else 1.0

    figures = {
        "rooms": len(rooms),
        "seats": seats,
        "seats_square": pooled("seats_square", "seats"),
        "seats_on_side": pooled("seats_on_side", "seats"),
        "sides_balanced": pooled("sides_balanced", "tables") if tables else 1.0,
        "lamps_kept": round(sum(r["lamps_kept"] * r["lamps"] * r["variants"] for r in rooms) / lamps, 4) if lamps else 1.0,
        "relkeep_min": min(r["relkeep_min"] for r in rooms),
        "div_iou_max": max(divs) if divs else None,
        "div_n_min": min(r["div_n"] for r in rooms if r["div_n"] is not None),
        "col_max": max(r["col_max"] for r in rooms),
        "oob_max": max(r["oob_max"] for r in rooms),
        "nav_min": min(r["nav_min"] for r in rooms),
        "plausibility_min": min([min(r["plausibility"].values()) for r in rooms] + [h["plausibility_min"] for h in houses]),
        "houses": {h["house"]: h["plausibility_min"] for h in houses},
        "per_room": {r["room"]: {k: r[k] for k in ("seats_square", "seats_on_side", "sides_balanced", "lamps_kept", "relkeep_min", "div_iou", "div_n")} for r in rooms},
        "seconds": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

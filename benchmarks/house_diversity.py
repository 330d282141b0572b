"""House diversity benchmark: are a house's variants ones a designer would draw, and all valid?

Every shipped multi-room house: those the solver was shaped on (``data/houses/procthor``) and the
held-out ones it was not (every other folder of ``data/houses``: ``held_out``, ``schema_forms``;
reported apart), and every house file in the
folders given with ``--extra`` (group ``extra``), runs
``generate --variants 5`` offline (rules model, seed 0). Per house:

* ``div_iou`` / ``div_n`` — the house's diversity over its five variants (``metrics.house_diversity``);
* ``rooms_moved`` / ``rooms_movable`` — rooms in which some variant moves a piece of furniture
  (``metrics.moved_furniture``: a non-fixture floor piece with at least 0.15 m² of footprint, by
  0.3 m or 20 degrees) / rooms that have such a piece; ``rooms_still`` names the others;
* ``room_div_iou_max`` — the highest per-room Div-IoU among the bedrooms, living rooms and dining
  rooms with at least 4 m² of free floor: floor that neither furniture nor a door's or passage's
  clearance zone takes (``room_div_iou`` lists them; ``free_floor`` gives every such room's);
* ``plausibility_min`` — the lowest ``PLAUS`` (``metrics.plausibility``) of any room of any variant;
* ``min_novelty`` — the smallest selection distance between variants (``MIN_NOVELTY`` is the floor);
* validity over base and variants: ``col_max``, ``oob_max``, ``nav_min`` (per room),
  ``house_nav_min``, ``door_blockers``, ``unreachable``, ``relkeep_min``; ``status``, ``seconds``.

The last line is one JSON object: per house the figures above, and pooled ``houses``,
``div_iou_max`` over houses of 3+ rooms (shipped, held-out and extra apart), ``rooms_moved`` / ``rooms_movable``,
``plausibility_min``, ``seconds``.

With ``--forms`` it runs instead the houses of other generators' forms (group ``forms``; issue
54), written from held-out houses: the Holodeck house joined from two real Holodeck rooms
(``tests/holodeck_helpers.py``), two held-out houses in ProcTHOR-Objaverse's form and one in a
fork's base-``y`` form (``tests/house_forms.py``), and a ``.jsonl.gz`` dataset of three held-out
houses, each run by its index.

Run: ``.venv/bin/python benchmarks/house_diversity.py [--only NAME] [--extra DIR ...] [--forms]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from shapely.geometry import Polygon
from shapely.ops import unary_union

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import load_scene
from scenemosaic.metrics import furniture, moved_furniture
from scenemosaic.scene import FLOOR, House, Scene, door_zones, is_thin

REPO = Path(__file__).resolve().parents[1]
HOUSES = REPO / "data" / "houses"
SHIPPED = HOUSES / "procthor"
FREE_FLOOR_M2 = 4.0
"""Rooms with at least this much free floor are held to the per-room diversity bar, square metres."""
ROOM_TYPES = ("bedroom", "livingroom", "living_room", "diningroom", "dining_room")


def _free_floor(room: Scene) -> float:
    """The floor furniture could stand on: the room's floor less the footprints of what stands on
    it and less the clearance zones in front of its doors and open passages (``scene.door_zones``:
    floor no piece may take), square metres."""
    if room.room is None:
        return 0.0
    floor = Polygon(room.room.floor)
    feet = [Polygon(o.footprint()) for o in room.objects if not is_thin(o) and (room.support_of(o.id) is None or room.support_of(o.id).parent == FLOOR)]  # type: ignore[union-attr]
    feet += [z.polygon for z in (*door_zones(room), *door_zones(room, kinds=("opening",)))]
    return float(floor.difference(unary_union(feet)).area) if feet else float(floor.area)


def _forms(folder: Path) -> list[tuple[Path, str, int | None, str]]:
    """The houses of other generators' forms (issue 54), written into ``folder`` from held-out
    houses and the shipped Holodeck rooms: (path, name, dataset index, form)."""
    sys.path.insert(0, str(REPO))
    from tests.dataset_helpers import write_dataset
    from tests.holodeck_helpers import holodeck_house
    from tests.house_forms import base_form, objaverse_form

    held = HOUSES / "held_out"
    folder.mkdir(parents=True, exist_ok=True)
    out: list[tuple[Path, str, int | None, str]] = [(holodeck_house(folder / "holodeck_house.json"), "holodeck_house", None, "holodeck")]
    for name in ("zg_houses20_house_15", "mq_hallway_3"):
        target = folder / f"objaverse_{name}.json"
        objaverse_form(held / f"{name}.json", target)
        out.append((target, target.stem, None, "procthor-objaverse"))
    target = folder / "base_y_mq_temp.json"
    out.append((base_form(held / "mq_temp.json", target), target.stem, None, "base-y fork"))
    dataset = write_dataset(folder / "held_out.jsonl.gz", [held / f"{n}.json" for n in ("zg_houses20_house_0", "zg_houses20_house_6", "mq_hallway_0")])
    out += [(dataset, f"held_out.jsonl.gz#{i}", i, "dataset") for i in range(3)]
    return out


def _house(path: Path, out: Path, group: str, index: int | None = None, name: str | None = None) -> dict[str, Any]:
    t0 = time.perf_counter()
    result = generate(path, out, GenerateConfig(variants=5, index=index))
    seconds = round(time.perf_counter() - t0, 1)
    report = result.report
    base = load_scene(out, allow_partial=False)
    assert isinstance(base, House)
    variants = [load_scene(out, variant=i) for i in range(1, len(result.variants) + 1)]
    metrics = report.get("metrics", {})
    rooms_metrics = metrics.get("rooms", {})
    moved = movable = 0
    still: list[str] = []
    room_div: dict[str, float] = {}
    free: dict[str, float] = {}
    plaus, cols, oobs, navs, relkeeps = [], [], [], [], []
    for k, room in enumerate(base.rooms):
        if furniture(room):
            movable += 1
            if moved_furniture(room, [v.rooms[k] for v in variants if isinstance(v, House)]):
                moved += 1
            else:
                still.append(room.id)
        rm = rooms_metrics.get(room.id, {})
        rows = [rm.get("base", {}), *rm.get("variants", [])]
        plaus += [r.get("PLAUS", 1.0) for r in rows]
        cols += [r.get("COL", 0.0) for r in rows]
        oobs += [r.get("OOB", 0.0) for r in rows]
        navs += [r.get("NAV", 1.0) for r in rows]
        relkeeps += [r["RelKeep"] for r in rm.get("variants", []) if r.get("RelKeep") is not None]
        rtype = str(report.get("rooms", {}).get(room.id, {}).get("room_type") or "").lower()
        div = (rm.get("diversity") or {}).get("Div-IoU")
        if div is not None and rtype in ROOM_TYPES and _free_floor(room) >= FREE_FLOOR_M2:
            room_div[f"{room.id} ({rtype})"] = div
        if rtype in ROOM_TYPES:
            free[f"{room.id} ({rtype})"] = round(_free_floor(room), 2)
    house = metrics.get("house", {})
    rows = [house.get("base", {}), *house.get("variants", [])]
    compose: dict[str, Any] = next((s["detail"] for s in report.get("stages", []) if s["name"] == "compose"), {})
    return {
        "house": name or path.stem,
        "group": group,
        "rooms": len(base.rooms),
        "objects": len(base.objects),
        "status": result.status,
        "variants": len(variants),
        "div_iou": (house.get("diversity") or {}).get("Div-IoU"),
        "div_n": (house.get("diversity") or {}).get("Div-N"),
        "rooms_moved": moved,
        "rooms_movable": movable,
        "rooms_still": still,
        "room_div_iou_max": max(room_div.values()) if room_div else None,
        "room_div_iou": room_div,
        "free_floor": free,
        "plausibility_min": min(plaus) if plaus else 1.0,
        "min_novelty": min(compose.get("min_distances") or [0.0]),
        "col_max": max(cols, default=0.0),
        "oob_max": max(oobs, default=0.0),
        "nav_min": min(navs, default=1.0),
        "house_nav_min": min((r.get("house_nav", 1.0) for r in rows), default=1.0),
        "door_blockers": sum(len(r.get("door_blockers") or []) if isinstance(r.get("door_blockers"), list) else int(r.get("door_blockers") or 0) for r in rows),
        "unreachable": sum(len(r.get("unreachable_rooms") or []) for r in rows),
        "relkeep_min": min(relkeeps, default=1.0),
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=None, help="run only houses whose name contains this")
    parser.add_argument("--extra", type=Path, nargs="*", default=[], help="folders of house files not tuned on")
    parser.add_argument("--forms", action="store_true", help="only the houses of other generators' forms (group forms)")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="house_diversity_"))
    inputs = [(p, "shipped") for p in sorted(SHIPPED.glob("*.json")) if p.name != "SOURCES.json"]
    for folder in sorted(p for p in HOUSES.iterdir() if p.is_dir() and p != SHIPPED):  # held_out, schema_forms, ...
        inputs += [(p, "held_out") for p in sorted(folder.glob("*.json")) if p.name != "SOURCES.json"]
    for folder in args.extra:
        inputs += [(p, "extra") for p in sorted(folder.glob("*.json")) if p.name != "SOURCES.json"]
    rows = []
    if args.forms:
        inputs = []
        for path, name, index, _ in _forms(work / "forms"):
            if args.only and args.only not in name:
                continue
            row = _house(path, work / name.replace("#", "_"), "forms", index, name)
            print(json.dumps(row), flush=True)
            rows.append(row)
    for path, group in inputs:
        if args.only and args.only not in path.stem:
            continue
        data = json.loads(path.read_text())
        if len(data.get("rooms", [])) < 2:
            continue  # a one-room house is a room: benchmarks/plausibility.py covers rooms
        row = _house(path, work / path.stem, group)
        print(json.dumps(row), flush=True)
        rows.append(row)

    def worst(key: str, group: str, pick: Any = max) -> Any:
        vals = [r[key] for r in rows if r["group"] == group and r["rooms"] >= 3 and r[key] is not None]
        return pick(vals) if vals else None

    figures = {
        "houses": len(rows),
        "ok": sum(r["status"] == "ok" for r in rows),
        "div_iou_max_shipped": worst("div_iou", "shipped"),
        "div_iou_max_held_out": worst("div_iou", "held_out"),
        "div_iou_max_extra": worst("div_iou", "extra"),
        "div_iou_max_forms": max((r["div_iou"] for r in rows if r["group"] == "forms" and r["div_iou"] is not None), default=None),
        "house_nav_min": min((r["house_nav_min"] for r in rows), default=1.0),
        "room_div_iou_max": max((r["room_div_iou_max"] for r in rows if r["room_div_iou_max"] is not None), default=None),
        "rooms_moved": sum(r["rooms_moved"] for r in rows),
        "rooms_movable": sum(r["rooms_movable"] for r in rows),
        "plausibility_min": min((r["plausibility_min"] for r in rows), default=1.0),
        "min_novelty": min((r["min_novelty"] for r in rows), default=None),
        "col_max": max((r["col_max"] for r in rows), default=0.0),
        "oob_max": max((r["oob_max"] for r in rows), default=0.0),
        "nav_min": min((r["nav_min"] for r in rows), default=1.0),
        "door_blockers": sum(r["door_blockers"] for r in rows),
        "unreachable": sum(r["unreachable"] for r in rows),
        "relkeep_min": min((r["relkeep_min"] for r in rows), default=1.0),
        "per_house": {r["house"]: {k: r[k] for k in ("group", "rooms", "div_iou", "div_n", "rooms_moved", "rooms_movable", "rooms_still", "room_div_iou_max", "plausibility_min", "status", "seconds")} for r in rows},
        "seconds": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""A ProcTHOR house rewritten as other generators write theirs (issue 54's tests and
``benchmarks/house_diversity.py --forms``): ProcTHOR-Objaverse's (Objaverse assets and an
``objectType`` on every object), and a fork's that puts every position at the bottom of its box."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from scenemosaic.exchange import load_asset_database
from tests.dataset_helpers import house_items

HOUSES = Path(__file__).resolve().parents[1] / "data" / "houses" / "procthor"
FOUR_ROOMS = HOUSES / "procthor_4room.json"
BEDROOM = HOUSES / "procthor_1room_bedroom.json"


def objaverse_form(source: Path, path: Path, *, every: int = 2, unknown: str | None = None) -> dict[str, str]:
    """``source`` as ProcTHOR-Objaverse writes it: every object an ``objectType``, every ``every``-th
    one (in file order) an Objaverse asset (a 32-hex id, type ``Obja<Type>``; ``unknown`` instead of
    the type for the first). Returns the changed objects' ids in the file -> their AI2-THOR type."""
    db = load_asset_database(None)
    house = json.loads(source.read_text(encoding="utf-8"))
    changed: dict[str, str] = {}
    count = 0

    def walk(items: list[dict]) -> None:
        nonlocal count
        for item in items:
            kind = db.types[item["assetId"]]
            item["objectType"] = kind
            if count % every == 0:
                item["assetId"] = hashlib.md5(item["assetId"].encode()).hexdigest()
                item["objectType"] = unknown if unknown is not None and not changed else "Obja" + kind
                changed[item["id"]] = kind
            count += 1
            walk(item.get("children") or [])

    walk(house["objects"])
    path.write_text(json.dumps(house), encoding="utf-8")
    return changed


def base_form(source: Path, path: Path) -> Path:
    """``source`` as the fork writes it: every position at the bottom of its box, not its centre."""
    db = load_asset_database(None)
    house = json.loads(source.read_text(encoding="utf-8"))
    for item in house_items(house["objects"]):
        item["position"]["y"] -= db.boxes[item["assetId"]][1] / 2
    path.write_text(json.dumps(house), encoding="utf-8")
    return path


"""Every room with free floor varies, whatever its type holds (issue 54, item 7): a bedroom with no
bed, a living room with no sofa. Rooms of shipped houses with their lead pieces taken out (and, as
the issue met it, a bedroom holding only a dresser and a coffee table) are generated with
variants: their furniture must move, and the variants stay valid."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from shapely.geometry import Point, Polygon

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import load_scene
from scenemosaic.metrics import furniture, moved_furniture
from scenemosaic.scene import Scene

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"
COFFEE_TABLE = {"assetId": "Coffee_Table_206_1", "kinematic": False, "rotation": {"x": 0, "y": 0, "z": 0}, "children": []}


def _rewritten(source: str, room: str, keep: tuple[str, ...], add: list[dict], path: Path) -> Path:
    """``source`` with ``room`` holding only its pieces whose asset starts with one of ``keep``
    (and its wall decor), and ``add`` put in."""
    house = json.loads((HOUSES / source).read_text(encoding="utf-8"))
    floor = next(Polygon([(p["x"], p["z"]) for p in r["floorPolygon"]]) for r in house["rooms"] if r["id"] == room)
    house["objects"] = [
        o for o in house["objects"]
        if not floor.buffer(0.05).contains(Point(o["position"]["x"], o["position"]["z"])) or o["assetId"].startswith((*keep, "Wall_Decor"))
    ] + add  # fmt: skip
    path.write_text(json.dumps(house), encoding="utf-8")
    return path


CASES = {
    # the issue's: a 26 m² bedroom holding a dresser and a coffee table, no bed
    "bedroom, dresser and coffee table": ("procthor_6room.json", "room|6", ("Dresser",), [{**COFFEE_TABLE, "id": "added|0", "position": {"x": 8.4, "y": 0.2356, "z": 9.3}}]),
    "bedroom without its bed": ("procthor10k_train4_4room.json", "room|4", ("Dining_Table", "RoboTHOR_office_chair", "Dog_Bed", "RoboTHOR_dresser"), []),
    "living room without its sofa": ("procthor10k_train4_4room.json", "room|7", ("TV_Stand", "Dining_Table", "Chair", "Shelving_Unit", "Cart"), []),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_room_without_its_lead_piece_still_varies(tmp_path: Path, case: str) -> None:
    source, room, keep, add = CASES[case]
    house = _rewritten(source, room, keep, add, tmp_path / "house.json")
    result = generate(house, tmp_path / "run", GenerateConfig(room=room, variants=3, seed=0))
    assert result.status == "ok", result.report.get("warnings")
    base = load_scene(tmp_path / "run")
    assert isinstance(base, Scene) and furniture(base)
    variants = [load_scene(tmp_path / "run", variant=i) for i in range(1, len(result.variants) + 1)]
    assert len(variants) == 3
    moved = moved_furniture(base, [v for v in variants if isinstance(v, Scene)])
    assert set(moved) == set(furniture(base)), f"never moved: {sorted(set(furniture(base)) - set(moved))}"
    for v in result.report["metrics"]["variants"]:
        assert v["COL"] == 0 and v["OOB"] == 0 and v["NAV"] >= 0.99

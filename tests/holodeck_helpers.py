"""Helpers of the Holodeck tests: a multi-room Holodeck house joined from two real single-room
outputs (``data/layouts/holodeck``), as Holodeck writes a house: one file, its rooms, walls, doors,
windows and objects side by side, the plan and the bookkeeping keys merged room by room."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

HOLODECK = Path(__file__).resolve().parents[1] / "data" / "layouts" / "holodeck"
BEDROOM = HOLODECK / "lmg_holodeck_cozy_bedroom.json"
DINING = HOLODECK / "lmg_holodeck_dining_room.json"
DOOR_WIDTH_M = 1.0


def _shift(value: Any, dx: float) -> Any:
    """Every ``{x, y, z}`` point of a JSON value moved by ``dx`` along x (footprint vertices are
    in centimetres: ``[x, z]`` pairs moved by ``100 dx``)."""
    if isinstance(value, dict):  # a hole runs along its own wall from the wall's first point: not shifted
        out = {k: v if k == "holePolygon" else _shift(v, dx) for k, v in value.items()}
        if {"x", "y", "z"} <= set(value) and all(isinstance(value[k], int | float) for k in "xyz"):
            out["x"] = value["x"] + dx
        if "vertices" in value and isinstance(value["vertices"], list):
            out["vertices"] = [[p[0] + 100 * dx, p[1]] for p in value["vertices"]]
        return out
    if isinstance(value, list):
        return [_shift(v, dx) for v in value]
    return value


def holodeck_house(path: Path, first: Path = BEDROOM, second: Path = DINING) -> Path:
    """Write at ``path`` a two-room Holodeck house: ``second``'s room placed east of ``first``'s,
    their floors meeting along ``first``'s east edge, a door between them at the middle of the
    shorter room's side. The rooms' own doors and windows are kept, moved with their walls."""
    a = json.loads(first.read_text(encoding="utf-8"))
    b = json.loads(second.read_text(encoding="utf-8"))
    width = max(p["x"] for p in a["rooms"][0]["floorPolygon"])
    depth_a = max(p["z"] for p in a["rooms"][0]["floorPolygon"])
    depth_b = max(p["z"] for p in b["rooms"][0]["floorPolygon"])
    moved = {k: _shift(b[k], width) for k in ("rooms", "walls", "doors", "windows", "objects")}
    house = copy.deepcopy(a)
    for key in ("rooms", "walls", "doors", "windows", "objects"):
        house[key] = a[key] + moved[key]
    for key in ("floor_objects", "wall_objects", "small_objects"):
        house[key] = a.get(key, []) + _shift(b.get(key, []), width)
    for key in ("object_selection_plan", "selected_objects", "receptacle2small_objects"):
        house[key] = {**a.get(key, {}), **b.get(key, {})}
    room_a, room_b = a["rooms"][0]["id"], b["rooms"][0]["id"]
    east = next(w for w in a["walls"] if w["roomId"] == room_a and "exterior" not in w["id"]
                and all(abs(p["x"] - width) < 1e-6 for p in w["polygon"]))  # fmt: skip
    west = next(w for w in moved["walls"] if w["roomId"] == room_b and "exterior" not in w["id"]
                and all(abs(p["x"] - width) < 1e-6 for p in w["polygon"]))  # fmt: skip
    middle = min(depth_a, depth_b) / 2
    along = abs(middle - east["polygon"][0]["z"])  # a hole runs along its wall from the wall's first point
    house["doors"].append({
        "assetId": "Doorway_1", "id": f"door|{room_a}|{room_b}", "openable": True, "openness": 1,
        "room0": room_a, "room1": room_b, "wall0": east["id"], "wall1": west["id"],
        "holePolygon": [{"x": along - DOOR_WIDTH_M / 2, "y": 0, "z": 0}, {"x": along + DOOR_WIDTH_M / 2, "y": 2.1, "z": 0}],
    })  # fmt: skip
    house["query"] = f"{a.get('query', '')} / {b.get('query', '')}"
    path.write_text(json.dumps(house), encoding="utf-8")
    return path

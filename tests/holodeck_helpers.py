"""Helpers of the Holodeck tests: a multi-room Holodeck house joined from two real single-room
outputs (``data/layouts/holodeck``), as Holodeck writes a house: one file, its rooms, walls, doors,
windows and objects side by side, the plan and the bookkeeping keys merged room by room.

Holodeck places a room's doors before its furniture, so the one stretch of wall its furniture
leaves free is where its door is. The house joins the two rooms there: the dining room is turned
a quarter turn and set west of the bedroom so that its door (on its north wall) meets the
bedroom's (on its west wall), and the two become the one door between the rooms, as a house
generator would have drawn it."""

from __future__ import annotations

import copy
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

HOLODECK = Path(__file__).resolve().parents[1] / "data" / "layouts" / "holodeck"
BEDROOM = HOLODECK / "lmg_holodeck_cozy_bedroom.json"
DINING = HOLODECK / "lmg_holodeck_dining_room.json"

Point = Callable[[float, float], tuple[float, float]]
_KEYS = ("rooms", "walls", "doors", "windows", "objects", "floor_objects", "wall_objects", "small_objects")


def _moved(value: Any, to: Point, turn: float) -> Any:
    """Every ``{x, y, z}`` point of a JSON value taken by ``to`` (on x and z), every ``rotation``
    turned by ``turn`` degrees about y, every footprint ``vertices`` (centimetres, ``[x, z]``)
    taken along. A hole's polygon and a door's asset position run along their own wall from the
    wall's first point: they are not moved."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if k in ("holePolygon", "assetPosition"):
                out[k] = v
            elif k == "rotation" and isinstance(v, dict):
                out[k] = {**v, "y": (v.get("y", 0) + turn) % 360}
            elif k == "vertices" and isinstance(v, list):
                out[k] = [[100 * c for c in to(p[0] / 100, p[1] / 100)] for p in v]
            else:
                out[k] = _moved(v, to, turn)
        if {"x", "y", "z"} <= set(value) and all(isinstance(value[k], int | float) for k in "xyz"):
            out["x"], out["z"] = to(value["x"], value["z"])
        return out
    if isinstance(value, list):
        return [_moved(v, to, turn) for v in value]
    return value


def _door_centre(house: dict, door: dict) -> tuple[float, float]:
    """The (x, z) centre of a door's hole: along its ``wall0`` from the wall's first point."""
    wall = next(w for w in house["walls"] if w["id"] == door["wall0"])
    (x0, z0), (x1, z1) = ((p["x"], p["z"]) for p in (wall["polygon"][0], wall["polygon"][-2]))
    length = ((x1 - x0) ** 2 + (z1 - z0) ** 2) ** 0.5
    along = (door["holePolygon"][0]["x"] + door["holePolygon"][1]["x"]) / 2 / length
    return x0 + (x1 - x0) * along, z0 + (z1 - z0) * along


def holodeck_house(path: Path) -> Path:
    """Write at ``path`` the two-room Holodeck house of the module docstring and return it: the
    dining room turned so its north wall faces east and set west of the bedroom, the two rooms'
    exterior doors (each room's only door) made the one door between them."""
    bed = json.loads(BEDROOM.read_text(encoding="utf-8"))
    dining = json.loads(DINING.read_text(encoding="utf-8"))
    (bed_door,), (dining_door,) = bed["doors"], dining["doors"]
    bx, bz = _door_centre(bed, bed_door)
    dx, dz = _door_centre(dining, dining_door)
    depth = max(p["z"] for p in dining["rooms"][0]["floorPolygon"])  # the dining room's north wall: z = depth
    # a quarter turn, (x, z) -> (z, -x): the north wall stands at x = depth, east of the room; then
    # the room set so that its door meets the bedroom's, the bedroom east of it (shifted by depth)
    shift_z = bz - (-dx)
    turned = {k: _moved(dining.get(k, []), lambda x, z: (z, -x + shift_z), 90.0) for k in _KEYS}
    moved = {k: _moved(bed.get(k, []), lambda x, z: (x + depth, z), 0.0) for k in _KEYS}
    assert abs(dz - depth) < 1e-6 and abs(bx) < 1e-6, "the doors: the dining room's on its north wall, the bedroom's on its west"
    house = copy.deepcopy(bed)
    for key in _KEYS:
        house[key] = [*turned[key], *moved[key]]
    house["doors"] = [d for d in house["doors"] if d["id"] not in (bed_door["id"], dining_door["id"])]
    for key in ("object_selection_plan", "selected_objects", "receptacle2small_objects"):
        house[key] = {**dining.get(key, {}), **bed.get(key, {})}
    room_bed, room_dining = bed["rooms"][0]["id"], dining["rooms"][0]["id"]
    inner = next(w for w in moved["walls"] if w["id"] == bed_door["wall1"])  # the bedroom's side of its west wall
    other = next(w for w in turned["walls"] if w["id"] == dining_door["wall1"])  # the dining room's side of its north wall
    start = inner["polygon"][0]["z"]
    hole = [abs(p - start) for p in (bz - 0.5 * _width(bed_door), bz + 0.5 * _width(bed_door))]
    house["doors"].append({
        "assetId": bed_door["assetId"], "id": f"door|{room_bed}|{room_dining}", "openable": True, "openness": 1,
        "room0": room_bed, "room1": room_dining, "wall0": inner["id"], "wall1": other["id"],
        "holePolygon": [{"x": min(hole), "y": 0, "z": 0}, {"x": max(hole), "y": bed_door["holePolygon"][1]["y"], "z": 0}],
    })  # fmt: skip
    house["query"] = f"{bed.get('query', '')} / {dining.get('query', '')}"
    path.write_text(json.dumps(house), encoding="utf-8")
    return path


def _width(door: dict) -> float:
    return float(door["holePolygon"][1]["x"] - door["holePolygon"][0]["x"])

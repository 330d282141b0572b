"""Acceptance of whole-house runs: every shipped ProcTHOR house, generated with five variants.

Each house is generated once (module-scoped fixture, ``rules`` model). The checks then read only
the delivered files (``base/`` and ``variant_<i>/``: the house MJCF and each room's
``scene.json``) and measure them with geometry written here, not with the package's own checks:

* MuJoCo contacts of the house MJCF: no two objects, and no object and a wall, overlap deeper
  than ``PENETRATION_M`` (pairs MuJoCo does not test because both bodies are fixed to the world
  are measured with ``mj_geomDistance``);
* each object's box footprint lies on its room's floor (a wall-hung object may reach a little
  further, into the wall it hangs on);
* the rectangle in front of every door, ``DOOR_DEPTH_M`` deep, holds no object one walks into;
* a robot of ``ROBOT_RADIUS_M`` gets from every room to every other on a raster of our own;
* the report's figures: diversity measured, every variant distinct from the others, RelKeep kept.

The shipped one-room house runs as a one-room run (``base/scene.json``); it gets the same checks.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import shapely
from scipy import ndimage
from shapely.geometry import MultiPoint, Point, Polygon
from shapely.ops import unary_union

from scenemosaic.pipeline import GenerateConfig, generate

HOUSES_DIR = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"
HOUSE_FILES = sorted(HOUSES_DIR.glob("procthor*.json"))
VARIANTS = 5

PENETRATION_M = 0.005
"""Deepest overlap (metres) two touching bodies may show: things resting on each other touch at ~0."""
FLOOR_GROWTH_M = 0.01
"""How far (metres) a footprint may reach past its room's floor polygon (float noise)."""
WALL_HUNG_REACH_M = 0.05
"""How far (metres) an object with a relation to a wall may reach past the floor (into its wall)."""
DOOR_DEPTH_M = 0.6
"""Depth (metres) of the zone kept clear in front of a door, as wide as the door."""
DOOR_OVERLAP_M2 = 1e-4
"""Largest footprint area (m²) allowed inside a door's zone (1 cm²: touching is fine)."""
WALK_UNDER_M = 2.0
"""Objects whose bottom is at least this high (metres) are walked under."""
THIN_RATIO = 0.02
"""An object lower than this share of its larger planar size is walked over (a rug)."""
CELL_M = 0.05
"""Side (metres) of a cell of the walkable raster."""
ROBOT_RADIUS_M = 0.2
"""Radius (metres) of the robot that must get from room to room."""
DOOR_MATCH_M = 0.03
"""Slack (metres) when pairing two rooms' cuts through one wall."""


# -- reading what was delivered --------------------------------------------------------------------


@dataclass(frozen=True)
class Thing:
    """One object as the delivered ``scene.json`` places it."""

    id: str
    room: str
    footprint: Polygon
    bottom: float
    thin: bool
    wall_hung: bool
    pose: tuple[float, ...]

    @property
    def blocks_walking(self) -> bool:
        return self.bottom < WALK_UNDER_M and not self.thin


@dataclass(frozen=True)
class Cut:
    """A door or open stretch in one room's wall: its centre on the wall line, its direction along
    the wall, its normal into the room, its width, and the wall's thickness."""

    room: str
    wall: str
    kind: str
    centre: np.ndarray
    along: np.ndarray
    inward: np.ndarray
    width: float
    thickness: float


@dataclass(frozen=True)
class RoomPlan:
    id: str
    floor: Polygon
    cuts: list[Cut]
    things: list[Thing]


def _rotation(q: list[float]) -> np.ndarray:
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _thing(obj: dict[str, Any], room: str, wall_ids: set[str], relations: list[dict[str, Any]]) -> Thing:
    pose = obj["pose"]
    size = np.asarray(obj["asset"]["extents"], dtype=np.float64) * np.asarray(pose.get("scale", [1, 1, 1]), dtype=np.float64)
    sx, sy, sz = size
    box = np.array([[x, y, z] for x in (-sx / 2, sx / 2) for y in (-sy / 2, sy / 2) for z in (0.0, sz)])
    world = box @ _rotation(pose["quaternion"]).T + np.asarray(pose["position"], dtype=np.float64)
    hung = any(r["child"] == obj["id"] and r["parent"] in wall_ids for r in relations)
    return Thing(
        id=obj["id"],
        room=room,
        footprint=MultiPoint([tuple(p) for p in world[:, :2]]).convex_hull,
        bottom=float(world[:, 2].min()),
        thin=bool(sz < THIN_RATIO * max(sx, sy)),
        wall_hung=hung,
        pose=tuple(round(float(v), 5) for v in (*pose["position"], *pose["quaternion"])),
    )


def _room_plan(scene: dict[str, Any]) -> RoomPlan:
    room = scene["room"]
    floor = Polygon(room["floor"])
    cuts = []
    for wall in room["walls"]:
        start, end = np.asarray(wall["start"], dtype=np.float64), np.asarray(wall["end"], dtype=np.float64)
        along = (end - start) / np.linalg.norm(end - start)
        for op in wall["openings"]:
            if op["kind"] == "window":
                continue
            centre = start + along * op["center"]
            normal = np.array([-along[1], along[0]])
            # the side of the wall the floor is on, right at the cut (L-shaped rooms included)
            inward = normal if floor.contains(Point(*(centre + 0.05 * normal))) else -normal
            cuts.append(Cut(scene["id"], wall["id"], op["kind"], centre, along, inward, float(op["width"]), float(wall["thickness"])))
    wall_ids = {w["id"] for w in room["walls"]}
    things = [_thing(o, scene["id"], wall_ids, scene.get("relations", [])) for o in scene["objects"]]
    return RoomPlan(scene["id"], floor, cuts, things)


def delivered_rooms(folder: Path) -> list[RoomPlan]:
    """The rooms a delivered folder holds: a house's ``rooms/<id>/scene.json`` in its index's
    order, or a one-room run's ``scene.json``."""
    index = folder / "house_scene.json"
    if index.is_file():
        ids = json.loads(index.read_text(encoding="utf-8"))["rooms"]
        files = [folder / "rooms" / rid / "scene.json" for rid in ids]
    else:
        files = [folder / "scene.json"]
    return [_room_plan(json.loads(f.read_text(encoding="utf-8"))) for f in files]


# -- the runs --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HouseRun:
    name: str
    out: Path
    report: dict[str, Any]

    @property
    def folders(self) -> list[Path]:
        return [self.out / "base", *(self.out / f"variant_{i}" for i in range(1, VARIANTS + 1))]

    def plans(self) -> Iterator[tuple[str, list[RoomPlan]]]:
        for folder in self.folders:
            yield folder.name, delivered_rooms(folder)


@pytest.fixture(scope="module", params=HOUSE_FILES, ids=[p.stem for p in HOUSE_FILES])
def house_run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> HouseRun:
    """One generate run of a shipped house with five variants, shared by every check of it."""
    house: Path = request.param
    out = tmp_path_factory.mktemp(house.stem) / "out"
    generate(house, out, GenerateConfig(variants=VARIANTS, overwrite=True))
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    return HouseRun(house.stem, out, report)


def test_six_houses_are_shipped() -> None:
    assert len(HOUSE_FILES) == 6, HOUSE_FILES


# -- the checks ------------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.house
def test_run_delivers_a_base_and_five_distinct_variants(house_run: HouseRun) -> None:
    assert house_run.report["status"] != "failed", house_run.report.get("error")
    found = sorted(p.name for p in house_run.out.glob("variant_*") if p.is_dir())
    assert found == [f"variant_{i}" for i in range(1, VARIANTS + 1)], f"{house_run.name}: {found}"
    poses = {name: {t.id: t.pose for r in rooms for t in r.things} for name, rooms in house_run.plans()}
    base_ids = set(poses["base"])
    for name, placed in poses.items():
        assert set(placed) == base_ids, f"{house_run.name}/{name}: objects differ from the base's"
    same = [(a, b) for a, b in itertools.combinations(poses, 2) if poses[a] == poses[b]]
    assert not same, f"{house_run.name}: identical houses {same}"


def _owner(m: mujoco.MjModel, geom: int) -> str:
    """The object a geom belongs to (its top body's name), or the world geom's own name (``floor``,
    a wall piece such as ``room_2/wall_0/1``, a ceiling)."""
    body = int(m.geom_bodyid[geom])
    if body == 0:
        return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom{geom}"
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.body_rootid[body])) or f"body{body}"


def _penetrations(xml: Path) -> tuple[dict[tuple[str, str], float], set[str]]:
    """Deepest overlap (positive metres) per pair of owners deeper than ``PENETRATION_M``, and the
    names of the model's object bodies."""
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    owner = [_owner(m, g) for g in range(m.ngeom)]
    structure = [int(m.geom_bodyid[g]) == 0 for g in range(m.ngeom)]
    worst: dict[tuple[str, str], float] = {}

    def note(g1: int, g2: int, dist: float) -> None:
        a, b = owner[g1], owner[g2]
        if a == b or "floor" in (a, b) or (structure[g1] and structure[g2]) or dist >= -PENETRATION_M:
            return
        key = (min(a, b), max(a, b))
        worst[key] = max(worst.get(key, 0.0), -dist)

    for i in range(d.ncon):
        c = d.contact[i]
        note(int(c.geom1), int(c.geom2), float(c.dist))
    # MuJoCo never tests two bodies both fixed to the world (a fixed cabinet and a wall, two fixed
    # counters): measure those pairs directly when their bounding spheres meet
    collides = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    fixed = [g for g in collides if m.body_weldid[m.geom_bodyid[g]] == 0 and owner[g] != "floor"]
    for g1, g2 in itertools.combinations(fixed, 2):
        if owner[g1] == owner[g2] or (structure[g1] and structure[g2]):
            continue
        if np.linalg.norm(d.geom_xpos[g1] - d.geom_xpos[g2]) > m.geom_rbound[g1] + m.geom_rbound[g2]:
            continue
        note(g1, g2, float(mujoco.mj_geomDistance(m, d, g1, g2, 0.05, None)))
    bodies = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or "" for b in range(1, m.nbody) if m.body_parentid[b] == 0}
    return worst, bodies


@pytest.mark.slow
@pytest.mark.house
def test_no_object_overlaps_another_or_a_wall_in_the_house_mjcf(house_run: HouseRun) -> None:
    problems = []
    for name, rooms in house_run.plans():
        worst, bodies = _penetrations(house_run.out / name / "scene.xml")
        missing = sorted({t.id for r in rooms for t in r.things} - bodies)
        if missing:
            problems.append(f"{name}: objects missing from scene.xml: {missing[:8]}")
        problems += [f"{name}: {a} x {b} overlap {depth * 1000:.1f} mm" for (a, b), depth in sorted(worst.items())]
    assert not problems, f"{house_run.name}: " + "; ".join(problems)


REST_SECONDS = 2.0
"""Simulated time (seconds) the delivered house must stay at rest."""
REST_MOVE_M = 0.01
"""The most (metres) any free body of the house may move in that time."""


@pytest.mark.slow
@pytest.mark.house
def test_the_house_mjcf_stays_at_rest_in_plain_mujoco(house_run: HouseRun) -> None:
    """The base house as a user loads it: plain MuJoCo, gravity on, two seconds; nothing moves 1 cm."""
    m = mujoco.MjModel.from_xml_path(str(house_run.out / "base" / "scene.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    free = [b for b in range(1, m.nbody) if m.body_jntnum[b] and m.jnt_type[m.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE]
    assert free, f"{house_run.name}: no free body in the house MJCF"
    start = {b: d.xpos[b].copy() for b in free}
    moved = dict.fromkeys(free, 0.0)
    for _ in range(round(REST_SECONDS / m.opt.timestep)):
        mujoco.mj_step(m, d)
        for b in free:
            moved[b] = max(moved[b], float(np.linalg.norm(d.xpos[b] - start[b])))
    worst = sorted(((v, mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)) for b, v in moved.items()), reverse=True)[:5]
    assert worst[0][0] < REST_MOVE_M, f"{house_run.name}: moved most: {[(n, round(v, 4)) for v, n in worst]}"


@pytest.mark.slow
@pytest.mark.house
def test_every_object_stays_on_its_room_floor(house_run: HouseRun) -> None:
    problems = []
    for name, rooms in house_run.plans():
        for room in rooms:
            grown = room.floor.buffer(FLOOR_GROWTH_M, join_style="mitre")
            hung = room.floor.buffer(WALL_HUNG_REACH_M, join_style="mitre")
            for t in room.things:
                if not (hung if t.wall_hung else grown).covers(t.footprint):
                    past = max(room.floor.distance(Point(p)) for p in t.footprint.exterior.coords)
                    problems.append(f"{name}/{room.id}: {t.id} reaches {past:.3f} m past the floor")
    assert not problems, f"{house_run.name}: " + "; ".join(problems)


def _door_zone(cut: Cut) -> Polygon:
    half, deep = cut.along * (cut.width / 2), cut.inward * DOOR_DEPTH_M
    c = cut.centre
    return Polygon([tuple(c - half), tuple(c + half), tuple(c + half + deep), tuple(c - half + deep)])


@pytest.mark.slow
@pytest.mark.house
def test_every_door_clearance_zone_is_free(house_run: HouseRun) -> None:
    problems = []
    doors = 0
    for name, rooms in house_run.plans():
        for room in rooms:
            for cut in (c for c in room.cuts if c.kind == "door"):
                doors += 1
                zone = _door_zone(cut)
                for t in room.things:
                    area = t.footprint.intersection(zone).area if t.blocks_walking else 0.0
                    if area > DOOR_OVERLAP_M2:
                        problems.append(f"{name}/{room.id}/{cut.wall}: {t.id} covers {area * 1e4:.0f} cm² of the door zone")
    assert doors > 0, f"{house_run.name}: no door found"
    assert not problems, f"{house_run.name}: " + "; ".join(problems)


def _passages(rooms: list[RoomPlan]) -> list[Polygon]:
    """The hole through the wall for every pair of cuts of two rooms that face each other across
    the wall: antiparallel walls, one wall's thickness apart, overlapping along the wall."""
    cuts = [c for r in rooms for c in r.cuts]
    out = []
    for a, b in itertools.combinations(cuts, 2):
        if a.room == b.room or float(np.dot(a.along, b.along)) > -0.99:
            continue
        gap = float(np.dot(b.centre - a.centre, -a.inward))  # from a's wall line out of a's room
        if abs(gap - a.thickness) > DOOR_MATCH_M:
            continue
        offset = float(np.dot(b.centre - a.centre, a.along))
        lo, hi = max(-a.width / 2, offset - b.width / 2), min(a.width / 2, offset + b.width / 2)
        if hi - lo <= 2 * ROBOT_RADIUS_M:
            continue
        # reach a cell into each floor so the passage and both floors join on the raster
        p0, p1 = a.centre + a.along * lo, a.centre + a.along * hi
        inner, outer = a.inward * CELL_M, -a.inward * (gap + CELL_M)
        out.append(Polygon([tuple(p0 + inner), tuple(p1 + inner), tuple(p1 + outer), tuple(p0 + outer)]))
    return out


def _disconnected_rooms(rooms: list[RoomPlan]) -> str | None:
    """``None`` when one connected piece of eroded free floor enters every room, else what splits."""
    passages = _passages(rooms)
    region = unary_union([r.floor for r in rooms] + passages)
    minx, miny, maxx, maxy = region.bounds
    xs = np.arange(minx - CELL_M, maxx + 2 * CELL_M, CELL_M) + CELL_M / 2
    ys = np.arange(miny - CELL_M, maxy + 2 * CELL_M, CELL_M) + CELL_M / 2
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    room_cells = {r.id: shapely.intersects_xy(r.floor, gx, gy) for r in rooms}
    inside = np.logical_or.reduce([*room_cells.values(), *(shapely.intersects_xy(p, gx, gy) for p in passages)])
    blocked = np.zeros_like(inside)
    for t in (t for r in rooms for t in r.things if t.blocks_walking):
        blocked |= shapely.intersects_xy(t.footprint, gx, gy)
        for x, y in t.footprint.exterior.coords:  # a footprint smaller than a cell still blocks its cell
            i, j = int((x - xs[0]) / CELL_M + 0.5), int((y - ys[0]) / CELL_M + 0.5)
            if 0 <= i < len(xs) and 0 <= j < len(ys):
                blocked[i, j] = True
    k = round(ROBOT_RADIUS_M / CELL_M)
    di, dj = np.mgrid[-k : k + 1, -k : k + 1]
    disk = di * di + dj * dj <= k * k
    walk = ndimage.binary_erosion(inside & ~blocked, structure=disk, border_value=0)
    labels, _ = ndimage.label(walk)
    pieces = {rid: set(np.unique(labels[cells & walk]).tolist()) - {0} for rid, cells in room_cells.items()}
    if set.intersection(*pieces.values()):
        return None
    empty = sorted(rid for rid, p in pieces.items() if not p)
    if empty:
        return f"no walkable cell in {empty}"
    groups: dict[int, list[str]] = {}
    for rid, p in pieces.items():
        groups.setdefault(min(p), []).append(rid)
    return f"rooms split into {sorted(groups.values())} ({len(passages)} passages)"


@pytest.mark.slow
@pytest.mark.house
def test_every_room_is_reachable_from_every_other(house_run: HouseRun) -> None:
    problems = []
    for name, rooms in house_run.plans():
        split = _disconnected_rooms(rooms)
        if split:
            problems.append(f"{name}: {split}")
    assert not problems, f"{house_run.name}: " + "; ".join(problems)


@pytest.mark.slow
@pytest.mark.house
def test_report_measures_diversity_and_keeps_relations(house_run: HouseRun) -> None:
    report = house_run.report
    metrics = report["metrics"]
    figures = metrics.get("house", metrics)  # a one-room run reports its room's figures at the top
    assert {"Div-IoU", "Div-N"} <= set(figures["diversity"]), figures.get("diversity")
    compose = next(s for s in report["stages"] if s["name"] == "compose")
    distances = compose["detail"]["min_distances"]
    assert len(distances) == VARIANTS and all(d > 0 for d in distances), f"{house_run.name}: min_distances {distances}"
    keep = [v["RelKeep"] for v in figures["variants"]]
    assert len(keep) == VARIANTS, f"{house_run.name}: {len(keep)} variants measured"
    low = [(f"variant_{i}", k) for i, k in enumerate(keep, start=1) if k < 0.99]
    assert not low, f"{house_run.name}: RelKeep below 0.99: {low}"

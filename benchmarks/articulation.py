"""Articulation benchmark: furniture that opens, per shipped house, pulled the way a robot pulls it.

Run: ``.venv/bin/python benchmarks/articulation.py [HOUSE ...]`` (default: every house file of
``data/houses/procthor`` and every room of ``data/layouts/physcene``; a whole run pulls every part
of every house, minutes). A HOUSE is a house file, read as shipped (no generation), or a delivered
house folder (``out/house/base`` of ``scenemosaic generate``). With ``--generate`` every input
file is first generated (rules model, seed 0, no variants) and its delivered ``base`` measured:
the world a user gets, after stabilization (a PhyScene layout as shipped is imprecise: one of
its wardrobes stands 0.55 m into the floor). Per house:

* ``openable``: objects a person opens (a category whose stand-in has parts, or whose AI2-THOR
  type can open by the ProcTHOR priors, or a TV stand, side table or dressing table with drawer
  fronts); ``articulated``: objects whose stand-in has parts;
* ``pulls_passed`` / ``pulls_tried``: every part pulled at its handle in the house's own MuJoCo
  world (``write_house_mjcf``; 10 N for drawers and doors, 3 N plus its weight for a lid, 3 s), a
  pass when a drawer slides 80 % of its depth or a door or lid turns 90 degrees (a laptop's lid,
  built open, is pushed shut instead) and neither the
  object's bodies nor what it holds moves faster than 5 m/s (neighbours may block a door: such a
  failure is real; a house read as shipped has no supports yet, so a picture may fall off its
  wall meanwhile, which is not the pull's doing);
* ``seconds_added``: validation time of the house (``validate_scene``) with the parts on their
  joints less the same run with every object rigid;
* ``room_doors`` / ``room_door_leaves``: the rooms' doors the simulator exports hang on the
  doorways (``with_room_doors``, counted apart from the furniture above) and their leaves;
  ``leaf_pushes_passed`` / ``leaf_pushes_tried``: every leaf, delivered open, pushed shut at its
  handle (20 N, 4 s) in the house's MuJoCo world with its doors, a pass when it shuts to within
  10 degrees and no body of the door moves faster than 5 m/s.

The last line is JSON: the per-house figures and their totals.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import mujoco
import numpy as np
import structlog

from scenemosaic import GenerateConfig, generate
from scenemosaic.assets import PartSpec, object_articulation, room_door_leaves, with_room_doors
from scenemosaic.exchange import load_scene, load_scenes
from scenemosaic.physics import validate_scene, write_house_mjcf
from scenemosaic.scene import House, SceneObject, thor_type

ROOT = Path(__file__).resolve().parents[1]
ASSET_DATABASE = ROOT / "scenemosaic" / "scene" / "priors" / "procthor" / "asset-database.json"
PULL_N = {"drawer": 10.0, "door": 10.0, "lid": 3.0}
PULL_S = 3.0
LEAF_PUSH_N = 20.0
LEAF_PUSH_S = 4.0
LEAF_SHUT_DEG = 10.0
DRAWERED = {"tv_stand", "side_table", "corner_side_table", "console_table", "dressing_table"}


def _houses(args: list[str]) -> list[Path]:
    if args:
        return [Path(a) for a in args]
    procthor = sorted((ROOT / "data" / "houses" / "procthor").glob("*.json"))
    physcene = sorted((ROOT / "data" / "layouts" / "physcene").glob("*.json"))
    return [p for p in [*procthor, *physcene] if p.name != "SOURCES.json"]


def _opens(obj: SceneObject, can_open: set[str]) -> bool:
    if object_articulation(obj) or obj.category in DRAWERED:
        return True
    kind = thor_type(obj.category)
    return kind is not None and kind in can_open


def _push_shut(model: mujoco.MjModel, obj: SceneObject, part: PartSpec) -> bool:
    """A room door's leaf, delivered open, pushed shut at its handle: whether it shuts to within
    ``LEAF_SHUT_DEG`` and no body of the door moves faster than 5 m/s."""
    data = mujoco.MjData(model)
    watched = [b for b in range(model.nbody) if model.body(b).name.split("/")[0] == obj.id]
    mujoco.mj_forward(model, data)
    body = model.body(f"{obj.id}/{part.name}").id
    qpos = model.jnt_qposadr[model.joint(f"{obj.id}/{part.name}").id]
    handle = part.handle_centre - np.asarray(part.anchor)
    way = -np.cross(np.asarray(part.axis, dtype=np.float64), handle)
    way *= LEAF_PUSH_N / np.linalg.norm(way)
    fastest, previous = 0.0, data.xipos.copy()
    for _ in range(round(LEAF_PUSH_S / model.opt.timestep)):
        rotation = data.xmat[body].reshape(3, 3)
        data.qfrc_applied[:] = 0.0
        point = data.xpos[body] + rotation @ handle
        mujoco.mj_applyFT(model, data, rotation @ way, np.zeros(3), point, body, data.qfrc_applied)
        mujoco.mj_step(model, data)
        speeds = np.linalg.norm(data.xipos[watched] - previous[watched], axis=1) / model.opt.timestep
        fastest = max(fastest, float(speeds.max()))
        previous = data.xipos.copy()
    return math.degrees(float(data.qpos[qpos])) <= LEAF_SHUT_DEG and fastest < 5.0


def _pull(model: mujoco.MjModel, obj: SceneObject, part: PartSpec, held: list[str]) -> bool:
    data = mujoco.MjData(model)
    watched = [b for b in range(model.nbody) if model.body(b).name.split("/")[0] in {obj.id, *held}]
    mujoco.mj_forward(model, data)
    body = model.body(f"{obj.id}/{part.name}").id
    qpos = model.jnt_qposadr[model.joint(f"{obj.id}/{part.name}").id]
    handle = part.handle_centre - np.asarray(part.anchor)
    axis = np.asarray(part.axis, dtype=np.float64)
    way = axis if part.joint == "slide" else np.cross(axis, handle)
    way /= np.linalg.norm(way)
    if part.limits[1] <= 0.0:  # built open (a laptop's lid): pushed shut instead
        way = -way
    force = PULL_N[part.kind]
    if part.kind == "lid":  # hold its weight too
        rotation = data.xmat[body].reshape(3, 3)
        weight = np.array([0.0, 0.0, -9.81 * float(model.body_mass[body])])
        torque = abs(float((rotation @ axis) @ np.cross(data.xipos[body] - data.xpos[body], weight)))
        force += 1.2 * torque / max(float(np.linalg.norm(np.cross(axis, handle))), 1e-6)
    fastest, previous = 0.0, data.xipos.copy()
    for _ in range(round(PULL_S / model.opt.timestep)):
        rotation = data.xmat[body].reshape(3, 3)
        data.qfrc_applied[:] = 0.0
        point = data.xpos[body] + rotation @ handle
        mujoco.mj_applyFT(model, data, rotation @ way * force, np.zeros(3), point, body, data.qfrc_applied)
        mujoco.mj_step(model, data)
        speeds = np.linalg.norm(data.xipos[watched] - previous[watched], axis=1) / model.opt.timestep
        fastest = max(fastest, float(speeds.max()))
        previous = data.xipos.copy()
    value = abs(float(data.qpos[qpos]))
    opened = value >= 0.8 * part.depth if part.joint == "slide" else math.degrees(value) >= 90.0
    return opened and fastest < 5.0


def _can_open() -> set[str]:
    """AI2-THOR types of which some asset can open, by the ProcTHOR asset database."""
    database = json.loads(ASSET_DATABASE.read_text())
    return {
        kind
        for kind, assets in database.items()
        if any("CanOpen" in a.get("secondaryProperties", []) or "open" in a.get("states", {}) for a in assets)
    }


def _validation_seconds(house: House, base_dir: Path | None, *, articulated: bool) -> float:
    """``validate_scene``'s time, with the parts on their joints or (``articulated=False``) every
    object rigid, as before parts had joints."""
    start = time.perf_counter()
    if articulated:
        validate_scene(house, base_dir)
    else:
        with mock.patch("scenemosaic.physics._hulls.object_articulation", return_value=[]):
            validate_scene(house, base_dir)
    return time.perf_counter() - start


def _house(path: Path) -> tuple[House, Path | None]:
    if path.is_dir():
        loaded = load_scene(path)
        house = loaded if isinstance(loaded, House) else House(id=loaded.id, rooms=[loaded])
        return house, path
    return House(id=path.stem, rooms=load_scenes(path)), None


def measure(path: Path, delivered: Path | None = None) -> dict[str, object]:
    """The figures of one input (module docstring); ``delivered``: measure this delivered folder
    (the input generated) instead of the input as shipped."""
    house, base_dir = _house(delivered if delivered is not None else path)
    can_open = _can_open()
    objects = house.objects
    parts = [(o, p) for o in objects for p in object_articulation(o)]
    held = {
        o.id: [r.child for s in house.rooms for r in s.relations if r.parent == o.id and r.kind in ("attach", "contain")]
        for o in objects
    }
    doors = room_door_leaves(house)
    with tempfile.TemporaryDirectory() as folder:
        model = mujoco.MjModel.from_xml_path(str(write_house_mjcf(house, Path(folder) / "house", base_dir)))
        hung = with_room_doors(house)
        assert isinstance(hung, House)
        with_doors = mujoco.MjModel.from_xml_path(str(write_house_mjcf(hung, Path(folder) / "doors", base_dir)))
    passed = sum(_pull(model, o, p, held[o.id]) for o, p in parts)
    leaves = [(d.object, p) for d in doors for p in object_articulation(d.object)]
    pushed = sum(_push_shut(with_doors, o, p) for o, p in leaves)
    rigid = _validation_seconds(house, base_dir, articulated=False)
    jointed = _validation_seconds(house, base_dir, articulated=True)
    return {
        "house": path.name,
        "objects": len(objects),
        "openable": sum(_opens(o, can_open) for o in objects),
        "articulated": sum(bool(object_articulation(o)) for o in objects),
        "parts": len(parts),
        "pulls_passed": passed,
        "pulls_tried": len(parts),
        "seconds_added": round(jointed - rigid, 3),
        "room_doors": len(doors),
        "room_door_leaves": len(leaves),
        "leaf_pushes_passed": pushed,
        "leaf_pushes_tried": len(leaves),
    }


def main() -> None:
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(40))
    args = [a for a in sys.argv[1:] if a != "--generate"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="scenemosaic-articulation-") as tmp:
        for k, path in enumerate(_houses(args)):
            delivered = None
            if "--generate" in sys.argv[1:] and path.is_file():
                out = Path(tmp) / f"{k}_{path.stem}"
                generate(path, out, GenerateConfig(model="rules"))
                delivered = out / "base"
            row = measure(path, delivered)
            row["generated"] = delivered is not None
            print(row, flush=True)
            rows.append(row)
    totals: dict[str, float] = {
        key: sum(int(r[key]) for r in rows)  # type: ignore[call-overload]
        for key in (
            "objects", "openable", "articulated", "pulls_passed", "pulls_tried",
            "room_doors", "room_door_leaves", "leaf_pushes_passed", "leaf_pushes_tried",
        )
    }  # fmt: skip
    totals["seconds_added"] = round(sum(float(r["seconds_added"]) for r in rows), 3)  # type: ignore[arg-type,misc]
    print(json.dumps({"houses": rows, "totals": totals}))


if __name__ == "__main__":
    main()

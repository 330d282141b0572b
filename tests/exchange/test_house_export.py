"""Whole-house exports: one MuJoCo world, USD stage, URDF, GLB and sceneState for a house, and the
delivered house folder.

The house is two rooms of the shipped 6-room ProcTHOR house (the kitchen and the living room,
joined by a door), each settled by ``stabilize_scene`` as a run settles it. Objects the one-room
checks already flag (crossing a wall, colliding, or moving in the one-room simulation) are dropped,
so what is left is at rest in its own room: the house world must keep it at rest. Geometry is
checked from the written files alone (MuJoCo's compiled boxes, USD's world transforms, the
doorway the scene model computes), not from the exporter's own helpers.
"""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from scenemosaic.assets import object_articulation, room_door_leaves, with_room_doors
from scenemosaic.exceptions import UsageError
from scenemosaic.exchange import (
    GLB_ROOT_NODE,
    HOUSE_INDEX_FILE,
    HOUSE_ROOMS_DIR,
    deliver_scene,
    delivered_files,
    delivery_parts,
    export_glb,
    export_house_folder,
    export_sceneeval,
    export_usd,
    formats_left_out,
    load_scenes,
    read_house,
    write_scene,
)
from scenemosaic.physics import check_collisions, stabilize_scene, validate_scene, write_house_mjcf
from scenemosaic.render import house_wall_pieces
from scenemosaic.scene import Doorway, House, Opening, Room, Scene, quat_to_matrix, wall_crossings

HOUSE_JSON = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_6room.json"
ROOMS = ("room_8", "room_9")
REST_SECONDS = 2.0
REST_TOLERANCE_M = 0.01
RESTLESS_ALONE_M = 0.002
"""An object moving more than this in its own room's simulation is left out of the test house."""

Box = tuple[np.ndarray, np.ndarray, np.ndarray]
"""A box as (centre (3,), rotation (3, 3) whose columns are its axes, half sizes (3,))."""


def _without(scene: Scene, drop: set[str]) -> Scene:
    """``scene`` less the objects in ``drop``, what stands on them, and relations naming them."""
    gone = set(drop)
    grew = True
    while grew:
        before = len(gone)
        gone |= {r.child for r in scene.relations if r.parent in gone}
        grew = len(gone) > before
    return scene.model_copy(
        update={
            "objects": [o for o in scene.objects if o.id not in gone],
            "relations": [r for r in scene.relations if r.child not in gone and r.parent not in gone],
            "constraints": [],
            "structure": None,
        }
    )


@pytest.fixture(scope="module")
def house() -> House:
    by_id = {s.id: s for s in load_scenes(HOUSE_JSON)}
    rooms = []
    for room_id in ROOMS:
        scene, _ = asyncio.run(stabilize_scene(by_id[room_id], base_dir=None, seed=0))
        crossing = {oid for _, oid, _ in wall_crossings(scene)}
        colliding = {oid for pair in check_collisions(scene, None).pairs for oid in (pair.a, pair.b)}
        scene = _without(scene, crossing | colliding)
        moving = {m.object_id for m in validate_scene(scene).motions if m.displacement_m > RESTLESS_ALONE_M}
        rooms.append(_without(scene, moving))
    out = House(id="two_bedrooms", rooms=rooms)
    assert min(len(s.objects) for s in out.rooms) >= 5  # enough left to mean something
    return out


@pytest.fixture(scope="module")
def doorway(house: House) -> Doorway:
    (door,) = [d for d in house.doorways() if set(d.rooms) == set(ROOMS)]
    return door


@pytest.fixture(scope="module")
def mjcf(house: House, tmp_path_factory: pytest.TempPathFactory) -> mujoco.MjModel:
    xml = write_house_mjcf(house, tmp_path_factory.mktemp("house_mjcf"))
    assert xml.name == "scene.xml" and (xml.parent / "mjcf").is_dir()
    return mujoco.MjModel.from_xml_path(str(xml))


def _mjcf_walls(model: mujoco.MjModel) -> dict[str, Box]:
    """Every wall box of the compiled model (named ``<room id>/<wall id>...``), in world coordinates."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    out = {}
    for g in range(model.ngeom):
        name = model.geom(g).name
        if "/" in name and "/ceiling" not in name:
            assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX, name
            out[name] = (
                data.geom_xpos[g].copy(),
                data.geom_xmat[g].reshape(3, 3).copy(),
                model.geom_size[g].copy(),
            )
    return out


def _contains(box: Box, point: np.ndarray, margin: float = 1e-6) -> bool:
    centre, rotation, half = box
    local = rotation.T @ (np.asarray(point, dtype=np.float64) - centre)
    return bool(np.all(np.abs(local) <= half + margin))


def _footprint(box: Box) -> tuple[Polygon, float, float]:
    """The box's outline seen from above and its height range (the boxes here stand upright)."""
    centre, rotation, half = box
    corners = [
        centre + rotation @ (half * np.array([sx, sy, 0.0]))
        for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))
    ]
    return Polygon([(c[0], c[1]) for c in corners]), float(centre[2] - half[2]), float(centre[2] + half[2])


def _assert_door_open(walls: dict[str, Box], door: Doorway) -> None:
    passage = door.passage().buffer(-0.002, join_style="mitre")
    assert passage.area > 0.5 * 0.08  # at least 50 cm wide, through the wall's thickness
    for name, box in walls.items():
        outline, z0, z1 = _footprint(box)
        if z0 < door.height - 0.01 and z1 > 0.01:
            assert outline.intersection(passage).area < 1e-9, f"{name} stands in the doorway"
    # the wall stands on both sides of the hole, and above it
    x, y = (door.sides[0].centre + door.sides[-1].centre) / 2.0
    dx, dy = door.direction * (door.width / 2.0 + 0.05)
    for point in ((x + dx, y + dy, 1.0), (x - dx, y - dy, 1.0), (x, y, door.height + 0.1)):
        assert any(_contains(box, np.array(point)) for box in walls.values()), point


def test_house_mjcf_loads_in_plain_mujoco_and_stays_at_rest(house: House, mjcf: mujoco.MjModel) -> None:
    model = mjcf
    roots = {model.body(b).name for b in range(1, model.nbody) if model.body_parentid[b] == 0}
    assert roots == {o.id for o in house.objects}
    # the other bodies are the drawers, doors and lids of furniture that opens (docs/articulation.md)
    parts = {f"{o.id}/{p.name}" for o in house.objects for p in object_articulation(o)}
    assert {model.body(b).name for b in range(1, model.nbody)} - roots == parts
    rooms_named = {model.geom(g).name.split("/")[0] for g in range(model.ngeom) if "/" in model.geom(g).name}
    assert rooms_named == set(ROOMS)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    free = [
        b
        for b in range(1, model.nbody)
        if model.body_jntnum[b] == 1 and model.jnt_type[model.body_jntadr[b]] == 0
    ]
    assert len(free) >= 10
    start = data.xpos[free].copy()
    mujoco.mj_step(model, data, nstep=round(REST_SECONDS / model.opt.timestep))
    moved = np.linalg.norm(data.xpos[free] - start, axis=1)
    worst = int(np.argmax(moved))
    assert moved[worst] < REST_TOLERANCE_M, model.body(free[worst]).name


def test_the_door_between_the_rooms_is_a_hole_in_the_mjcf(mjcf: mujoco.MjModel, doorway: Doorway) -> None:
    _assert_door_open(_mjcf_walls(mjcf), doorway)


def test_a_shared_wall_is_simulated_once(house: House, mjcf: mujoco.MjModel, doorway: Doorway) -> None:
    """Along the wall the two rooms share, every point of the slab lies in exactly one wall box
    above the door, and in at most one beside it (none in the doorway itself)."""
    walls = _mjcf_walls(mjcf)
    middle = (doorway.sides[0].centre + doorway.sides[-1].centre) / 2.0
    # the slab between the two floors: where both floors, grown by a little over half its thickness, meet
    a, b = (Polygon(s.room.floor).buffer(0.06, join_style="mitre") for s in house.rooms if s.room is not None)
    line = LineString([tuple(middle - 30.0 * doorway.direction), tuple(middle + 30.0 * doorway.direction)])
    band = a.intersection(b).intersection(line.buffer(0.01, cap_style="flat"))
    band = next(g for g in getattr(band, "geoms", [band]) if g.distance(Point(middle)) < 1e-6)
    along = [float(np.dot(np.asarray(c) - middle, doorway.direction)) for c in band.exterior.coords]
    lo, hi = min(along) + 0.15, max(along) - 0.15  # away from the corners, where other walls meet it
    assert hi - lo > 2.0
    passage = doorway.passage()
    for t in np.linspace(lo, hi, 61):
        xy = middle + doorway.direction * t
        for z in (1.0, 2.5):
            count = sum(_contains(box, np.array([xy[0], xy[1], z])) for box in walls.values())
            in_door = passage.contains(Point(xy)) and z < doorway.height
            assert count == (0 if in_door else 1), (t, z, count)


def test_each_ceiling_covers_its_own_floor_and_no_other(house: House, mjcf: mujoco.MjModel) -> None:
    data = mujoco.MjData(mjcf)
    mujoco.mj_forward(mjcf, data)
    for scene in house.rooms:
        assert scene.room is not None
        floor = Polygon(scene.room.floor)
        outlines = []
        for g in range(mjcf.ngeom):
            if mjcf.geom(g).name.startswith(f"{scene.id}/ceiling"):
                box = (data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), mjcf.geom_size[g])
                outline, z0, _ = _footprint(box)
                assert z0 == pytest.approx(scene.room.ceiling_height, abs=1e-5)  # MJCF keeps ~6 digits
                assert floor.buffer(1e-5, join_style="mitre").contains(outline)
                outlines.append(outline)
        assert outlines
        assert unary_union(outlines).area == pytest.approx(floor.area, rel=1e-4)


def test_identical_walls_of_two_rooms_are_kept_once() -> None:
    """Two rooms drawn side by side, their shared wall cut by the same door on both sides: the
    first room keeps the wall (three boxes around the door), the second keeps nothing of it."""
    west = Room.rectangle(0.0, 0.0, 4.0, 3.0, ceiling_height=2.5)
    east = Room.rectangle(4.1, 0.0, 8.0, 3.0, ceiling_height=2.5)
    west_wall = next(w for w in west.walls if w.start[0] == w.end[0] == 4.0)
    east_wall = next(w for w in east.walls if w.start[0] == w.end[0] == 4.1)
    west_wall.openings = [Opening(kind="door", center=1.5, width=0.9, height=2.0)]
    east_wall.openings = [Opening(kind="door", center=1.5, width=0.9, height=2.0)]
    pieces = house_wall_pieces(House(rooms=[Scene(id="west", room=west), Scene(id="east", room=east)]))
    assert pieces[("east", east_wall.id)] == []
    kept = pieces[("west", west_wall.id)]
    assert len(kept) == 3
    solid = sum((p.s1 - p.s0) * (p.z1 - p.z0) for p in kept)
    assert solid == pytest.approx((3.0 + 0.2) * 2.5 - 0.9 * 2.0)
    # every other wall is its room's own, whole
    assert all(len(v) == 1 for k, v in pieces.items() if k[1] not in (west_wall.id, east_wall.id))


def test_house_usd_has_a_rigid_body_per_object_under_its_room(
    house: House, doorway: Doorway, tmp_path: Path
) -> None:
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.Open(str(export_usd(house, tmp_path)))
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    for scene in house.rooms:
        room = stage.GetPrimAtPath(f"/World/{scene.id}")
        assert room.IsValid() and room.GetCustomDataByKey("scenemosaic:roomId") == scene.id
        children = room.GetChild("Objects").GetChildren()
        prims = {p.GetCustomDataByKey("scenemosaic:objectId"): p for p in children if p.GetCustomDataByKey("scenemosaic:objectId")}
        assert set(prims) == {o.id for o in scene.objects}
        # beside them, a rigid body per drawer, door and lid of furniture that opens (docs/articulation.md)
        parts = {(p.GetCustomDataByKey("scenemosaic:partOf"), p.GetCustomDataByKey("scenemosaic:part")) for p in children if p.GetCustomDataByKey("scenemosaic:part")}
        assert parts == {(o.id, part.name) for o in scene.objects for part in object_articulation(o)}
        for obj in scene.objects:
            prim = prims[obj.id]
            rel = scene.support_of(obj.id)
            if rel is None or rel.parent == "floor" or scene.anchor_kind(rel.parent) == "object":
                assert prim.HasAPI(UsdPhysics.RigidBodyAPI) and prim.HasAPI(UsdPhysics.MassAPI), obj.id
            assert prim.GetChild("collision").IsValid(), obj.id  # its geometry layer is found
            world = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
            np.testing.assert_allclose(world, obj.pose.matrix(with_scale=False), atol=1e-9)
    # the walls are cut the same way: no wall cube in the doorway, walls beside it
    walls: dict[str, Box] = {}
    for prim in stage.Traverse():
        path = str(prim.GetPath())
        if prim.IsA(UsdGeom.Cube) and "/Room/" in path and "ceiling" not in path:
            assert prim.HasAPI(UsdPhysics.CollisionAPI) and not prim.HasAPI(UsdPhysics.RigidBodyAPI)
            m = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
            scale = np.linalg.norm(m[:3, :3], axis=0)
            walls[path] = (m[:3, 3], m[:3, :3] / scale, scale / 2.0)
    assert walls
    _assert_door_open(walls, doorway)


def test_house_glb_has_a_node_per_object_under_its_room(house: House, tmp_path: Path) -> None:
    glb = trimesh.load(export_glb(house, tmp_path / "scene.glb"))
    parents = glb.graph.transforms.parents
    for scene in house.rooms:
        assert parents[scene.id] == GLB_ROOT_NODE
        for obj in scene.objects:
            assert parents[obj.id] == scene.id, obj.id
            # the node's matrix relative to the room node is the object's rigid pose
            matrix, _ = glb.graph.get(obj.id, scene.id)
            np.testing.assert_allclose(matrix, obj.pose.matrix(with_scale=False), atol=1e-6)
        assert parents[f"{scene.id}/floor"] == scene.id and parents[f"{scene.id}/ceiling"] == scene.id


def test_house_sceneeval_holds_every_room_and_object(house: House, tmp_path: Path) -> None:
    state = json.loads(export_sceneeval(house, tmp_path).read_text())["scene"]
    elements = state["arch"]["elements"]
    assert sorted(e["roomId"] for e in elements if e["type"] == "Floor") == sorted(ROOMS)
    door_holes = [h for e in elements if e["type"] == "Wall" for h in e["holes"] if h["type"] == "Door"]
    assert len(door_holes) >= 2  # the shared door, seen from both rooms
    # a door hung in a doorway rides on the hole of each room it joins, never as an object
    hung = [h["leaf"] for h in door_holes if "leaf" in h]
    doors = room_door_leaves(house)
    assert doors and len(hung) == sum(len(d.rooms) for d in doors)
    assert {r["swingsInto"] for r in hung} == {d.room_id for d in doors}
    assert [o["id"] for o in state["object"]] == [o.id for o in house.objects]
    written = json.loads(write_scene(house, "sceneeval", tmp_path / "written").read_text())["scene"]
    assert [o["id"] for o in written["object"]] == [o.id for o in house.objects]
    assert [o["index"] for o in state["object"]] == list(range(len(house.objects)))


def _unity_centre(
    obj_pose: tuple[tuple[float, float, float], tuple[float, float, float, float]], height: float
) -> np.ndarray:
    """Unity (Y up) position of a ProcTHOR object: its box centre, (x, z, y) of ours."""
    position, quaternion = obj_pose
    centre = np.asarray(position) + quat_to_matrix(quaternion) @ np.array([0.0, 0.0, height / 2.0])
    return np.array([centre[0], centre[2], centre[1]])


def test_deliver_house_round_trips_and_writes_the_procthor_house_back(house: House, tmp_path: Path) -> None:
    folder = tmp_path / "base"
    written = deliver_scene(house, folder, None)
    expected = {HOUSE_INDEX_FILE, "scene.xml", "scene.urdf", "scene.glb", "topdown.png", "house.json"}
    expected |= {f"{HOUSE_ROOMS_DIR}/", "mjcf/", "urdf/", "sceneeval/"}
    if "usd" not in formats_left_out():
        expected |= {"scene.usda", "usd/"}
    assert expected <= set(written)
    index = json.loads((folder / HOUSE_INDEX_FILE).read_text())
    assert index["format"] == "scenemosaic-house" and index["version"] == 1 and index["rooms"] == list(ROOMS)
    assert all((folder / HOUSE_ROOMS_DIR / rid / "scene.json").is_file() for rid in ROOMS)
    hung = with_room_doors(house)  # the simulator files also hold the rooms' doors, each leaf a part
    parts = sum(len(object_articulation(o)) for o in hung.objects)
    assert mujoco.MjModel.from_xml_path(str(folder / "scene.xml")).nbody == 1 + len(hung.objects) + parts

    back = read_house(folder)
    assert back.id == house.id and back.room_ids == house.room_ids
    for before, after in zip(house.rooms, back.rooms, strict=True):
        assert [o.id for o in after.objects] == [o.id for o in before.objects]
        for a, b in zip(before.objects, after.objects, strict=True):
            np.testing.assert_allclose(b.pose.position, a.pose.position, atol=1e-12)
            np.testing.assert_allclose(b.pose.quaternion, a.pose.quaternion, atol=1e-12)

    # house.json: every object of both rooms at its settled pose; the other rooms as they were
    source = json.loads(HOUSE_JSON.read_text())
    written_back = json.loads((folder / "house.json").read_text())

    def flat(items: list[dict]) -> dict[str, dict]:
        out: dict[str, dict] = {}
        for item in items:
            out[str(item["id"])] = item
            out |= flat(item.get("children") or [])
        return out

    old, new = flat(source["objects"]), flat(written_back["objects"])
    assert set(old) == set(new)
    ours = {}
    for scene in house.rooms:
        for oid, raw in scene.provenance.source_ids.items():
            if any(o.id == oid for o in scene.objects):
                ours[str(raw)] = scene.get(oid)
    assert len(ours) == len(house.objects)
    moved = 0
    for raw, obj in ours.items():
        pose = (obj.pose.position, obj.pose.quaternion)
        centre = _unity_centre(pose, float(obj.asset.extents[2] * obj.pose.scale[2]))
        got = new[raw]["position"]
        np.testing.assert_allclose([got["x"], got["y"], got["z"]], centre, atol=2e-6)
        if abs(obj.pose.quaternion[1]) < 1e-9 and abs(obj.pose.quaternion[2]) < 1e-9:  # upright: yaw only
            unity_yaw = (180.0 - math.degrees(obj.pose.yaw)) % 360.0
            assert math.isclose(new[raw]["rotation"]["y"] % 360.0, unity_yaw, abs_tol=1e-4) or math.isclose(
                abs(new[raw]["rotation"]["y"] % 360.0 - unity_yaw), 360.0, abs_tol=1e-4
            ), raw
        moved += old[raw]["position"] != got
    assert moved > 0  # settling moved something, and the file says so
    assert all(new[raw] == item for raw, item in old.items() if raw not in ours)

    # last, as it may skip: the URDF loads, a link per object, per room, the floor and the world
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = yourdfpy.URDF.load(str(folder / "scene.urdf"), build_scene_graph=False, load_meshes=False)
    # drawers, doors, lids, and the rooms' doors with their leaves
    parts = {f"{o.id}/{p.name}" for o in hung.objects for p in object_articulation(o)}
    assert {o.id for o in hung.objects} | parts | set(ROOMS) | {"world", "floor"} == set(urdf.link_map)


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_house_delivered_in_two_halves_is_the_house_delivered_at_once(house: House, tmp_path: Path) -> None:
    """What a house run does in its two worker processes: the native house first, then two
    disjoint sets of parts, each written on its own; together they make the same files."""
    whole = tmp_path / "whole"
    written = deliver_scene(house, whole, None)
    halves = tmp_path / "halves"
    assert deliver_scene(house, halves, None, parts=()) == [HOUSE_INDEX_FILE, f"{HOUSE_ROOMS_DIR}/"]
    assert not (halves / "scene.xml").exists() and not (halves / "topdown.png").exists()
    first, second = ("mjcf", "usd", "glb"), tuple(p for p in delivery_parts() if p not in ("mjcf", "usd", "glb"))
    export_house_folder(halves, parts=second)
    assert (halves / "topdown.png").is_file() and not (halves / "scene.xml").exists()
    assert export_house_folder(halves, parts=first) == written == delivered_files(whole)
    assert _tree(halves) == _tree(whole)
    with pytest.raises(UsageError, match="no such delivery part: svg"):
        export_house_folder(halves, parts=["mjcf", "svg"])

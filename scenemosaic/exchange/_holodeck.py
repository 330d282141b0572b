"""Holodeck output: an AI2-THOR-style house (one room or several) with a flat object list and the LLM's plan.

A Holodeck file is a ProcTHOR house (``rooms``, ``walls``, ``doors``, ``windows``, ``objects``)
plus the generator's working state (``object_selection_plan``, ``floor_objects``,
``wall_objects``, ``small_objects``, ``receptacle2small_objects``...). Frames are AI2-THOR's
(Unity: left-handed, Y up) and are converted with the ProcTHOR importer's helpers, so an
object's ``position`` is the centre of its box and an upright object gets
``yaw = pi - radians(rotation.y)``.

Objects carry Objaverse asset uids whose meshes cannot be redistributed, and no size. Each
object becomes a procedural box-like asset of its category, sized by the first rule that
applies:

1. ``asset_database``: the asset's box, when the database knows the ``assetId`` (the ProcTHOR
   database shipped with the package holds the AI2-THOR assets Holodeck mixes in);
2. a floor (or unlisted, hand-added) object with ``vertices``: the footprint those vertices
   draw (centimetres, world x/z; measured along the object's own axes), and twice its centre
   height (it stands on the floor: Holodeck's own rule);
3. a wall object with ``vertices``: the same footprint, and the middle one of the three sizes
   the plan (``object_selection_plan``) asked for as its height, because the LLM does not keep
   the plan's ``[length, width, height]`` order for flat wall objects (paintings come as
   ``[width, height, depth]``);
4. a small object (id ``<name>|<parent id>``): a cube whose side is the largest horizontal
   extent of its asset, the one size ``receptacle2small_objects`` records.

Anything else raises :class:`ImportFormatError` naming the object. A small object's id names
its parent: it gets an ``attach`` relation to that object when it exists.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import structlog
from scipy.spatial.transform import Rotation
from shapely.geometry import Point, Polygon

from scenemosaic.exchange._common import FieldReader
from scenemosaic.exchange._procthor import (
    _HALF_TURN,
    _SWAP,
    AssetDatabase,
    _nearest_type,
    _RoomBuild,
    _unity_rotation,
    clear_shared_walls,
    house_rooms,
    load_asset_database,
    orphan_problems,
    room_for,
)
from scenemosaic.scene import (
    AssetRef,
    FloatArray,
    Pose,
    Provenance,
    Relation,
    Scene,
    SceneObject,
    coordinate_problem,
    normalize_category,
    sanitize_id,
    size_problem,
    unique_id,
)

__all__ = ["HOLODECK_KEYS", "import_holodeck", "looks_like_holodeck"]

log = structlog.get_logger(__name__)

IMPORTER = "scenemosaic.exchange.holodeck"
HOLODECK_KEYS = (
    "object_selection_plan",
    "selected_objects",
    "floor_objects",
    "wall_objects",
    "small_objects",
    "receptacle2small_objects",
)
"""Top-level keys only Holodeck writes; one of them (besides ``rooms`` and ``objects``) marks its output."""

Placement = Literal["floor", "wall", "small", "other"]
_ROOM_SUFFIX = re.compile(r"\s*\([^()]*\)\s*$")  # Holodeck ids end with " (<room id>)"
_INSTANCE = re.compile(r"-\d+$")  # "armchair-1" -> plan entry "armchair"
_MIN_EXTENT_M = 1e-6  # a footprint thinner than this is a line, not an object
_OFF_CENTRE_NOTE_M = 0.05  # footprint centre this far from the position: worth a note


def looks_like_holodeck(data: Any) -> bool:
    """Detection rule: a house with ``rooms`` and ``objects`` and one of :data:`HOLODECK_KEYS`.

    Such a file also passes the ProcTHOR test (``rooms`` with a ``floorPolygon``), so this rule
    must be tried first.
    """
    if not isinstance(data, dict) or not isinstance(data.get("rooms"), list):
        return False
    return isinstance(data.get("objects"), list) and any(k in data for k in HOLODECK_KEYS)


def import_holodeck(data: Any, path: Path, *, asset_database: Any = None, allow_orphans: bool = False) -> list[Scene]:
    """One :class:`Scene` of procedural objects per room of a parsed Holodeck output, in its room
    order: a single-room output (its scene named after the file, as Holodeck names its runs) or a
    whole house (each room named after its id: ``"living room"`` -> ``living_room``).

    The rooms, walls, doors and windows are read as a ProcTHOR house's are (``house_rooms``: shared
    edges cut back to one wall, every door and window cut into the rooms it joins). Each object
    goes to the room its id names (Holodeck ids end with `` (<room id>)``), else to the room its
    centre stands in. Object sizes follow the rules of the module docstring, each room reading its
    own part of the plan; ids are Holodeck's without the room suffix (``throw pillow-0|sofa-0
    (living room)`` -> ``throw_pillow-0_sofa-0``). Objects that share one position (the
    generator's failed small-object placement) are kept as given and listed in
    ``provenance.notes``; every size not taken from the asset database is listed in
    ``provenance.size_estimates``. A door or window onto a room the file does not hold is refused
    unless ``allow_orphans`` (as for ProcTHOR).

    Raises:
        ImportFormatError: naming the file and field for malformed input, or an object whose
            size none of the rules gives.
    """
    db = load_asset_database(asset_database)
    r = FieldReader(path)
    top = r.mapping(data, "")
    builds, strays = house_rooms(r, top)
    by_source = {b.source_id: b for b in builds}
    problems = orphan_problems([], strays, by_source)
    if problems and not allow_orphans:
        r.fail(
            "doors" if strays[0].startswith("doors") else "windows",
            "; ".join(text for text, _ in problems) + f" (is a room missing from {path.name}'s rooms?). "
            "To cut them into the rooms the house holds instead, allow orphans (generate --allow-orphans, "
            "load_scene(..., allow_orphans=True)); the run is then reported degraded",
        )
    warnings = [f"{text}: {done} (allow_orphans)" for text, done in problems]
    contexts = {b.source_id: _Context.read(r, top, b) for b in builds}
    items = r.objects(r.get(top, "objects", ""), "objects")
    raw_ids: list[str] = []
    for i, raw in enumerate(items):
        item = r.mapping(raw, f"objects[{i}]")
        raw_ids.append(r.text(r.get(item, "id", f"objects[{i}]"), f"objects[{i}].id"))
    taken: set[str] = set()
    oid_of: dict[str, str] = {}
    for i, raw_id in enumerate(raw_ids):
        if raw_id in oid_of:
            r.fail(
                f"objects[{i}].id", f"duplicate id {raw_id!r} (objects[{raw_ids.index(raw_id)}] has it too)"
            )
        oid_of[raw_id] = unique_id(sanitize_id(_ROOM_SUFFIX.sub("", raw_id)), taken)

    per_room: dict[str, _RoomObjects] = {b.source_id: _RoomObjects() for b in builds}
    room_of: dict[str, _RoomBuild] = {}
    for i, raw in enumerate(items):
        f = f"objects[{i}]"
        item = r.mapping(raw, f)
        build = _room_of(item, raw_ids[i], by_source, builds, r, f)
        room_of[raw_ids[i]] = build
        built = _object(r, item, f, oid_of[raw_ids[i]], contexts[build.source_id], db, build)
        obj = built.obj
        build.objects.append(obj)
        here = per_room[build.source_id]
        here.placements[obj.id] = built.placement
        here.size_sources[obj.id] = built.size_source
        here.asset_ids[obj.id] = built.asset_id
        here.centres[obj.id] = built.centre
        if built.size_source != "asset_database":
            build.size_estimates[obj.id] = f"{f} (asset {built.asset_id!r}): {_SIZE_SOURCES[built.size_source]}"
        if built.placement == "small":
            parent_raw = raw_ids[i].split("|", 1)[1]
            parent = oid_of.get(parent_raw)
            if parent is None:
                build.notes.append(
                    f"{f}: parent {parent_raw!r} named in its id is not in the file; no relation"
                )
            elif room_of.get(parent_raw, build) is not build:
                build.notes.append(f"{f}: parent {parent_raw!r} named in its id stands in another room; no relation")
            else:
                build.relations.append(Relation(kind="attach", child=obj.id, parent=parent, source=IMPORTER))

    for b in builds:
        _onto_receptacles(b, per_room[b.source_id])
    query = top.get("query")
    scenes = []
    for b in builds:
        here = per_room[b.source_id]
        _note_shared_positions(here.centres, here.placements, b.notes)
        clear_shared_walls(b)
        scenes.append(
            Scene(
                id=sanitize_id(path.stem, fallback="scene") if len(builds) == 1 else b.room.id,
                room=b.room,
                objects=b.objects,
                relations=b.relations,
                metadata={
                    "holodeck": {
                        "query": query if isinstance(query, str) else None,
                        "placement": here.placements,
                        "size_source": here.size_sources,
                    }
                },
                provenance=Provenance(
                    source_format="holodeck", source_path=path.as_posix(), importer=IMPORTER, notes=b.notes,
                    source_faults=b.faults, size_estimates=dict(b.size_estimates), room_type=b.room_type,
                    source_room_id=str(b.source_id), asset_ids={oid: str(a) for oid, a in here.asset_ids.items()},
                    source_ids={oid: raw for raw, oid in oid_of.items() if oid in here.asset_ids},
                    asset_database=db.source, import_warnings=list(warnings),
                ),
            )
        )  # fmt: skip
    log.debug("holodeck_imported", path=str(path), rooms=len(scenes), objects=sum(len(s.objects) for s in scenes))
    return scenes


_SIZE_SOURCES = {
    "small_object_type": "the proportions of its type's median box in the asset database, as wide as "
    "receptacle2small_objects records",
    "small_object_extent": "a cube of the largest extent receptacle2small_objects records",
    "small_object_receptacle": "as wide as receptacle2small_objects records, twice its centre's height over its "
    "receptacle's top tall",
    "vertices": "its footprint vertices, twice its centre's height tall",
    "vertices+plan_height": "its footprint vertices, the height the plan asked for",
    "plan": "the box its plan asked for (width the largest size, height the middle one, depth the least): "
    "its footprint vertices drew far less",
}
"""How each of the module's size rules (beside the asset database) reads in a size estimate."""


@dataclass
class _RoomObjects:
    """What the reader keeps about one room's objects besides the objects themselves."""

    placements: dict[str, Placement] = field(default_factory=dict)
    size_sources: dict[str, str] = field(default_factory=dict)
    asset_ids: dict[str, str] = field(default_factory=dict)
    centres: dict[str, tuple[float, float, float]] = field(default_factory=dict)


def _room_of(
    item: Mapping[str, Any], raw_id: str, by_source: Mapping[str, _RoomBuild], builds: list[_RoomBuild], r: FieldReader, f: str
) -> _RoomBuild:
    """The room an object belongs to: the one its id names (``... (living room)``), else the one
    its centre stands in (the nearest, with a note, when it stands in none)."""
    named = _ROOM_SUFFIX.search(raw_id)
    if named is not None:
        room = named.group(0).strip()[1:-1]
        if room in by_source:
            return by_source[room]
    x, _, z = r.xyz(r.get(item, "position", f), f"{f}.position")
    build, distance = room_for(builds, x, z)
    if distance > 0.0:
        build.notes.append(f"{f} lies outside every floor polygon; assigned to the nearest room")
    return build


# -- what the generator's working state tells about objects ----------------------------------------


@dataclass(frozen=True)
class _Context:
    """The parts of the file beside ``objects`` that size and classify them."""

    plan: Mapping[str, Any]
    """The room's ``object_selection_plan`` entries by object name (``armchair``)."""
    wall_ids: set[str]
    floor_ids: set[str]
    small_sizes: Mapping[str, Mapping[str, float]]
    """Receptacle id -> small object name -> largest horizontal extent of its asset (m)."""

    @classmethod
    def read(cls, r: FieldReader, top: Mapping[str, Any], build: _RoomBuild) -> _Context:
        plans = top.get("object_selection_plan")
        plan: Mapping[str, Any] = {}
        if isinstance(plans, Mapping):  # keyed by room type (Holodeck) or room id
            for key in (build.room_type, build.source_id):
                if isinstance(plans.get(key), Mapping):
                    plan = plans[key]
                    break

        def ids(key: str) -> set[str]:
            out = set()
            for entry in top.get(key) or []:
                if isinstance(entry, Mapping) and isinstance(entry.get("id"), str):
                    out.add(entry["id"])
            return out

        small: dict[str, dict[str, float]] = {}
        r2s = top.get("receptacle2small_objects")
        if isinstance(r2s, Mapping):
            for parent, rows in r2s.items():
                field = f"receptacle2small_objects.{parent}"
                for j, row in enumerate(r.array(rows, field)):
                    entry = r.array(row, f"{field}[{j}]")
                    if len(entry) < 3:
                        r.fail(f"{field}[{j}]", "expected [name, assetId, size]")
                    name = r.text(entry[0], f"{field}[{j}][0]")
                    size = r.number(entry[2], f"{field}[{j}][2]")
                    if size <= 0:
                        r.fail(f"{field}[{j}][2]", f"size must be positive, got {size}")
                    small.setdefault(str(parent), {})[name] = size
        return cls(plan, ids("wall_objects"), ids("floor_objects"), small)

    def plan_entry(self, name: str) -> Mapping[str, Any] | None:
        entry = self.plan.get(_INSTANCE.sub("", name))
        return entry if isinstance(entry, Mapping) else None


@dataclass(frozen=True)
class _Built:
    obj: SceneObject
    placement: Placement
    size_source: str
    asset_id: str
    centre: tuple[float, float, float]


def _object(
    r: FieldReader,
    item: Mapping[str, Any],
    f: str,
    oid: str,
    ctx: _Context,
    db: AssetDatabase,
    build: _RoomBuild,
) -> _Built:
    raw_id = r.text(r.get(item, "id", f), f"{f}.id")
    who = f"object {raw_id!r}"
    asset_id = r.text(r.get(item, "assetId", f), f"{f}.assetId")
    cx, cy, cz = r.xyz(r.get(item, "position", f), f"{f}.position")
    r.check(coordinate_problem((cx, cy, cz)), f"{f}.position", what=who)
    rx, ry, rz = r.xyz(item.get("rotation", {"x": 0.0, "y": 0.0, "z": 0.0}), f"{f}.rotation")
    core = _ROOM_SUFFIX.sub("", raw_id)
    small = "|" in raw_id
    name_raw = item.get("object_name")
    name = name_raw if isinstance(name_raw, str) and name_raw else core.split("|", 1)[0]
    plan = None if small else ctx.plan_entry(name)
    location = plan.get("location") if plan is not None else None
    placement: Placement
    if small:
        placement = "small"
    elif raw_id in ctx.wall_ids or (raw_id not in ctx.floor_ids and location == "wall"):
        placement = "wall"
    elif raw_id in ctx.floor_ids or location == "floor":
        placement = "floor"
    else:
        placement = "other"

    unity = _unity_rotation(rx, ry, rz)
    box, source = _size(
        r, item, f, raw_id, name, asset_id, placement, plan, (cx, cy, cz), unity, ctx, db, build
    )
    bx, by, bz = box
    r.check(size_problem((bx, bz, by)), f, what=f"{who}: size from {source}")
    rotation = _SWAP @ unity @ _SWAP @ _HALF_TURN
    centre = np.array([cx, cz, cy])
    if source == "plan":  # deeper than its footprint: its back stays where the footprint's was, on the wall
        wide, drawn, _ = _footprint(r, item["vertices"], f"{f}.vertices", unity)
        centre = centre + rotation @ np.array([0.0, -1.0, 0.0]) * (bz - drawn) / 2.0
        build.faults.append(
            f"{f} ({name}): its footprint vertices draw {wide:.2f} x {drawn:.2f} m, far below the "
            f"{bx:.2f} x {bz:.2f} m its plan asked for; sized as planned"
        )
    origin = centre - rotation @ np.array([0.0, 0.0, by / 2.0])
    if abs(rx) < 1e-9 and abs(rz) < 1e-9:
        pose = Pose.from_yaw(_vec3(origin), math.pi - math.radians(ry))  # exact for upright objects
    else:
        qx, qy, qz, qw = Rotation.from_matrix(rotation).as_quat()
        pose = Pose(position=_vec3(origin), quaternion=(float(qw), float(qx), float(qy), float(qz)))
    category = normalize_category(name)
    described = plan.get("description") if plan is not None else None
    description = described if isinstance(described, str) and described else name.replace("_", " ")
    obj = r.scene_object(
        f,
        who,
        id=oid,
        category=category,
        description=description[:500],
        asset=AssetRef(kind="procedural", category=category, extents=(bx, bz, by)),
        pose=pose,
    )
    return _Built(obj, placement, source, asset_id, (cx, cy, cz))


def _size(
    r: FieldReader,
    item: Mapping[str, Any],
    f: str,
    raw_id: str,
    name: str,
    asset_id: str,
    placement: Placement,
    plan: Mapping[str, Any] | None,
    centre: tuple[float, float, float],
    unity: FloatArray,
    ctx: _Context,
    db: AssetDatabase,
    build: _RoomBuild,
) -> tuple[tuple[float, float, float], str]:
    """The object's Unity-frame box (x, y up, z) and which rule gave it."""
    if asset_id in db.boxes:
        return db.boxes[asset_id], "asset_database"
    if placement == "small":
        child, parent = raw_id.split("|", 1)
        side = ctx.small_sizes.get(parent, {}).get(child)
        if side is None:
            r.fail(
                f"{f}.id",
                f"small object {raw_id!r} has no size: asset {asset_id!r} is not in the asset database and "
                f"receptacle2small_objects[{parent!r}] does not list {child!r}",
            )
        match = _nearest_type(_type_name(child), db.type_boxes)
        if match is not None:  # its type's proportions (a book lies flat), as wide as recorded
            tx, ty, tz = db.type_boxes[match]
            k = side / max(tx, tz)
            return (tx * k, ty * k, tz * k), "small_object_type"
        return (side, side, side), "small_object_extent"
    if "vertices" not in item:
        r.fail(
            f"{f}.vertices",
            f"object {raw_id!r} has no size: no footprint vertices and asset {asset_id!r} is not in the asset database",
        )
    bx, bz, mid = _footprint(r, item["vertices"], f"{f}.vertices", unity)
    if math.dist(mid, (centre[0], centre[2])) > _OFF_CENTRE_NOTE_M:
        build.notes.append(
            f"{f} ({name}): its footprint vertices are centred {math.dist(mid, (centre[0], centre[2])):.2f} m "
            "from its position; sizes taken from them, position kept"
        )
    if placement == "wall":
        planned = plan.get("size") if plan is not None else None
        if not isinstance(planned, list) or len(planned) != 3:
            r.fail(
                f"{f}.vertices",
                f"wall object {raw_id!r} has no height: asset {asset_id!r} is not in the asset database and "
                f"object_selection_plan gives no size for {_INSTANCE.sub('', name)!r}",
            )
        dims = sorted(r.number(v, f"object_selection_plan.{_INSTANCE.sub('', name)}.size") for v in planned)
        if dims[1] <= 0:
            r.fail(
                f"object_selection_plan.{_INSTANCE.sub('', name)}.size",
                f"sizes must be positive, got {planned}",
            )
        if max(bx, bz) < PLAN_TRUST * dims[2] / 100.0:  # a footprint far smaller than what was asked: the plan's box
            return (dims[2] / 100.0, dims[1] / 100.0, dims[0] / 100.0), "plan"
        return (bx, dims[1] / 100.0, bz), "vertices+plan_height"
    if centre[1] <= 0:
        r.fail(f"{f}.position.y", f"a floor object's centre must be above the floor, got {centre[1]}")
    return (bx, 2.0 * centre[1], bz), "vertices"


def _footprint(
    r: FieldReader, raw: Any, f: str, unity: FloatArray
) -> tuple[float, float, tuple[float, float]]:
    """Extents of the footprint (cm, world x/z) along the object's own x and z axes, and its centre (m)."""
    pts = r.array(raw, f)
    if len(pts) < 3:
        r.fail(f, f"a footprint needs at least 3 vertices, got {len(pts)}")
    xz = np.array([r.vector(p, 2, f"{f}[{j}]") for j, p in enumerate(pts)], dtype=np.float64) / 100.0
    axis_x = np.array([unity[0, 0], unity[2, 0]])
    axis_z = np.array([unity[0, 2], unity[2, 2]])
    along_x, along_z = xz @ axis_x, xz @ axis_z
    bx = float(along_x.max() - along_x.min())
    bz = float(along_z.max() - along_z.min())
    if bx <= _MIN_EXTENT_M or bz <= _MIN_EXTENT_M:
        r.fail(f, f"the footprint has zero width or depth ({bx:.3g} x {bz:.3g} m)")
    lo, hi = xz.min(axis=0), xz.max(axis=0)
    return bx, bz, (float(lo[0] + hi[0]) / 2.0, float(lo[1] + hi[1]) / 2.0)


# -- openings -------------------------------------------------------------------------------------


# -- notes ----------------------------------------------------------------------------------------


def _note_shared_positions(
    centres: Mapping[str, tuple[float, float, float]], placements: Mapping[str, Placement], notes: list[str]
) -> None:
    """Record objects stacked at one point (Holodeck's failed small-object placement); they stay as given."""
    groups: dict[tuple[float, ...], list[str]] = {}
    for oid, c in centres.items():
        groups.setdefault(tuple(round(v, 6) for v in c), []).append(oid)
    shared = [ids for ids in groups.values() if len(ids) > 1]
    if not shared:
        return
    small = [oid for oid, kind in placements.items() if kind == "small"]
    distinct = len({tuple(round(v, 6) for v in centres[oid]) for oid in small})
    head = (
        f"{len(small)} small objects sit at only {distinct} distinct positions"
        if distinct < len(small)
        else f"{sum(len(ids) for ids in shared)} objects share {len(shared)} positions"
    )
    listed = "; ".join(", ".join(ids) for ids in shared)
    notes.append(
        f"{head} (the generator stacked them); imported as given for later stages to separate. "
        f"Objects at one position: {listed}"
    )


PLAN_TRUST = 0.25
"""A wall object whose footprint vertices draw less than this share of the width its plan asked
for (a wall cabinet drawn 5 cm wide, planned 150) is sized by the plan instead."""
RECEPTACLE_REACH_M = 0.05
"""How far (m) outside its receptacle's footprint a small object's centre may stand and still be
on it; one farther off was not placed by the generator (:func:`_onto_receptacles`)."""


def _type_name(name: str) -> str:
    """A Holodeck object name as a type name: ``bedside reading book`` -> ``BedsideReadingBook``."""
    return "".join(w[:1].upper() + w[1:] for w in re.split(r"[^A-Za-z0-9]+", _INSTANCE.sub("", name)) if w)


def _onto_receptacles(build: _RoomBuild, here: _RoomObjects) -> None:
    """Each small object on the receptacle its id names. One whose centre stands off that
    receptacle (Holodeck leaves a small object it failed to place at another one's position, so
    several stack at one point) is put on it, centred on its top, for the stabilizer to lay out
    among the others there: a source fault, named. One standing on it whose size is only the
    cube of its recorded extent takes twice its centre's height over the receptacle's top as its
    height (the file's own cue) when that is a plausible height."""
    by_id = {o.id: o for o in build.objects}
    for rel in build.relations:
        if rel.kind != "attach" or here.placements.get(rel.child) != "small" or rel.parent not in by_id:
            continue
        child, parent = by_id[rel.child], by_id[rel.parent]
        top = float(parent.aabb()[1][2])
        foot = Polygon(parent.footprint())
        cx, cy = (float(v) for v in here.centres[child.id][::2])  # Unity x, z -> our x, y
        if not foot.buffer(RECEPTACLE_REACH_M).contains(Point(cx, cy)):
            px, py = (float(v) for v in foot.centroid.coords[0])
            lift = top - float(child.aabb()[0][2])
            x, y, z = child.pose.position
            child.pose = child.pose.model_copy(update={"position": (x + px - cx, y + py - cy, z + lift)})
            build.faults.append(
                f"{child.id}: stood {foot.distance(Point(cx, cy)):.2f} m off {parent.id}, the receptacle its id "
                "names (the generator did not place it); put on its top"
            )
            continue
        if here.size_sources.get(child.id) != "small_object_extent":
            continue
        height = 2.0 * (here.centres[child.id][1] - top)
        side = float(child.size[0])
        if 0.01 <= height <= 2.0 * side:
            x, y, z = child.pose.position
            child.asset = child.asset.model_copy(update={"extents": (side, side, height)})
            child.pose = child.pose.model_copy(update={"position": (x, y, top)})
            here.size_sources[child.id] = "small_object_receptacle"
            if child.id in build.size_estimates:  # "<field> (asset ...): <how>": the how is now this
                where = build.size_estimates[child.id].split(": ", 1)[0]
                build.size_estimates[child.id] = f"{where}: {_SIZE_SOURCES['small_object_receptacle']}"


def _vec3(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))

"""AI2-THOR / ProcTHOR / Holodeck house JSON: one :class:`Scene` per room.

Unity's frame is left-handed and Y-up: (x, y, z) with z forward. Swapping y and z gives our
right-handed Z-up world, so a floor point ``{x, z}`` is simply ``(x, z)`` on our floor. A
Unity rotation (Euler degrees, applied z, then x, then y) conjugated by that swap is a proper
rotation of our world; for the usual upright object it is ``-rotation.y`` about +Z. AI2-THOR
assets face their local +Z, i.e. +Y after the swap, so a half turn about Z maps our front
(-Y) onto it: upright objects get ``yaw = pi - radians(rotation.y)``.

Objects carry no size: each ``assetId`` is looked up in an asset database (the
``asset-database.json`` that ProcTHOR publishes: ``{objectType: [{assetId, boundingBox:
{x, y, z}}, ...]}``). ``position`` is the centre of the asset's bounding box.

Both published forms of the house schema are read (``metadata.schema``; a file without one is
the first form): ``1.0.0`` gives a door or window's hole as ``holePolygon`` and an exterior wall
the ``roomId`` ``"exterior"``; ``0.0.1`` gives the same hole as ``boundingBox`` ``{min, max}``
(with an ``assetOffset`` that only places the door's mesh in it) and an exterior wall the id of
the room it closes, its own id reading ``wall|exterior|...``. ProcTHOR's own upgrade from 0.0.1 to
1.0.0 keeps the hole's two corners as they are, so both forms give the same openings. Material
and colour fields, which changed shape between the two, are not read.
"""

from __future__ import annotations

import functools
import json
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import structlog
from pydantic import ValidationError
from scipy.spatial.transform import Rotation
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.exchange._common import FieldReader, read_json
from scenemosaic.exchange._dataset import dataset_entry
from scenemosaic.scene import (
    CLUTTER_METADATA,
    PROCTHOR_PRIORS_DIR,
    AssetRef,
    FloatArray,
    House,
    Opening,
    Pose,
    Provenance,
    Relation,
    Room,
    Scene,
    SceneObject,
    Wall,
    coordinate_problem,
    house_problem,
    object_count_problem,
    quat_to_matrix,
    sanitize_id,
    size_problem,
    unique_id,
    write_atomic,
)

__all__ = [
    "DEFAULT_CEILING_HEIGHT",
    "HOUSE_FILE",
    "OUTSIDE_ROOM_TOLERANCE_M",
    "SCHEMAS_READ",
    "SHARED_WALL_THICKNESS_M",
    "AssetDatabase",
    "export_procthor",
    "import_procthor",
    "load_asset_annotations",
    "load_asset_database",
    "looks_like_procthor",
]

log = structlog.get_logger(__name__)

DEFAULT_CEILING_HEIGHT = 2.5
"""Ceiling height (metres) of a room none of whose walls gives a height."""
IMPORTER = "scenemosaic.exchange.procthor"
_WALL_MATCH_TOL = 1e-3  # metres: an opening's point must lie this close to one of our walls
OPENING_CLIP_NOTE_M = 0.005
"""A door or window drawn further than this (metres) past the end of the wall it is cut in is
named in the import notes; every hole is cut only as wide as its wall goes (a door beside a corner
whose wall was cut back by half a shared wall runs past it; a hole wider than its wall is a
source error). One lying mostly past the wall's ends is dropped, named."""
MIN_SHARED_M = 0.05
"""An edge of a room's floor counts as shared with another room when at least this much of it (metres) is."""
SHARED_WALL_THICKNESS_M = 0.1
"""Thickness (metres) of a wall two rooms of a house share. AI2-THOR's walls have none: its rooms
meet on a line. Each room's floor is cut back by half this along every stretch of its boundary
another room shares, so the two rooms' walls there (each standing outside its own floor, this
thick) are the same slab, centred on the line: one wall, and neither room loses more floor than
half of it. Exterior walls keep the polygon as it is."""

OUTSIDE_ROOM_TOLERANCE_M = 0.1
"""How far (metres) outside every floor polygon a top-level object's centre may lie and still go to
the nearest room (with a provenance note): the thickness of a shared wall, so a piece hung on or
pushed against a wall belongs to the room it stands in. A centre farther out is an orphan: the
house lacks the room it stood in, and the import fails naming it unless ``allow_orphans``. (No
shipped house has a centre outside its floors at all.)"""
SCHEMAS_READ = ("0.0.1", "1.0.0")
"""The ``metadata.schema`` versions of the AI2-THOR / ProcTHOR house format this reader knows; a
later minor version of 1 is read as 1.0.0, a major version above 1 (the multi-floor schema 2.0.0
of some forks) is refused."""
OUTSIDE = "exterior"
"""The name a door or window gives the outside as its ``room0`` or ``room1`` (Holodeck; ProcTHOR
names the room itself twice)."""

# swaps Unity's y and z: Unity coordinates <-> our Z-up world (its own inverse)
_SWAP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
# our asset frame (front -Y) -> Unity asset frame after the swap (front +Y): half turn about Z
_HALF_TURN = np.diag([-1.0, -1.0, 1.0])


@dataclass(frozen=True)
class AssetDatabase:
    """Per-asset bounding boxes and object types, keyed by ``assetId``."""

    boxes: Mapping[str, tuple[float, float, float]]
    """Unity-frame bounding-box size (x, y, z) in metres; y is the height."""
    types: Mapping[str, str]
    """AI2-THOR object type (``"DiningTable"``...)."""
    source: str = ""

    @functools.cached_property
    def type_boxes(self) -> dict[str, tuple[float, float, float]]:
        """Each object type's median box over the database's assets of that type: what an asset
        it does not hold is sized by (:func:`_estimated_box`)."""
        by_type: dict[str, list[tuple[float, float, float]]] = {}
        for asset, kind in self.types.items():
            if asset in self.boxes:
                by_type.setdefault(kind, []).append(self.boxes[asset])
        return {kind: _median_box(rows) for kind, rows in by_type.items()}

    @functools.cached_property
    def type_footprints(self) -> dict[str, list[tuple[float, float]]]:
        """Each object type's footprints (x, z) an unknown asset's stand-in may shrink to when its
        median box does not fit where the file puts it (:func:`_fit_estimates`): the median's,
        then the 25th percentile's, then the smallest of the database's assets of that type."""
        by_type: dict[str, list[tuple[float, float, float]]] = {}
        for asset, kind in self.types.items():
            if asset in self.boxes:
                by_type.setdefault(kind, []).append(self.boxes[asset])
        out = {}
        for kind, rows in by_type.items():
            a = np.array(rows, dtype=np.float64)[:, [0, 2]]
            steps = [np.median(a, axis=0), np.percentile(a, 25, axis=0), a.min(axis=0)]
            out[kind] = [(float(x), float(z)) for x, z in steps]
        return out


def _median_box(rows: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in np.median(np.array(rows, dtype=np.float64), axis=0))
    return x, y, z


_DB_CACHE: dict[tuple[str, float], AssetDatabase] = {}


def load_asset_database(
    source: str | os.PathLike[str] | Mapping[str, Any] | AssetDatabase | None,
) -> AssetDatabase:
    """Load (and cache) an asset database from a path or a parsed mapping; ``None`` reads the
    database shipped with the package (``PROCTHOR_PRIORS_DIR / "asset-database.json"``).

    Accepted layouts: ``{objectType: [entry, ...]}`` (ProcTHOR's own), ``[entry, ...]`` or
    ``{assetId: entry}``, where an entry holds ``boundingBox: {x, y, z}`` and optionally
    ``assetId`` and ``objectType``.
    """
    if isinstance(source, AssetDatabase):
        return source
    if source is None:
        source = PROCTHOR_PRIORS_DIR / "asset-database.json"
    if isinstance(source, Mapping):
        return _index_database(source, "<mapping>")
    path = Path(source)
    try:
        key = (str(path.resolve()), path.stat().st_mtime)
    except OSError as exc:
        raise ImportFormatError("asset database not found", path=str(path)) from exc
    if key not in _DB_CACHE:
        _DB_CACHE[key] = _index_database(read_json(path), str(path))
    return _DB_CACHE[key]


_ANNOTATIONS_CACHE: dict[tuple[str, float, str], AssetDatabase] = {}


def load_asset_annotations(
    path: str | os.PathLike[str], base: str | os.PathLike[str] | Mapping[str, Any] | AssetDatabase | None = None
) -> AssetDatabase:
    """The asset database ``base`` (default: the shipped one) with the sizes of an annotations
    file laid over it: what a user knows of assets the database does not hold (Objaverse ids, a
    fork's own), or knows better. An annotated asset takes the file's box and the type its
    ``objectType`` or ``category`` reads as (``"coffee table"`` as ``CoffeeTable``; the nearest
    database type by name, as for unknown assets).

    The file (``.json``, or ``.json.gz`` as Objaverse's ship) maps each asset id to an entry whose
    box is objathor's ``thor_metadata.assetMetadata.boundingBox`` (``{min: {x, y, z}, max: {x, y,
    z}}`` or a size ``{x, y, z}``), else ``assetMetadata.boundingBox``, else ``boundingBox``, in
    metres with ``y`` up. An entry without a box, or a box that is not a positive size, raises
    ``ImportFormatError`` naming it; so does a file that is not such a mapping.
    """
    p = Path(path)
    db = load_asset_database(base)
    try:
        key = (str(p.resolve()), p.stat().st_mtime, db.source)
    except OSError as exc:
        raise ImportFormatError("asset annotations not found", path=str(p)) from exc
    if key not in _ANNOTATIONS_CACHE:
        _ANNOTATIONS_CACHE.clear()  # one annotations file a process at a time: they are large
        _ANNOTATIONS_CACHE[key] = _overlay_annotations(read_json(p), p, db)
    return _ANNOTATIONS_CACHE[key]


def _overlay_annotations(data: Any, path: Path, db: AssetDatabase) -> AssetDatabase:
    r = FieldReader(path)
    if not isinstance(data, Mapping) or not data:
        r.fail("", "asset annotations are a JSON object of entries by asset id")
    boxes, types = dict(db.boxes), dict(db.types)
    known = db.type_boxes
    for uid, raw in data.items():
        entry = r.mapping(raw, str(uid))
        box: Any = None
        for where in (("thor_metadata", "assetMetadata", "boundingBox"), ("assetMetadata", "boundingBox"), ("boundingBox",)):
            node: Any = entry
            for k in where:
                node = node.get(k) if isinstance(node, Mapping) else None
            if node is not None:
                box, named_at = node, f"{uid}." + ".".join(where)
                break
        if box is None:
            r.fail(str(uid), "no boundingBox (thor_metadata.assetMetadata.boundingBox, assetMetadata.boundingBox or boundingBox)")
        if isinstance(box, Mapping) and "min" in box and "max" in box:
            lo, hi = r.xyz(box["min"], f"{named_at}.min"), r.xyz(box["max"], f"{named_at}.max")
            size: tuple[float, float, float] = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
        else:
            x, y, z = r.xyz(box, named_at)
            size = (x, y, z)
        if not all(math.isfinite(v) and v > 0 for v in size):
            r.fail(named_at, f"sizes must be positive, got {[round(v, 4) for v in size]}")
        boxes[str(uid)] = size
        named = entry.get("objectType") or entry.get("category")
        kind = "".join(w[:1].upper() + w[1:] for w in re.split(r"[^A-Za-z0-9]+", named) if w) if isinstance(named, str) else ""
        types[str(uid)] = (_nearest_type(kind, known) or kind) if kind else types.get(str(uid), "Object")
    return AssetDatabase(boxes=boxes, types=types, source=f"{path} over {db.source}")


def _index_database(data: Any, source: str) -> AssetDatabase:
    r = FieldReader(Path(source))
    boxes: dict[str, tuple[float, float, float]] = {}
    types: dict[str, str] = {}

    def add(entry: Any, field: str, asset_id: str | None, object_type: str | None) -> None:
        e = r.mapping(entry, field)
        aid = e.get("assetId", asset_id)
        if not isinstance(aid, str):
            r.fail(f"{field}.assetId", "missing asset id")
        bx, by, bz = r.xyz(r.get(e, "boundingBox", field), f"{field}.boundingBox")
        if min(bx, by, bz) <= 0:
            r.fail(f"{field}.boundingBox", f"sizes must be positive, got {[bx, by, bz]}")
        boxes[aid] = (bx, by, bz)
        otype = e.get("objectType", object_type)
        types[aid] = otype if isinstance(otype, str) else re.sub(r"_\d+$", "", aid)

    if isinstance(data, list):
        for i, entry in enumerate(data):
            add(entry, f"[{i}]", None, None)
    elif isinstance(data, Mapping):
        for key, value in data.items():
            if isinstance(value, list):
                for i, entry in enumerate(value):
                    add(entry, f"{key}[{i}]", None, key)
            else:
                add(value, key, key, None)
    else:
        r.fail("", "an asset database is a JSON object or array")
    return AssetDatabase(boxes=boxes, types=types, source=source)


def looks_like_procthor(data: Any) -> bool:
    """Detection rule: a JSON object with ``rooms`` (each with a ``floorPolygon``) and ``objects``."""
    if not isinstance(data, dict) or not isinstance(data.get("rooms"), list) or "objects" not in data:
        return False
    return any(isinstance(room, dict) and "floorPolygon" in room for room in data["rooms"])


@dataclass
class _RoomBuild:
    room: Room
    polygon: Polygon
    source_id: str
    room_type: str
    objects: list[SceneObject] = field(default_factory=list)
    relations: list[Relation] = field(default_factory=list)
    asset_ids: dict[str, str] = field(default_factory=dict)
    source_ids: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    faults: list[str] = field(default_factory=list)
    """What the file got wrong and the reader mended (``Provenance.source_faults``)."""
    size_estimates: dict[str, str] = field(default_factory=dict)
    """Objects whose asset the database does not hold, by id: how their stand-in was sized."""
    estimated_types: dict[str, str] = field(default_factory=dict)
    """The database type each top-level stand-in of :attr:`size_estimates` was sized as."""
    cut: list[tuple[FloatArray, FloatArray, FloatArray]] = field(default_factory=list)
    """The stretches of boundary given up to shared walls: (start, end, inward unit normal)."""


def import_procthor(
    data: Any, path: Path, *, asset_database: Any = None, allow_orphans: bool = False
) -> list[Scene]:
    """One :class:`Scene` per room of a parsed house, in the house's room order.

    Each top-level object goes to the room whose floor polygon contains its centre; its
    ``children`` follow it and get an ``attach`` relation to it. Top-level objects get no relation:
    structuring decides. A centre just outside every floor (at most
    :data:`OUTSIDE_ROOM_TOLERANCE_M`) goes to the nearest room with a provenance note.

    An object farther out than that (an *orphan*: the room it stood in is not in the file), or a
    door or window whose ``room0`` / ``room1`` names a room the file does not hold (other than
    ``"exterior"``), raises :class:`~scenemosaic.exceptions.ImportFormatError` naming them all.
    With ``allow_orphans`` the import goes on instead: orphans go to the nearest room, such a door
    or window is cut into the rooms it names that the house holds, and every room's
    ``provenance.import_warnings`` says what was done (a run reports it, ``degraded``).
    """
    db = load_asset_database(asset_database)
    r = FieldReader(path)
    top = r.mapping(data, "")
    builds, strays = house_rooms(r, top)
    by_source = {b.source_id: b for b in builds}

    taken: set[str] = set()
    orphans: list[_Orphan] = []
    renamed = _distinct_ids(top.get("objects"))
    at_base = positions_at_base(top, db)
    if at_base:  # said once, on every room: the file's convention, not ProcTHOR's
        for b in builds:
            b.faults.append(
                "the file puts each object's position at the bottom of its box (y = 0 on the floor), "
                "not at its centre as ProcTHOR does; read (and written back) so"
            )
    for i, raw in enumerate(r.array(r.get(top, "objects", ""), "objects")):
        field_name = f"objects[{i}]"
        item = r.mapping(raw, field_name)
        centre = r.xyz(r.get(item, "position", field_name), f"{field_name}.position")
        build, distance = room_for(builds, centre[0], centre[2])
        raw_id = item.get("id")
        if distance > OUTSIDE_ROOM_TOLERANCE_M:
            asset = item.get("assetId")
            orphans.append(
                _Orphan(
                    field_name, raw_id if isinstance(raw_id, str) else "", asset if isinstance(asset, str) else "",
                    build.source_id, distance,
                )
            )  # fmt: skip
            build.notes.append(
                f"{field_name} lies {distance:.2f} m outside every floor polygon; assigned to the nearest room (allow_orphans)"
            )
        elif distance > 0.0:
            build.notes.append(f"{field_name} lies outside every floor polygon; assigned to the nearest room")
        _add_object(r, item, field_name, None, build, db, taken, renamed, at_base)
    problems = orphan_problems(orphans, strays, by_source)
    if problems and not allow_orphans:
        r.fail(
            "objects" if orphans else "doors" if strays[0].startswith("doors") else "windows",
            "; ".join(text for text, _ in problems) + f" (is a room missing from {path.name}'s rooms?). "
            "To put each in the nearest room instead, allow orphans (generate --allow-orphans, "
            "load_scene(..., allow_orphans=True)); the run is then reported degraded",
        )
    warnings = [f"{text}: {done} (allow_orphans)" for text, done in problems]
    if warnings:
        log.warning("procthor_orphans_allowed", path=str(path), problems=warnings)

    for b in builds:
        clear_shared_walls(b)
        _fit_estimates(b, db)
    scenes = []
    for i, b in enumerate(builds):
        r.check(object_count_problem(len(b.objects)), "objects", what=f"room {b.source_id!r} (rooms[{i}])")
        scenes.append(
            Scene(
                id=b.room.id,
                room=b.room,
                objects=b.objects,
                relations=b.relations,
                provenance=Provenance(
                    source_format="procthor", source_path=path.as_posix(), importer=IMPORTER, notes=b.notes,
                    source_faults=b.faults, size_estimates=dict(b.size_estimates),
                    room_type=b.room_type, source_room_id=str(b.source_id), asset_ids=dict(b.asset_ids),
                    source_ids={oid: str(raw) for oid, raw in b.source_ids.items()}, asset_database=db.source,
                    # the house's, on every room: whichever is worked on, the house it came from is incomplete
                    import_warnings=list(warnings),
                ),
            )
        )  # fmt: skip
    log.debug(
        "procthor_imported", path=str(path), rooms=len(scenes), objects=sum(len(s.objects) for s in scenes)
    )
    return scenes


def house_rooms(r: FieldReader, top: Mapping[str, Any]) -> tuple[list[_RoomBuild], list[str]]:
    """A house's rooms, in file order, with their walls and openings (the ProcTHOR and Holodeck
    readers' one home for them): each room's floor and walls, the edges rooms share cut back to
    one wall between them, empty walls opened, every door and window cut into the rooms it joins.
    With the doors and windows that open onto a room the file does not hold, in words (what
    ``allow_orphans`` lets through)."""
    _check_schema(r, top)
    rooms_raw = r.array(r.get(top, "rooms", ""), "rooms")
    if not rooms_raw:
        r.fail("rooms", "the house has no rooms")
    _check_house_size(r, rooms_raw)
    walls_by_id = _walls_by_id(r, top)
    builds: list[_RoomBuild] = []
    room_ids: set[str] = set()
    for i, raw in enumerate(rooms_raw):
        builds.append(_build_room(r, raw, f"rooms[{i}]", walls_by_id, room_ids))
    _cut_back_shared_walls(builds)
    by_source = {b.source_id: b for b in builds}
    _open_empty_walls(walls_by_id, by_source)
    strays: list[str] = []  # doors and windows onto rooms the house does not hold
    for key in ("doors", "windows"):
        for i, raw in enumerate(r.array(top.get(key) or [], key)):
            f = f"{key}[{i}]"
            missing = _rooms_not_held(r, raw, f, by_source)
            if missing:
                item_id = raw.get("id") if isinstance(raw, dict) else None
                named = f" ({item_id!r})" if isinstance(item_id, str) else ""
                strays.append(f"{f}{named} opens onto {' and '.join(repr(m) for m in missing)}")
            _add_opening(r, raw, f, key, walls_by_id, by_source)
    return builds, strays


_LISTED = 8
"""How many orphans an error names one by one (the rest are counted)."""


@dataclass(frozen=True)
class _Orphan:
    field: str
    source_id: str
    asset_id: str
    nearest: str
    distance: float


def orphan_problems(
    orphans: list[_Orphan], strays: list[str], by_source: Mapping[str, _RoomBuild]
) -> list[tuple[str, str]]:
    """What the house holds outside its rooms, in words: the orphans (how many, their ids, the
    nearest room of each group) and the doors and windows onto rooms it does not hold; each with
    what ``allow_orphans`` does about it."""
    out: list[tuple[str, str]] = []
    if orphans:
        groups: dict[str, list[_Orphan]] = {}
        for o in orphans:
            groups.setdefault(o.nearest, []).append(o)
        parts = []
        for nearest, group in groups.items():
            names = [
                f"{o.source_id or o.field!r} ({', '.join(filter(None, [o.asset_id, f'{o.distance:.2f} m']))})"
                for o in group[:_LISTED]
            ]
            more = f" and {len(group) - _LISTED} more" if len(group) > _LISTED else ""
            room_type = by_source[nearest].room_type
            parts.append(f"nearest room {nearest!r}{f' ({room_type})' if room_type else ''}: {', '.join(names)}{more}")
        out.append((
            f"{len(orphans)} object(s) lie outside every room (centre more than "
            f"{OUTSIDE_ROOM_TOLERANCE_M:g} m from each floor): " + "; ".join(parts),
            "each put in the nearest room",
        ))  # fmt: skip
    if strays:
        held = ", ".join(repr(k) for k in by_source)
        out.append((
            f"{len(strays)} door(s) or window(s) open onto a room the house does not hold ({held}): " + "; ".join(strays),
            "cut into the rooms the house holds only",
        ))  # fmt: skip
    return out


def _rooms_not_held(r: FieldReader, raw: Any, f: str, by_source: Mapping[str, _RoomBuild]) -> list[str]:
    """The rooms a door or window names (``room0``, ``room1``) that the house does not hold; the
    outside (:data:`OUTSIDE`) is not one."""
    item = r.mapping(raw, f)
    names = dict.fromkeys(item.get(k) for k in ("room0", "room1"))
    return [n for n in names if isinstance(n, str) and n not in by_source and n != OUTSIDE]


def _check_schema(r: FieldReader, top: Mapping[str, Any]) -> None:
    """Refuse a house schema this reader does not know (see :data:`SCHEMAS_READ`)."""
    meta = top.get("metadata")
    schema = meta.get("schema") if isinstance(meta, Mapping) else None
    if schema is None:
        return  # the first form: ProcTHOR's own upgrade reads a missing version as 0.0.1
    major = re.match(r"\s*(\d+)\.", str(schema))
    if major is None or int(major.group(1)) > 1:
        multi = " (a multi-floor house)" if isinstance(top.get("floors"), list) else ""
        r.fail(
            "metadata.schema",
            f"house schema {schema!r}{multi} is not read; this reader knows {' and '.join(SCHEMAS_READ)}",
        )


# -- rooms and walls ------------------------------------------------------------------------------


@dataclass(frozen=True)
class _SourceWall:
    room_id: str | None
    start: tuple[float, float]
    end: tuple[float, float]
    height: float | None
    empty: bool = False
    """AI2-THOR's ``empty`` wall: no wall at all, the room is open to its neighbour there."""


def _walls_by_id(r: FieldReader, top: Mapping[str, Any]) -> dict[str, _SourceWall]:
    out: dict[str, _SourceWall] = {}
    for i, raw in enumerate(r.array(top.get("walls") or [], "walls")):
        f = f"walls[{i}]"
        w = r.mapping(raw, f)
        wid = r.text(r.get(w, "id", f), f"{f}.id")
        poly = r.array(r.get(w, "polygon", f), f"{f}.polygon")
        pts = [r.xyz(p, f"{f}.polygon[{j}]") for j, p in enumerate(poly)]
        if len(pts) < 2:
            r.fail(f"{f}.polygon", "a wall polygon needs at least 2 points")
        low = min(p[1] for p in pts)
        base: list[tuple[float, float]] = []
        for p in pts:  # bottom edge, in file order: start then end
            q = (p[0], p[2])
            if abs(p[1] - low) < 1e-6 and q not in base:
                base.append(q)
        if len(base) < 2:
            r.fail(f"{f}.polygon", "the wall has no bottom edge (two distinct points at its lowest height)")
        high = max(p[1] for p in pts)
        room_id = w.get("roomId")
        if wid.split("|")[1:2] == ["exterior"]:  # schema 0.0.1 gives it the id of the room it closes
            room_id = None
        out[wid] = _SourceWall(
            room_id=room_id if isinstance(room_id, str) else None,
            start=base[0],
            end=base[1],
            height=(high - low) if high - low > 1e-6 else None,
            empty=w.get("empty") is True,
        )
    return out


def _check_house_size(r: FieldReader, rooms_raw: list[Any]) -> None:
    """Refuse a house too large to work on as one (``scene.house_problem``) before building any
    room: too many rooms, or rooms spread too far apart."""
    xs: list[float] = []
    ys: list[float] = []
    for raw in rooms_raw:
        points = raw.get("floorPolygon") if isinstance(raw, dict) else None
        for p in points if isinstance(points, list) else []:
            if isinstance(p, dict) and all(isinstance(p.get(k), int | float) for k in ("x", "z")):
                xs.append(float(p["x"]))
                ys.append(float(p["z"]))
    problem = house_problem(len(rooms_raw), xs, ys)
    if problem is not None:
        r.fail("rooms", f"the house is too large: {problem}")


def _build_room(
    r: FieldReader, raw: Any, f: str, walls_by_id: Mapping[str, _SourceWall], room_ids: set[str]
) -> _RoomBuild:
    room = r.mapping(raw, f)
    source_id = r.text(r.get(room, "id", f), f"{f}.id")
    points = r.array(r.get(room, "floorPolygon", f), f"{f}.floorPolygon")
    floor = []
    for j, p in enumerate(points):
        x, _, z = r.xyz(p, f"{f}.floorPolygon[{j}]")
        floor.append((x, z))
    if len(floor) < 3:
        r.fail(f"{f}.floorPolygon", f"a floor polygon needs at least 3 points, got {len(floor)}")
    polygon = Polygon(floor)
    if not polygon.is_valid or polygon.area <= 1e-9:
        r.fail(f"{f}.floorPolygon", "the floor polygon is degenerate or self-intersecting")
    heights = [w.height for w in walls_by_id.values() if w.room_id == source_id and w.height is not None]
    ceiling = max(heights) if heights else DEFAULT_CEILING_HEIGHT
    rid = unique_id(sanitize_id(source_id, fallback="room"), room_ids)
    try:
        built = Room.from_polygon(floor, ceiling_height=ceiling, room_id=rid)
    except ValidationError as exc:
        r.fail(f"{f}.floorPolygon", exc.errors()[0]["msg"])
    room_type = room.get("roomType")
    return _RoomBuild(
        room=built,
        polygon=polygon,
        source_id=source_id,
        room_type=room_type if isinstance(room_type, str) else "",
    )


def _cut_back_shared_walls(builds: list[_RoomBuild], thickness: float = SHARED_WALL_THICKNESS_M) -> None:
    """Move each edge of a room's floor that another room shares (any stretch of it at least
    ``MIN_SHARED_M`` long) in by half ``thickness`` (see :data:`SHARED_WALL_THICKNESS_M`); its walls
    follow the new floor. A whole edge moves, not only the shared stretch, so no wall shorter than
    the room's own edges appears."""
    if len(builds) < 2:
        return
    for b in builds:
        others = unary_union([o.polygon.exterior for o in builds if o is not b])
        pts = [np.asarray(p, dtype=np.float64) for p in b.room.floor]  # counter-clockwise
        k = len(pts)
        moved = []
        for e in range(k):
            a, c = pts[e], pts[(e + 1) % k]
            shared = LineString([tuple(a), tuple(c)]).intersection(others)
            moved.append(float(shared.length) >= MIN_SHARED_M)
        if not any(moved):
            continue
        lines = []
        for e in range(k):
            a, c = pts[e], pts[(e + 1) % k]
            d = (c - a) / max(float(np.linalg.norm(c - a)), 1e-12)
            n = np.array([-d[1], d[0]])  # inward: left of a counter-clockwise edge
            off = n * (thickness / 2) if moved[e] else np.zeros(2)
            lines.append((a + off, d))
            if moved[e]:
                b.cut.append((a, c, n))
        floor: list[tuple[float, float]] = []
        for e in range(k):
            (p0, d0), (p1, d1) = lines[e - 1], lines[e]
            cross = d0[0] * d1[1] - d0[1] * d1[0]
            if abs(cross) < 1e-9:  # collinear edges: the corner stays on the line
                floor.append((float(p1[0]), float(p1[1])))
                continue
            t = ((p1[0] - p0[0]) * d1[1] - (p1[1] - p0[1]) * d1[0]) / cross
            q = p0 + d0 * t
            floor.append((float(q[0]), float(q[1])))
        cut = Polygon(floor)
        if not cut.is_valid or cut.area < 0.5 * b.polygon.area:
            b.cut.clear()
            b.notes.append("the floor is too narrow to give up half a shared wall; kept as drawn")
            continue
        b.room = Room.from_polygon(floor, ceiling_height=b.room.ceiling_height, room_id=b.room.id)
        for w in b.room.walls:
            w.thickness = thickness


def clear_shared_walls(b: _RoomBuild, thickness: float = SHARED_WALL_THICKNESS_M) -> None:
    """Move each top-level object (with what it carries) off the half of a shared wall its room
    gave up: by as much as its footprint reaches into it, plus 5 mm, along the wall's inward
    normal (ProcTHOR stands furniture and hangs pictures on the line the rooms meet on)."""
    if not b.cut:
        return
    children: dict[str, list[str]] = {}
    for rel in b.relations:
        children.setdefault(rel.parent, []).append(rel.child)
    carried = {c for kids in children.values() for c in kids}
    by_id = {o.id: o for o in b.objects}
    for obj in b.objects:
        if obj.id in carried:
            continue
        foot = obj.footprint()
        push: dict[tuple[float, float], tuple[FloatArray, float]] = {}  # per wall direction: the deepest reach
        for a, c, n in b.cut:
            d = c - a
            length = float(np.linalg.norm(d))
            along = (foot - a) @ (d / max(length, 1e-12))
            if along.max() <= 0.0 or along.min() >= length:
                continue  # beside this stretch, not against it
            reach = thickness / 2 - float(((foot - a) @ n).min())
            key = (round(float(n[0]), 3), round(float(n[1]), 3))
            if 0.0 < reach <= thickness and reach > push.get(key, (n, 0.0))[1]:
                push[key] = (n, reach)
        shift = sum((n * (reach + 0.005) for n, reach in push.values()), np.zeros(2))
        if not shift.any():
            continue
        stack = [obj.id]
        while stack:
            moved = by_id[stack.pop()]
            x, y, z = moved.pose.position
            moved.pose = moved.pose.model_copy(update={"position": (x + float(shift[0]), y + float(shift[1]), z)})
            stack += children.get(moved.id, [])
        b.notes.append(f"{obj.id} moved {float(np.linalg.norm(shift)):.3f} m off a shared wall")


def _open_empty_walls(walls_by_id: Mapping[str, _SourceWall], by_source: Mapping[str, _RoomBuild]) -> None:
    """An ``empty`` wall of the house is open floor between two rooms: the stretch of the room's
    wall along it becomes an opening of kind ``opening``, floor to wall top."""
    for sw in walls_by_id.values():
        build = by_source.get(sw.room_id or "")
        if not sw.empty or build is None:
            continue
        a, b = np.asarray(sw.start, dtype=np.float64), np.asarray(sw.end, dtype=np.float64)
        for w in build.room.walls:
            ws = np.asarray(w.start)
            if abs(float(np.dot(w.direction, b - a))) < 0.999 * float(np.linalg.norm(b - a)):
                continue  # not parallel
            off = [float(np.dot(p - ws, w.outward_normal)) for p in (a, b)]
            if not all(-_WALL_MATCH_TOL < o < SHARED_WALL_THICKNESS_M / 2 + _WALL_MATCH_TOL for o in off):
                continue
            t = sorted(float(np.dot(p - ws, w.direction)) for p in (a, b))
            lo, hi = max(0.0, t[0]), min(w.length, t[1])
            if hi - lo > 0.05:
                w.openings = [*w.openings, Opening(kind="opening", center=(lo + hi) / 2, width=hi - lo, height=w.height)]


def _add_opening(
    r: FieldReader,
    raw: Any,
    f: str,
    key: str,
    walls_by_id: Mapping[str, _SourceWall],
    by_source: Mapping[str, _RoomBuild],
) -> None:
    """Cut a door or window into the wall it lies on, once in each room it opens onto.

    AI2-THOR measures the hole (:func:`_hole`) along ``wall0`` from its start, so the hole's
    centre is placed on ``wall0`` in world coordinates and then found on each room's own wall
    through that point. ``room0`` and ``room1`` are the same room for an exterior window or door
    (the other side is the outside): it is cut once, not twice. A room the house does not hold is
    skipped (:func:`import_procthor` decides whether that is an error). Shared by the ProcTHOR and
    Holodeck readers.
    """
    item = r.mapping(raw, f)
    x0, x1, y0, y1 = _hole(r, item, f)
    width, height = x1 - x0, y1 - y0
    wall_key = r.text(r.get(item, "wall0", f), f"{f}.wall0")
    wall = walls_by_id.get(wall_key)
    if wall is None:
        r.fail(f"{f}.wall0", f"no wall with id {wall_key!r}")
    d = np.subtract(wall.end, wall.start)
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        r.fail(f"{f}.wall0", f"wall {wall_key!r} has zero length")
    centre = np.asarray(wall.start) + d / length * (0.5 * (x0 + x1))
    kind: Literal["door", "window"] = "door" if key == "doors" else "window"
    leaves = _door_leaves(item.get("assetId")) if kind == "door" else None
    rooms = dict.fromkeys(src for src in (item.get("room0"), item.get("room1")) if isinstance(src, str))
    for src in rooms:
        build = by_source.get(src)
        if build is None:  # the outside, or a room this file does not hold
            continue
        target = _wall_through(build.room.walls, centre, SHARED_WALL_THICKNESS_M / 2 + _WALL_MATCH_TOL)
        if target is None:
            build.faults.append(f"{f} does not lie on any wall of room {build.source_id!r}; dropped")
            continue
        along = float(np.dot(centre - np.asarray(target.start), target.direction))
        lo, hi = max(along - width / 2, 0.0), min(along + width / 2, target.length)
        if hi - lo < width / 2:
            build.faults.append(
                f"{f} lies mostly past the ends of {build.source_id!r}'s wall {target.id} "
                f"({hi - lo:.3f} of its {width:.3f} m on it); dropped"
            )
            continue
        if hi - lo < width - OPENING_CLIP_NOTE_M:
            build.faults.append(
                f"{f} runs {width - (hi - lo):.3f} m past the end of {build.source_id!r}'s wall {target.id}; "
                f"cut {hi - lo:.3f} m wide, as far as the wall goes"
            )
        target.openings = [
            *target.openings,
            Opening(kind=kind, center=(lo + hi) / 2, width=hi - lo, bottom=max(0.0, y0), height=height, leaves=leaves),
        ]


def _door_leaves(asset_id: Any) -> int | None:
    """How many leaves an AI2-THOR door asset hangs in its hole: a ``Doorframe_*`` none (a frame
    without a door), a ``Doorway_Double_*`` two, another ``Doorway_*`` one; ``None`` for an asset
    id that says nothing (a door then gets one leaf)."""
    if not isinstance(asset_id, str):
        return None
    name = asset_id.lower()
    if name.startswith("doorframe"):
        return 0
    if name.startswith("doorway"):
        return 2 if "double" in name else 1
    return None


def _hole(r: FieldReader, item: Mapping[str, Any], f: str) -> tuple[float, float, float, float]:
    """A door or window's hole in its ``wall0``: ``(x0, x1, y0, y1)``, x along the wall from its
    first point, y up from the floor (metres, ``x0 < x1``, ``y0 < y1``).

    Schema 1.0.0 gives ``holePolygon`` (two opposite corners, or more points: their extent);
    schema 0.0.1 gives ``boundingBox: {min, max}``, the same two corners."""
    if "holePolygon" in item:
        hole = r.array(item["holePolygon"], f"{f}.holePolygon")
        if len(hole) < 2:
            r.fail(f"{f}.holePolygon", "expected two corners")
        points = [r.xyz(p, f"{f}.holePolygon[{j}]") for j, p in enumerate(hole)]
        field = f"{f}.holePolygon"
    elif "boundingBox" in item:
        box = r.mapping(item["boundingBox"], f"{f}.boundingBox")
        points = [r.xyz(r.get(box, k, f"{f}.boundingBox"), f"{f}.boundingBox.{k}") for k in ("min", "max")]
        field = f"{f}.boundingBox"
    else:
        r.fail(
            f,
            "the door or window has no hole: expected holePolygon (house schema 1.0.0) "
            "or boundingBox (house schema 0.0.1)",
        )
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    if max(xs) - min(xs) <= 0 or max(ys) - min(ys) <= 0:
        r.fail(field, "the hole has zero width or height")
    return min(xs), max(xs), min(ys), max(ys)


def _wall_through(walls: list[Wall], point: FloatArray, reach: float) -> Wall | None:
    """The wall whose line passes within ``reach`` of ``point`` (behind it: a shared wall's room
    side was cut back from the line the house draws), with ``point`` along its length; the
    nearest such wall."""
    best: tuple[float, Wall] | None = None
    for w in walls:
        rel = point - np.asarray(w.start)
        along = float(np.dot(rel, w.direction))
        off = float(np.dot(rel, w.outward_normal))
        inside = -_WALL_MATCH_TOL < off < reach and -_WALL_MATCH_TOL <= along <= w.length + _WALL_MATCH_TOL
        if inside and (best is None or abs(off) < best[0]):
            best = (abs(off), w)
    return None if best is None else best[1]


def room_for(builds: list[_RoomBuild], x: float, z: float) -> tuple[_RoomBuild, float]:
    """The room whose floor polygon (as the house draws it) covers ``(x, z)``, else the nearest
    one; with the distance to it (0 when covered)."""
    p = Point(x, z)
    for b in builds:
        if b.polygon.covers(p):
            return b, 0.0
    nearest = min(builds, key=lambda b: b.polygon.distance(p))
    return nearest, float(nearest.polygon.distance(p))


# -- objects --------------------------------------------------------------------------------------


def _camel_to_snake(name: str) -> str:
    s = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", name)
    s = re.sub(r"(?<=[A-Z])(?=[A-Z][a-z])", "_", s)
    return re.sub(r"[^a-z0-9_]+", "_", s.lower()).strip("_") or "object"


def _unity_rotation(rx: float, ry: float, rz: float) -> FloatArray:
    """Unity's Euler rotation (degrees; z, then x, then y) as a matrix in Unity coordinates."""
    matrix: FloatArray = Rotation.from_euler("YXZ", [ry, rx, rz], degrees=True).as_matrix()
    return matrix


def _add_object(
    r: FieldReader,
    item: Mapping[str, Any],
    f: str,
    parent: str | None,
    build: _RoomBuild,
    db: AssetDatabase,
    taken: set[str],
    renamed: Mapping[str, tuple[str, str]],
    at_base: bool = False,
) -> None:
    asset_id = r.text(r.get(item, "assetId", f), f"{f}.assetId")
    raw_id = item.get("id")
    if f in renamed:  # an id the file gave an object before: this one is read (and written back) by another
        raw_id, first = renamed[f]
        build.faults.append(f"{f}: its id {item.get('id')!r} is the id of {first} too; read as {raw_id!r}")
    who = f"object {raw_id!r}" if isinstance(raw_id, str) else f"asset {asset_id!r}"
    cx, cy, cz = r.xyz(r.get(item, "position", f), f"{f}.position")
    r.check(coordinate_problem((cx, cy, cz)), f"{f}.position", what=who)
    estimate: str | None = None
    if asset_id in db.boxes:
        bx, by, bz = db.boxes[asset_id]
        otype = db.types.get(asset_id, "Object")
    else:  # an Objaverse asset, a fork's own: a stand-in sized from what is known of it
        otype, (bx, by, bz), estimate = _estimated_box(
            item, asset_id, top_level=parent is None, centre_y=None if at_base else cy, db=db
        )
    r.check(size_problem((bx, bz, by)), f"{f}.assetId", what=f"{who}: {estimate or 'asset database box'}")
    rot_raw = item.get("rotation", {"x": 0.0, "y": 0.0, "z": 0.0})
    rx, ry, rz = r.xyz(rot_raw, f"{f}.rotation")
    rotation = _SWAP @ _unity_rotation(rx, ry, rz) @ _SWAP @ _HALF_TURN
    centre = np.array([cx, cz, cy + (by / 2.0 if at_base else 0.0)])
    origin = centre - rotation @ np.array([0.0, 0.0, by / 2.0])
    qx, qy, qz, qw = Rotation.from_matrix(rotation).as_quat()
    if abs(rx) < 1e-9 and abs(rz) < 1e-9:
        pose = Pose.from_yaw(tuple(origin.tolist()), math.pi - math.radians(ry))  # exact for upright objects
    else:
        pose = Pose(position=tuple(origin.tolist()), quaternion=(qw, qx, qy, qz))
    category = _camel_to_snake(otype)
    oid = unique_id(sanitize_id(raw_id) if isinstance(raw_id, str) else category, taken)
    if estimate is not None:
        build.size_estimates[oid] = f"{f} (asset {asset_id!r}): {estimate}"
        if parent is None:
            build.estimated_types[oid] = otype
    words = category.replace("_", " ")
    build.objects.append(
        r.scene_object(
            f,
            who,
            id=oid,
            category=category,
            description=f"{words} (AI2-THOR asset {asset_id})",
            asset=AssetRef(kind="procedural", category=category, extents=(bx, bz, by)),
            pose=pose,
        )
    )
    build.asset_ids[oid] = asset_id
    if isinstance(raw_id, str):
        build.source_ids[oid] = raw_id
    if parent is not None:
        build.relations.append(Relation(kind="attach", child=oid, parent=parent, source=IMPORTER))
    for j, child in enumerate(r.array(item.get("children") or [], f"{f}.children")):
        cf = f"{f}.children[{j}]"
        _add_object(r, r.mapping(child, cf), cf, oid, build, db, taken, renamed, at_base)


STAND_IN_BOX_M = (0.4, 0.4, 0.4)
"""The box (x, height, z; m) of an unknown asset whose type says nothing the asset database knows."""
_OBJA_PREFIX = "Obja"  # ProcTHOR-Objaverse's types: ObjaGarbageCan is a GarbageCan


_TYPE_WORDS = {
    "bookcase": "ShelvingUnit", "bookshelf": "ShelvingUnit", "shelf": "ShelvingUnit", "shelves": "ShelvingUnit",
    "cabinet": "Dresser", "wardrobe": "Dresser", "closet": "Dresser", "chest": "Dresser", "couch": "Sofa",
    "nightstand": "SideTable", "table": "SideTable", "plant": "HousePlant", "tv": "Television",
    "lamp": "FloorLamp", "trashcan": "GarbageCan", "bin": "GarbageCan", "mirror": "Painting",
    "picture": "Painting", "poster": "Painting", "clock": "AlarmClock", "tablelamp": "DeskLamp",
    "blanket": "Cloth", "cushion": "Pillow", "album": "Book", "binder": "Book", "notepad": "Book",
    "notebook": "Book", "tray": "Plate", "board": "Plate", "pitcher": "Vase", "frame": "Painting",
}  # fmt: skip
"""Words of types the AI2-THOR database has no asset of, read as a database type of like size."""


def _nearest_type(kind: str, known: Mapping[str, Any]) -> str | None:
    """The database type a type it does not hold reads as (``ObjaGarbageCan`` as ``GarbageCan``):
    the same name in any case, or a word of :data:`_TYPE_WORDS`; else the longest known type or
    word the name ends with (its head noun: a ``DiningChair`` is a ``Chair``), then the longest
    known type it contains; ``None`` when nothing matches."""
    plain = kind[len(_OBJA_PREFIX) :] if kind.startswith(_OBJA_PREFIX) and len(kind) > len(_OBJA_PREFIX) else kind
    lowered = {k.lower(): k for k in known}
    words = {w: t for w, t in _TYPE_WORDS.items() if t in known}
    key = re.sub(r"[^a-z0-9]", "", plain.lower())
    if key in lowered:
        return lowered[key]
    if key in words:
        return words[key]
    ends = [(low, k) for low, k in (*lowered.items(), *words.items()) if len(low) >= 2 and key.endswith(low)]
    if ends:
        return max(ends, key=lambda e: (len(e[0]), e[1]))[1]
    inside = [k for low, k in lowered.items() if len(low) >= 3 and low in key]
    return max(inside, key=lambda k: (len(k), k)) if inside else None


def _estimated_box(
    item: Mapping[str, Any], asset_id: str, *, top_level: bool, centre_y: float | None, db: AssetDatabase
) -> tuple[str, tuple[float, float, float], str]:
    """The type, box (x, height, z) and how it was found of an asset the database does not hold:
    the median box of its type among the database's assets (``objectType``, ``ObjaX`` read as
    ``X``, else the nearest type by name), else :data:`STAND_IN_BOX_M`; a top-level object standing
    on the floor (its centre's height within half to twice its type's height over two) takes twice
    its centre's height, the file's own cue."""
    raw = item.get("objectType")
    kind = raw if isinstance(raw, str) and raw.strip() else "Object"
    boxes = db.type_boxes
    match = _nearest_type(kind, boxes)
    if match is not None:
        bx, by, bz = boxes[match]
        how = f"the median {match} of the asset database" + ("" if match == kind else f" (its type {kind!r})")
        otype = match
    else:
        bx, by, bz = STAND_IN_BOX_M
        how = f"a {STAND_IN_BOX_M[0]:g} m stand-in box (its type {kind!r} is not one the asset database knows)"
        otype = kind[len(_OBJA_PREFIX) :] if kind.startswith(_OBJA_PREFIX) and len(kind) > len(_OBJA_PREFIX) else kind
    standing = 2.0 * centre_y if centre_y is not None else 0.0  # a file of base positions gives no height
    if top_level and 0.5 * by <= standing <= 2.0 * by and standing > 0.02:
        by = standing
        how += f", {standing:.2f} m tall (twice its centre's height)"
    return otype, (bx, by, bz), how


FLOOR_STANDING_M = 0.05
"""A stand-in whose bottom is this high or lower (metres) stands on the floor and is fitted to it."""


def _fit_estimates(build: _RoomBuild, db: AssetDatabase) -> None:
    """Each top-level stand-in (an asset the database does not hold, sized as its type's median)
    standing on the floor whose footprint, where the file puts it, runs through the room's walls
    is shrunk to the first of its type's smaller footprints that fits
    (``AssetDatabase.type_footprints``: the 25th percentile, then the smallest; the smallest when
    none does), its height and centre kept: a corner counter's median box does not cut across a
    kitchen where the file's own counter was a straight one along the wall. Said in its estimate."""
    if not build.estimated_types:
        return
    floor = Polygon(build.room.floor).buffer(0.02)
    by_id = {o.id: o for o in build.objects}
    for oid, kind in build.estimated_types.items():
        obj = by_id.get(oid)
        steps = db.type_footprints.get(kind)
        if obj is None or not steps or float(obj.aabb()[0][2]) > FLOOR_STANDING_M:
            continue  # a picture or a TV on the wall hangs at its wall's face: not fitted to the floor
        if _fits(obj, floor):
            continue
        _, _, height = obj.asset.extents
        said = ""
        for which, (x, z) in zip(("its type's 25th-percentile footprint", "its type's smallest footprint"), steps[1:], strict=True):
            obj.asset, said = obj.asset.model_copy(update={"extents": (x, z, height)}), which
            if _fits(obj, floor):
                break
        build.size_estimates[oid] += f"; the median ran through the room's walls where it stands: {said}"


def _fits(obj: SceneObject, floor: Polygon) -> bool:
    """Whether ``obj``'s footprint lies on ``floor`` (not through the room's walls)."""
    return bool(floor.covers(Polygon(obj.footprint())))


BASE_Y_TOLERANCE_M = 0.02
"""How near ``y = 0`` (or half its height) a floor object's ``y`` must be to say where the file
puts positions (:func:`positions_at_base`), m."""


def positions_at_base(top: Mapping[str, Any], db: AssetDatabase) -> bool:
    """Whether a house file writes an object's ``position`` at the bottom of its box (``y = 0`` for
    what stands on the floor, as some forks do) instead of ProcTHOR's box centre. Decided per file
    from its top-level objects whose box the database knows and that are not flat: those whose
    ``y`` lies within :data:`BASE_Y_TOLERANCE_M` of 0 against those within it of half their height
    (a picture on a wall counts for neither); ties read as ProcTHOR's centres."""
    base = centre = 0
    for item in top.get("objects") or []:
        if not isinstance(item, Mapping):
            continue
        box = db.boxes.get(str(item.get("assetId")))
        pos = item.get("position")
        y = pos.get("y") if isinstance(pos, Mapping) else None
        if box is None or not isinstance(y, int | float) or box[1] / 2 <= 2 * BASE_Y_TOLERANCE_M:
            continue
        if abs(y) <= BASE_Y_TOLERANCE_M:
            base += 1
        elif abs(y - box[1] / 2) <= BASE_Y_TOLERANCE_M:
            centre += 1
    return base > centre


def _distinct_ids(objects: Any) -> dict[str, tuple[str, str]]:
    """The objects (children included, in file order) whose ``id`` an object before them holds
    already (a hand edit, a merge of two files): by field (``objects[4].children[0]``), the id each
    is read and written back by, ``<id>#<k>`` (the k-th of that id, a number no other id of the
    file takes), and the field of the first object with the id. The reader and the writer walk
    the file alike, so a house written back puts each object where its own scene object stands."""
    fields: list[tuple[str, str]] = []

    def walk(items: Any, prefix: str) -> None:
        if not isinstance(items, list):
            return
        for i, item in enumerate(items):
            if not isinstance(item, dict):
                continue
            f = f"{prefix}[{i}]"
            if isinstance(item.get("id"), str):
                fields.append((f, item["id"]))
            walk(item.get("children"), f"{f}.children")

    walk(objects, "objects")
    used = {raw for _, raw in fields}
    first: dict[str, str] = {}
    out: dict[str, tuple[str, str]] = {}
    for f, raw in fields:
        if raw not in first:
            first[raw] = f
            continue
        k = 2
        while f"{raw}#{k}" in used:
            k += 1
        used.add(f"{raw}#{k}")
        out[f] = (f"{raw}#{k}", first[raw])
    return out


# -- writing a house back ---------------------------------------------------------------------------

HOUSE_FILE = "house.json"
"""The file :func:`export_procthor` writes in its folder."""


def _unity_pose(obj: SceneObject, at_base: bool = False) -> tuple[dict[str, float], dict[str, float]]:
    """``position`` (the box centre; ``at_base``: the bottom of its box, :func:`positions_at_base`)
    and ``rotation`` (Euler degrees) of an object, in Unity's frame: :func:`_add_object` run backwards."""
    rotation = quat_to_matrix(obj.pose.quaternion)
    unity = _SWAP @ rotation @ _HALF_TURN @ _SWAP
    ry, rx, rz = Rotation.from_matrix(unity).as_euler("YXZ", degrees=True)
    height = float(obj.asset.extents[2]) * float(obj.pose.scale[2])
    centre = np.asarray(obj.pose.position, dtype=np.float64) + rotation @ np.array([0.0, 0.0, height / 2.0])

    def tidy(v: float) -> float:
        return round(float(v), 6) + 0.0  # + 0.0: no "-0.0" in the file

    y = centre[2] - (height / 2.0 if at_base else 0.0)
    return (
        {"x": tidy(centre[0]), "y": tidy(y), "z": tidy(centre[1])},
        {"x": tidy(rx), "y": tidy(ry % 360.0), "z": tidy(rz)},
    )


def _clutter_items(scene: Scene, raw_ids: Mapping[str, str], at_base: bool = False) -> list[tuple[str | None, dict[str, Any]]]:
    """The objects a clutter pass drew from the asset database into ``scene`` (``docs/clutter.md``)
    as house-file items, each with the file's id of the receptacle it rests on (``None`` when that
    is no object of the file): a child of the receptacle there, as ProcTHOR lists the small
    objects on a receptacle."""
    record = (scene.metadata.get(CLUTTER_METADATA) or {}).get("objects") or {}
    known = {o.id for o in scene.objects}
    out: list[tuple[str | None, dict[str, Any]]] = []
    for oid, entry in sorted(record.items()):
        if oid in raw_ids or oid not in known or not isinstance(entry, dict) or not entry.get("asset_id"):
            continue  # the file's own objects are moved in place; what left the scene is not written
        obj = scene.get(oid)
        position, rotation = _unity_pose(obj, at_base)
        support = scene.support_of(oid)
        holder = raw_ids.get(support.parent) if support is not None else None
        item = {"assetId": str(entry["asset_id"]), "id": oid, "kinematic": False, "position": position, "rotation": rotation}
        out.append((holder, item))
    return out


def _source_name(path: str, index: int | None) -> str:
    return path if index is None else f"{path} house {index}"


def _write_back(scenes: list[Scene], folder: str | os.PathLike[str], what: str) -> Path:
    """Write ``folder/house.json``: the house file the ``scenes`` (rooms of one house) came from,
    with every object of theirs at its scene's pose; everything else as the house had it."""
    sources: set[tuple[str, int | None]] = set()
    placed: dict[str, SceneObject] = {}
    added: list[tuple[str | None, dict[str, Any]]] = []  # (the receptacle's id in the file, item)
    drawn: list[tuple[Scene, dict[str, str]]] = []  # each room with its objects' ids in the file
    rooms: list[str] = []
    for scene in scenes:
        origin = scene.provenance
        source = origin.source_path
        if origin.source_format != "procthor" or origin.source_room_id is None or not source:
            raise UsageError(
                f"scene {scene.id!r} was not imported from an AI2-THOR/ProcTHOR house "
                f"(source format {scene.provenance.source_format!r}); only such a scene can be written back as one"
            )
        sources.add((source, origin.source_index))
        known = {o.id for o in scene.objects}
        raw_ids = dict(origin.source_ids)
        placed.update({raw: scene.get(oid) for oid, raw in raw_ids.items() if oid in known})
        drawn.append((scene, raw_ids))
        rooms.append(origin.source_room_id)
    if len(sources) != 1:
        raise UsageError(
            f"the {what} comes from several houses ({', '.join(_source_name(*s) for s in sorted(sources, key=str))}); "
            "write one at a time"
        )
    source, index = sources.pop()
    path = Path(source)
    house = read_json(path) if index is None else dataset_entry(path, index).parse(path)
    if not isinstance(house, dict) or not isinstance(house.get("objects"), list):
        raise ImportFormatError(
            "the house the scene came from has no objects list", path=str(path), field="objects"
        )
    database = scenes[0].provenance.asset_database
    at_base = positions_at_base(house, load_asset_database(database if database and Path(database).is_file() else None))
    for scene, raw_ids in drawn:
        added.extend(_clutter_items(scene, raw_ids, at_base))
    moved = 0
    by_id: dict[str, dict[str, Any]] = {}
    renamed = _distinct_ids(house["objects"])  # as the reader named them: each by its own object

    def visit(items: list[Any], prefix: str) -> None:
        nonlocal moved
        for i, item in enumerate(items):
            if not isinstance(item, dict):
                continue
            f = f"{prefix}[{i}]"
            if f in renamed:
                item["id"] = renamed[f][0]
            by_id[str(item.get("id"))] = item
            obj = placed.get(str(item.get("id")))
            if obj is not None:
                item["position"], item["rotation"] = _unity_pose(obj, at_base)
                moved += 1
            children = item.get("children")
            if isinstance(children, list):
                visit(children, f"{f}.children")

    visit(house["objects"], "objects")
    for holder, item in added:
        parent = by_id.get(holder) if holder is not None else None
        if parent is None:
            house["objects"].append(item)
            continue
        item.setdefault("layer", parent.get("layer"))
        parent.setdefault("children", []).append(item)
    out = Path(folder) / HOUSE_FILE
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(out, json.dumps(house, indent=1, ensure_ascii=False) + "\n")
    log.info("procthor_exported", path=str(out), rooms=rooms, objects=moved, added=len(added), source=str(path))
    return out


def export_procthor(scene: Scene | House, folder: str | os.PathLike[str], base_dir: Path | None = None) -> Path:
    """Write ``folder/house.json``: the AI2-THOR / ProcTHOR / Holodeck house the scene was imported
    from, with every object of this room (top-level or a child) at the scene's pose; the other
    rooms, walls, doors, windows and every other field as the house had them. Returns its path.

    Only a scene imported from a house can be written back as one (it names the house file and
    maps its objects to the house's ids); others raise :class:`~scenemosaic.exceptions.UsageError`.
    Small objects a clutter pass drew from the asset database (``--clutter fill``) are added, each
    a child of the receptacle it rests on; other objects the house does not know are left out.
    """
    if isinstance(scene, House):  # a whole house: every room in one world
        return _export_procthor_house(scene, folder, base_dir)
    return _write_back([scene], folder, f"scene {scene.id!r}")


def _export_procthor_house(house: House, folder: str | os.PathLike[str], base_dir: Path | None = None) -> Path:
    """Write ``folder/house.json``: the AI2-THOR / ProcTHOR / Holodeck house ``house`` was imported
    from, with every object of every one of its rooms at its new pose (as :func:`export_procthor`
    writes one room); rooms of the file the house does not hold, walls, doors, windows and every
    other field stay as they were. Returns its path.

    Every room must come from the same house file; otherwise, or for a room not imported from such
    a house, raises :class:`~scenemosaic.exceptions.UsageError`.
    """
    return _write_back(list(house.rooms), folder, f"house {house.id!r}")

"""SceneEval ``sceneState`` import: the file SceneEval, SceneSmith and LayoutVLM exchange, and the
one :func:`~scenemosaic.exchange.export_sceneeval` writes.

Frames (the exact inverse of our export, ``_sceneeval.py``):

* The scene is Z-up and metric (``up`` = ``[0, 0, 1]``, ``unit`` = 1); arch points are world
  ``[x, y, z]``.
* Each object names a mesh by ``modelId`` = ``<source>.<assetId>`` and places it with a 4x4
  ``transform`` stored column-major in ``transform.data``: world = ``M`` · (raw glTF vertex).
  A glTF asset is Y-up with its front along +Z, so ``M = T · A`` with ``A = R · S · Rx(+90°)``.
  Removing the ``Rx(+90°)`` (right-multiplying by :data:`LOCAL_TO_GLTF`) leaves ``B = R · S``
  in our object frame (Z up, front -Y), which a polar decomposition splits into the rotation
  ``R`` and the stretch ``S``; the diagonal of ``S`` is the per-axis scale.
* The mesh, brought into the canonical frame (``load_mesh``: the same ``Rx(+90°)``, then its
  bottom centre moved to the origin), gives the asset extents; the pose position is where that
  bottom centre lands, ``T + B · c``.

Meshes are looked up as ``<assetId>.glb`` in ``asset_dir`` (when given), then in ``assets/``
beside the file: the layout our export writes. A mesh found there must resolve (symlinks
followed) inside the scene file's folder or ``asset_dir``. Objects become
``AssetRef(kind="mesh")`` with a uri relative to the scene file's folder when the mesh lies under
it (absolute otherwise), the mesh's canonical ``source_transform`` and content hash.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import structlog
from pydantic import ValidationError
from scipy.spatial.transform import Rotation
from shapely.geometry import Point, Polygon

from scenemosaic.assets import CanonicalMesh, load_mesh
from scenemosaic.exceptions import AssetError
from scenemosaic.exchange._common import FieldReader, normalize_label
from scenemosaic.exchange._sceneeval import LOCAL_TO_GLTF
from scenemosaic.scene import (
    CEILING,
    FLOOR,
    MAX_OBJECT_SIZE,
    AssetRef,
    FloatArray,
    Opening,
    Pose,
    Provenance,
    Relation,
    Room,
    Scene,
    SceneObject,
    Wall,
    coordinate_problem,
    normalize_category,
    recover_room,
    sanitize_id,
    scale_problem,
    unique_id,
)

__all__ = ["SCENEEVAL_ASSET_FOLDER", "import_sceneeval", "looks_like_sceneeval"]

log = structlog.get_logger(__name__)

IMPORTER = "scenemosaic.exchange.sceneeval"
SCENEEVAL_ASSET_FOLDER = "assets"
"""Folder beside a sceneState file where its ``<assetId>.glb`` meshes are looked up."""
MAX_LISTED_MISSING = 10
"""Missing asset ids named in the error message; the rest are counted."""

_AFFINE_TOL = 1e-6  # bottom row of a transform must be (0, 0, 0, 1) to this tolerance
_SHEAR_TOL = 1e-6  # off-diagonal stretch (relative) above which a note says it was dropped
_HASH_TAIL = re.compile(r"[_\-.]?[0-9a-fA-F]{8,}(?:-[0-9a-fA-F]{4,})*$")
_OBJECT_ID = re.compile(r"^[A-Za-z0-9_.\-]{1,64}$")
_HOLE_KINDS: dict[str, Literal["door", "window"]] = {"door": "door", "window": "window"}


def looks_like_sceneeval(data: Any) -> bool:
    """Detection rule: ``{"format": "sceneState", "scene": {...}}``."""
    return (
        isinstance(data, dict) and data.get("format") == "sceneState" and isinstance(data.get("scene"), dict)
    )


def import_sceneeval(data: Any, path: Path, *, asset_dir: Path | None = None) -> Scene:
    """Build a :class:`Scene` of mesh objects from a parsed SceneEval sceneState file at ``path``.

    Each object's mesh is ``<assetId>.glb`` (``assetId`` = the ``modelId`` after its first dot)
    in ``asset_dir`` when given, else in ``assets/`` beside the file. Its category is the
    object's ``category`` field, else derived from the ``modelId`` (a trailing hash or uuid
    removed; ``"object"`` when nothing is left). The room comes from ``arch`` (one ``Floor``
    element, its ``Wall`` elements and, for the ceiling height, its ``Ceiling`` element or the
    tallest wall); without an ``arch`` the room is recovered from the objects. A non-empty
    ``parentId`` naming another object (or an arch element) becomes an ``attach`` relation; an
    empty one gives no relation (support is inferred later).

    Raises:
        ImportFormatError: naming the file and field for malformed input (non-finite or
            reflecting transforms included), and once, listing them, for missing meshes.
    """
    r = FieldReader(path)
    top = r.mapping(data, "")
    fmt = r.get(top, "format", "")
    if fmt != "sceneState":
        r.fail("format", f"expected 'sceneState', got {fmt!r}")
    body = r.mapping(r.get(top, "scene", ""), "scene")
    _check_frame(r, body)
    raw_objects = r.objects(body.get("object") or [], "scene.object")

    # pass 1: everything the file itself says (fails fast on malformed fields)
    parsed: list[_Parsed] = []
    taken: set[str] = set()
    for i, raw in enumerate(raw_objects):
        parsed.append(_parse_object(r, raw, i, taken))

    # pass 2: meshes, all looked up before failing so the error lists every missing one
    folders = ([asset_dir] if asset_dir is not None else []) + [path.parent / SCENEEVAL_ASSET_FOLDER]
    found: dict[str, Path] = {}
    missing: dict[str, str] = {}
    for p in parsed:
        if p.asset_id in found or p.asset_id in missing:
            continue
        hit = next((d / f"{p.asset_id}.glb" for d in folders if (d / f"{p.asset_id}.glb").is_file()), None)
        if hit is None:
            missing[p.asset_id] = p.field
        else:
            # the file found may be a symlink: where it leads must be the scene's folder or asset_dir
            found[p.asset_id] = r.file(
                path.parent,
                str(hit.absolute()),
                f"{p.field}.modelId",
                roots=[asset_dir] if asset_dir is not None else [],
                what=f"asset {p.asset_id!r}",
            )
    if missing:
        _fail_missing(r, missing, folders)

    notes: list[str] = []
    canonical: dict[str, CanonicalMesh] = {}
    objects: list[SceneObject] = []
    base = path.parent.resolve()
    for p in parsed:
        if p.asset_id not in canonical:
            try:
                canonical[p.asset_id] = load_mesh(found[p.asset_id], up_axis="y")
            except AssetError as exc:
                r.fail(f"{p.field}.modelId", f"asset {p.asset_id!r}: {exc}")
        mesh = canonical[p.asset_id]
        transform = np.asarray(mesh.transform, dtype=np.float64)
        bottom_centre = -transform[:3, 3]  # load_mesh translates the bottom centre to the origin
        position = p.translation + p.linear @ bottom_centre
        if p.shear > _SHEAR_TOL:
            notes.append(
                f"{p.field}.transform has shear ({p.shear:.2g} of its scale); kept its per-axis scale"
            )
        objects.append(
            r.scene_object(
                p.field,
                f"object {p.source_id or p.oid!r}",
                id=p.oid,
                category=p.category,
                description=f"SceneEval model {p.model_id}"[:500],
                asset=AssetRef(
                    kind="mesh",
                    uri=_uri(found[p.asset_id], base),
                    extents=mesh.extents,
                    sha256=mesh.sha256,
                    source_transform=[float(v) for v in transform.reshape(-1)],
                ),
                pose=Pose(position=_vec3(position), quaternion=p.quaternion, scale=p.scale),
            )
        )

    arch = body.get("arch")
    room, element_anchors = (
        _room_from_arch(r, arch, {p.oid for p in parsed}, notes) if arch is not None else (None, {})
    )
    if room is None:
        if not objects:
            r.fail("scene.object", "the scene holds neither objects nor an arch to take a room from")
        room = recover_room(objects, source=str(path))
        notes.append("no arch floor: room recovered from the objects")

    relations = _relations(parsed, element_anchors, notes)
    scene_id = _text_id(body.get("id"))
    log.debug("sceneeval_imported", path=str(path), objects=len(objects), assets=len(canonical))
    return Scene(
        id=sanitize_id(scene_id or path.stem, fallback="scene"),
        room=room,
        objects=objects,
        relations=relations,
        metadata={
            "sceneeval": {
                "model_ids": {p.oid: p.model_id for p in parsed},
                "support_types": {p.oid: p.support_type for p in parsed if p.support_type is not None},
                "asset_dir": str(asset_dir) if asset_dir is not None else None,
            }
        },
        provenance=Provenance(
            source_format="sceneeval", source_path=path.as_posix(), importer=IMPORTER, notes=notes,
            source_ids={p.oid: str(p.source_id) for p in parsed if p.source_id is not None},
            asset_ids={p.oid: str(p.model_id) for p in parsed if p.model_id is not None},
        ),
    )


# -- objects --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Parsed:
    """One object as the file states it (before its mesh is read)."""

    field: str
    oid: str
    source_id: str | None
    model_id: str
    asset_id: str
    category: str
    parent: str | None
    support_type: str | None
    translation: FloatArray
    linear: FloatArray
    quaternion: tuple[float, float, float, float]
    scale: tuple[float, float, float]
    shear: float


def _parse_object(r: FieldReader, raw: Any, i: int, taken: set[str]) -> _Parsed:
    f = f"scene.object[{i}]"
    item = r.mapping(raw, f)
    model_id = r.text(r.get(item, "modelId", f), f"{f}.modelId").strip()
    asset_id = model_id.split(".", 1)[1] if "." in model_id else model_id
    if not asset_id or asset_id in (".", "..") or "/" in asset_id or "\\" in asset_id:
        r.fail(f"{f}.modelId", f"{model_id!r} does not name an asset (expected '<source>.<assetId>')")
    category = _category(item.get("category"), asset_id)
    source_id = _text_id(item.get("id"))
    oid = unique_id(sanitize_id(source_id) if source_id else f"{category}_{i}", taken)
    parent = _text_id(item.get("parentId"))
    support = item.get("sceneeval")
    support_type = support.get("supportType") if isinstance(support, Mapping) else None
    translation, linear, quaternion, scale, shear = _decompose(r, item, f)
    return _Parsed(
        field=f,
        oid=oid,
        source_id=source_id,
        model_id=model_id,
        asset_id=asset_id,
        category=category,
        parent=parent or None,
        support_type=support_type if isinstance(support_type, str) else None,
        translation=translation,
        linear=linear,
        quaternion=quaternion,
        scale=scale,
        shear=shear,
    )


def _category(raw: Any, asset_id: str) -> str:
    if isinstance(raw, str) and raw.strip():
        return raw.strip()[:64]  # kept verbatim, so our own export re-imports unchanged
    stem = _HASH_TAIL.sub("", asset_id)  # "dining_chair_0a1b2c3d4e" -> "dining_chair"; a bare uid -> ""
    label = normalize_label(stem) if stem else None
    return normalize_category(label) if label else "object"


def _decompose(
    r: FieldReader, item: Mapping[str, Any], f: str
) -> tuple[FloatArray, FloatArray, tuple[float, float, float, float], tuple[float, float, float], float]:
    """Translation, ``B = R·S`` (our object frame), R as a quaternion, per-axis scale, relative shear."""
    tf = f"{f}.transform"
    t = r.mapping(r.get(item, "transform", f), tf)
    for key in ("rows", "cols"):
        if key in t and t[key] != 4:
            r.fail(f"{tf}.{key}", f"expected 4, got {t[key]!r}")
    values = r.vector(r.get(t, "data", tf), 16, f"{tf}.data")
    m = np.asarray(values, dtype=np.float64).reshape(4, 4).T  # stored column-major
    if np.max(np.abs(m[3] - np.array([0.0, 0.0, 0.0, 1.0]))) > _AFFINE_TOL:
        r.fail(tf, f"not an affine transform: bottom row {m[3].tolist()} (expected [0, 0, 0, 1])")
    linear = m[:3, :3] @ LOCAL_TO_GLTF[:3, :3]  # undo the Rx(+90°) that turns glTF assets Z-up
    w, sigma, vt = np.linalg.svd(linear)
    if sigma[-1] <= 1e-9 * max(1.0, float(sigma[0])):
        r.fail(tf, f"degenerate transform (singular values {sigma.tolist()})")
    if np.linalg.det(linear) < 0:
        r.fail(tf, "the transform mirrors the object (negative determinant); reflections are not supported")
    r.check(coordinate_problem(m[:3, 3]), f"{tf}.data")
    rotation = w @ vt
    stretch = vt.T @ np.diag(sigma) @ vt
    scale = np.diag(stretch).copy()
    r.check(scale_problem(scale), tf)
    off = stretch - np.diag(scale)
    shear = float(np.max(np.abs(off)) / sigma[0])
    qx, qy, qz, qw = Rotation.from_matrix(rotation).as_quat()
    return (
        m[:3, 3].copy(),
        linear,
        (float(qw), float(qx), float(qy), float(qz)),
        _vec3(scale),
        shear,
    )


def _relations(parsed: list[_Parsed], element_anchors: Mapping[str, str], notes: list[str]) -> list[Relation]:
    by_source = {p.source_id: p.oid for p in parsed if p.source_id is not None}
    parent_of: dict[str, str] = {}
    for p in parsed:
        if p.parent is None:
            continue
        target = by_source.get(p.parent) or element_anchors.get(p.parent)
        if target is None:
            notes.append(f"{p.field}.parentId {p.parent!r} names no object nor arch element; no relation")
        elif target == p.oid:
            notes.append(f"{p.field}.parentId names the object itself; no relation")
        else:
            parent_of[p.oid] = target
    accepted: dict[str, str] = {}
    for child, parent in parent_of.items():
        node: str | None = parent
        while node is not None and node != child:  # a support cycle cannot be simulated
            node = accepted.get(node)
        if node == child:
            notes.append(f"object {child!r}: parentId closes a cycle; relation to {parent!r} dropped")
        else:
            accepted[child] = parent
    return [Relation(kind="attach", child=c, parent=p, source=IMPORTER) for c, p in accepted.items()]


# -- arch -----------------------------------------------------------------------------------------


def _room_from_arch(
    r: FieldReader, arch_raw: Any, object_ids: set[str], notes: list[str]
) -> tuple[Room | None, dict[str, str]]:
    """The room and a map from arch element id (as text) to our anchor id."""
    arch = r.mapping(arch_raw, "scene.arch")
    scale = arch.get("scaleToMeters", 1)
    if scale is not None and (
        isinstance(scale, bool) or not isinstance(scale, int | float) or abs(float(scale) - 1.0) > 1e-9
    ):
        r.fail("scene.arch.scaleToMeters", f"only metric arches (1) are supported, got {scale!r}")
    elements = r.array(arch.get("elements") or [], "scene.arch.elements")
    floors: list[tuple[int, Mapping[str, Any]]] = []
    walls: list[tuple[int, Mapping[str, Any]]] = []
    ceilings: list[tuple[int, Mapping[str, Any]]] = []
    for k, raw in enumerate(elements):
        e = r.mapping(raw, f"scene.arch.elements[{k}]")
        kind = e.get("type")
        if kind == "Floor":
            floors.append((k, e))
        elif kind == "Wall":
            walls.append((k, e))
        elif kind == "Ceiling":
            ceilings.append((k, e))
    if not floors:
        return None, {}
    if len(floors) > 1:
        r.fail(
            "scene.arch.elements",
            f"the arch has {len(floors)} Floor elements; only single-room scenes are read",
        )
    k, floor_el = floors[0]
    ff = f"scene.arch.elements[{k}]"
    pts = [
        r.vector(p, 3, f"{ff}.points[{j}]")
        for j, p in enumerate(r.array(r.get(floor_el, "points", ff), f"{ff}.points"))
    ]
    for j, p in enumerate(pts):
        r.check(coordinate_problem(p[:2]), f"{ff}.points[{j}]")
    floor = [(p[0], p[1]) for p in pts]
    if len(floor) < 3:
        r.fail(f"{ff}.points", f"a floor polygon needs at least 3 points, got {len(floor)}")
    polygon = Polygon(floor)
    if not polygon.is_valid or polygon.area <= 1e-9:
        r.fail(f"{ff}.points", "the floor polygon is degenerate or self-intersecting")
    room_id = _text_id(floor_el.get("roomId")) or ""
    room_id = room_id if _OBJECT_ID.match(room_id) else "room"

    heights: list[float] = []
    for k, c in ceilings:
        cf = f"scene.arch.elements[{k}]"
        for j, p in enumerate(r.array(c.get("points") or [], f"{cf}.points")):
            heights.append(r.vector(p, 3, f"{cf}.points[{j}]")[2])
    ceiling = max(heights) if heights and max(heights) > 0 else None

    anchors: dict[str, str] = {}
    anchors[str(floor_el.get("id"))] = FLOOR
    for k, _ in ceilings:
        anchors[str(elements[k].get("id"))] = CEILING
    built: list[Wall] = []
    wall_ids: set[str] = set()
    reserved = object_ids | {FLOOR, CEILING}
    for n, (k, w) in enumerate(walls):
        wall = _wall(r, w, f"scene.arch.elements[{k}]", n, polygon, reserved | wall_ids, ceiling)
        wall_ids.add(wall.id)
        built.append(wall)
        anchors[str(w.get("id"))] = wall.id
    if ceiling is None:
        ceiling = max((w.height for w in built), default=None)
    try:
        if built:
            room = Room(id=room_id, floor=floor, walls=built, ceiling_height=ceiling or 2.8)
        else:
            room = Room.from_polygon(floor, ceiling_height=ceiling or 2.8, room_id=room_id)
            notes.append("the arch has no walls: one wall per floor edge")
    except ValidationError as exc:
        r.fail(ff, exc.errors()[0]["msg"])
    return room, anchors


def _wall(
    r: FieldReader,
    w: Mapping[str, Any],
    f: str,
    n: int,
    polygon: Polygon,
    reserved: set[str],
    ceiling: float | None,
) -> Wall:
    pts = r.array(r.get(w, "points", f), f"{f}.points")
    if len(pts) != 2:
        r.fail(f"{f}.points", f"a wall needs 2 points, got {len(pts)}")
    a = r.vector(pts[0], 3, f"{f}.points[0]")
    b = r.vector(pts[1], 3, f"{f}.points[1]")
    r.check(coordinate_problem(a[:2]), f"{f}.points[0]")
    r.check(coordinate_problem(b[:2]), f"{f}.points[1]")
    start, end = (a[0], a[1]), (b[0], b[1])
    length = math.dist(start, end)
    if length < 1e-9:
        r.fail(f"{f}.points", "the wall has zero length")
    height = r.number(w["height"], f"{f}.height") if "height" in w else ceiling
    if height is None or height <= 0:
        r.fail(f"{f}.height", "missing or non-positive wall height (and no ceiling to take it from)")
    if height > MAX_OBJECT_SIZE:
        r.fail(f"{f}.height", f"wall height {height:g} m is above the {MAX_OBJECT_SIZE:g} m maximum")
    thickness = r.number(w["depth"], f"{f}.depth") if "depth" in w else 0.1
    if thickness <= 0:
        r.fail(f"{f}.depth", f"wall depth must be positive, got {thickness}")
    openings = []
    for j, raw in enumerate(r.array(w.get("holes") or [], f"{f}.holes")):
        hf = f"{f}.holes[{j}]"
        hole = r.mapping(raw, hf)
        box = r.mapping(r.get(hole, "box", hf), f"{hf}.box")
        lo = r.vector(r.get(box, "min", f"{hf}.box"), 2, f"{hf}.box.min")
        hi = r.vector(r.get(box, "max", f"{hf}.box"), 2, f"{hf}.box.max")
        if hi[0] <= lo[0] or hi[1] <= lo[1]:
            r.fail(f"{hf}.box", f"empty hole box {list(lo)}..{list(hi)}")
        kind: Literal["door", "window", "opening"] = _HOLE_KINDS.get(
            str(hole.get("type", "")).lower(), "opening"
        )
        bottom = max(lo[1], 0.0)
        openings.append(
            Opening(
                kind=kind,
                center=(lo[0] + hi[0]) / 2,
                width=hi[0] - lo[0],
                bottom=bottom,
                height=hi[1] - bottom,
            )
        )
    # our walls keep the room on their left; a wall listed the other way round is turned, and
    # its openings measured from the new start
    mid = ((start[0] + end[0]) / 2, (start[1] + end[1]) / 2)
    left = (-(end[1] - start[1]) / length, (end[0] - start[0]) / length)
    eps = min(1e-3, length / 4)
    if not polygon.covers(Point(mid[0] + eps * left[0], mid[1] + eps * left[1])) and polygon.covers(
        Point(mid[0] - eps * left[0], mid[1] - eps * left[1])
    ):
        start, end = end, start
        openings = [o.model_copy(update={"center": length - o.center}) for o in openings]
    raw_id = w.get("id")
    candidate = str(raw_id).rsplit("|", 1)[-1] if isinstance(raw_id, str) else ""
    if not _OBJECT_ID.match(candidate) or candidate in reserved:
        candidate = f"wall_{n}"
        while candidate in reserved:
            candidate += "_"
    return Wall(id=candidate, start=start, end=end, height=height, thickness=thickness, openings=openings)


# -- helpers --------------------------------------------------------------------------------------


def _check_frame(r: FieldReader, body: Mapping[str, Any]) -> None:
    up = body.get("up")
    if up is not None:
        vec = r.vector(up, 3, "scene.up")
        if max(abs(a - b) for a, b in zip(vec, (0.0, 0.0, 1.0), strict=True)) > 1e-9:
            r.fail("scene.up", f"only Z-up scenes ([0, 0, 1]) are supported, got {list(vec)}")
    unit = body.get("unit")
    if unit is not None and abs(r.number(unit, "scene.unit") - 1.0) > 1e-9:
        r.fail("scene.unit", f"only metric scenes (unit 1.0) are supported, got {unit!r}")


def _fail_missing(r: FieldReader, missing: Mapping[str, str], folders: list[Path]) -> None:
    ids = list(missing)
    listed = ", ".join(ids[:MAX_LISTED_MISSING])
    more = f" and {len(ids) - MAX_LISTED_MISSING} more" if len(ids) > MAX_LISTED_MISSING else ""
    where = " and ".join(str(d) for d in folders)
    r.fail(
        f"{next(iter(missing.values()))}.modelId",
        f"{len(ids)} asset mesh(es) not found: {listed}{more}. Looked for <assetId>.glb in {where}. "
        "SceneEval files name their meshes without carrying them: pass asset_dir= (on the command line: "
        "--asset-dir) pointing at a folder of <assetId>.glb files",
    )


def _text_id(value: Any) -> str | None:
    """An id the file gives as a string or an integer; ``None`` for anything else or ``""``."""
    if isinstance(value, bool) or not isinstance(value, str | int):
        return None
    return str(value).strip() or None


def _uri(mesh: Path, base: Path) -> str:
    resolved = mesh.resolve()
    try:
        return resolved.relative_to(base).as_posix()
    except ValueError:  # outside the scene folder: keep it absolute, as the SAM3D importer does
        return resolved.as_posix()


def _vec3(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))

"""3D-FRONT / ATISS / PhyScene layouts: ``{"ThreedFront": {model_id: [object, ...]}, ...}``.

Per object: ``label``; ``size`` = half extents (x, y, z), Y-up, metres; ``position`` = the
bottom centre (3D-FUTURE meshes have their origin there), Y-up; ``theta`` = rotation about +Y
in radians. Y-up (x, y, z) becomes Z-up (x, -z, y), a proper rotation (+90 degrees about X),
under which a rotation about +Y becomes the same rotation about +Z. 3D-FUTURE models face
+Z in their own Y-up frame, which is -Y after the change of axes: exactly our front, so
``yaw = theta`` and ``extents = (2 sx, 2 sz, 2 sy)``.

The generator's errors (sunk or floating objects, a pendant lamp on the floor, chairs driven
into tables) are kept as they are: structuring and physics fix them, the importer does not.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import structlog

from scenemosaic.exchange._common import FieldReader
from scenemosaic.scene import (
    AssetRef,
    Pose,
    Provenance,
    Room,
    Scene,
    SceneObject,
    coordinate_problem,
    object_count_problem,
    recover_room,
    sanitize_id,
    size_problem,
    unique_id,
)

__all__ = ["FRONT3D_KEY", "import_front3d", "looks_like_front3d"]

log = structlog.get_logger(__name__)

FRONT3D_KEY = "ThreedFront"
"""Top-level key that marks a 3D-FRONT-style layout."""
IMPORTER = "scenemosaic.exchange.front3d"


def looks_like_front3d(data: Any) -> bool:
    """Detection rule: a JSON object with a ``ThreedFront`` key."""
    return isinstance(data, dict) and FRONT3D_KEY in data


def import_front3d(data: Any, path: Path, *, room: Room | None = None) -> Scene:
    """Build a :class:`Scene` of procedural objects from a parsed 3D-FRONT-style layout.

    Ids are ``<label>_<n>``, numbered per label in file order from 0 (stable for a given file).
    Without ``room`` the room is recovered from the objects (:func:`recover_room`).
    """
    r = FieldReader(path)
    top = r.mapping(data, "")
    models = r.mapping(r.get(top, FRONT3D_KEY, ""), FRONT3D_KEY)
    # counted over every model before any object is built
    r.check(object_count_problem(sum(len(v) for v in models.values() if isinstance(v, list))), FRONT3D_KEY)
    taken: set[str] = set()
    counters: dict[str, int] = {}
    objects: list[SceneObject] = []
    source_ids: dict[str, dict[str, Any]] = {}
    for model_id, entries in models.items():
        base = f"{FRONT3D_KEY}.{model_id}"
        for i, raw in enumerate(r.array(entries, base)):
            field = f"{base}[{i}]"
            item = r.mapping(raw, field)
            label = r.label(r.get(item, "label", field), f"{field}.label")
            n = counters.get(label, 0)
            counters[label] = n + 1
            oid = unique_id(sanitize_id(f"{label}_{n}"), taken)
            who = f"object {oid!r}"
            sx, sy, sz = r.vector(r.get(item, "size", field), 3, f"{field}.size")
            if min(sx, sy, sz) <= 0:
                r.fail(f"{field}.size", f"half extents must be positive, got {[sx, sy, sz]}")
            r.check(size_problem((2 * sx, 2 * sy, 2 * sz)), f"{field}.size", what=who)
            px, py, pz = r.vector(r.get(item, "position", field), 3, f"{field}.position")
            r.check(coordinate_problem((px, py, pz)), f"{field}.position", what=who)
            theta = r.number(r.get(item, "theta", field), f"{field}.theta")
            objects.append(
                SceneObject(
                    id=oid,
                    category=label,
                    description=label.replace("_", " "),
                    asset=AssetRef(kind="procedural", category=label, extents=(2 * sx, 2 * sz, 2 * sy)),
                    pose=Pose.from_yaw((px, -pz, py), theta),
                )
            )
            source_ids[oid] = {"model_id": str(model_id), "index": i}
    if not objects:
        r.fail(FRONT3D_KEY, "the layout holds no objects")
    scene_room = room if room is not None else recover_room(objects, source=str(path))
    log.debug("front3d_imported", path=str(path), objects=len(objects), room_given=room is not None)
    return Scene(
        id=sanitize_id(path.stem, fallback="scene"),
        room=scene_room,
        objects=objects,
        metadata={"front3d": {"source_ids": source_ids, "room_recovered": room is None}},
        provenance=Provenance(source_format="front3d", source_path=path.as_posix(), importer=IMPORTER),
    )

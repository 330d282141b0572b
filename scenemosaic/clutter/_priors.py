"""What the ProcTHOR priors say about small objects: which types a receptacle holds, how many, and
which real assets stand for each type.

Three shipped files are read (or the same files of a ``--priors`` folder):

* ``receptacles.json`` — per receptacle type, per object type found on or in it: ``count`` (how
  many were seen over all ProcTHOR houses) and ``p`` (the share of that receptacle type's
  instances that held one). ``count / p`` is the number of receptacle instances observed, so
  ``sum(count) / (count / p)`` is the **typical density**: the mean number of small objects one
  receptacle of the type holds (a dining table 4.1, a side table 2.0, a chair 0.14);
* ``placement-annotations.json`` — per type, in which room types it appears (``inKitchens``,
  ``inLivingRooms``, ``inBedrooms``, ``inBathrooms``) and whether it is picked up;
* ``asset-database.json`` — per type, the real assets: id and bounding box (Unity frame, ``y`` up).

Types whose procedural model opens (a laptop's lid, a box's flaps) are left out: a hinge on a
small free body rattles as it rests. The database carries no mass or friction; those come from the attributes table the structuring
stage uses (``structure.attribute_row``: a fill density and a mass range per category group, a
friction per group), so an object drawn here weighs what the same object would weigh had the input
held it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from scenemosaic.assets import procedural_articulation
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, Scene, load_priors, normalize_category
from scenemosaic.structure import attribute_row

__all__ = [
    "ROOM_TYPE_FLAGS",
    "ClutterAsset",
    "ClutterPriors",
    "load_clutter_priors",
    "room_kind",
    "thor_category",
]

EXTRA_CLUTTER_TYPES = frozenset({"DeskLamp", "HousePlant"})
"""Types that are not picked up in AI2-THOR but stand on furniture as small objects do (a lamp on a
nightstand, a plant on a shelf)."""
LEFT_OUT_TYPES = frozenset({"Pillow", "Footstool", "TableTopDecor", "Boots", "Cloth", "Towel", "HandTowel"})
"""Pickupable types never drawn: soft things a rigid stand-in does not model (a pillow, a towel,
a cloth rocks and tips where the real one moulds to its support), and types whose name our
category vocabulary reads as another type (``footstool`` is an ottoman, ``table_top_decor`` a
table)."""
MAX_CLUTTER_SIDE_M = 0.6
"""An asset longer than this along any side is furniture, not clutter, whatever its type says."""

ROOM_TYPE_FLAGS: dict[str, tuple[str, ...]] = {
    "bedroom": ("inBedrooms",),
    "living": ("inLivingRooms",),
    "dining": ("inLivingRooms", "inKitchens"),
    "kitchen": ("inKitchens",),
    "bathroom": ("inBathrooms",),
}
"""Which placement-annotation flags admit a type in a room of each kind (a dining room takes what
ProcTHOR puts in living rooms or kitchens: it has no dining rooms of its own)."""


def thor_category(object_type: str) -> str:
    """Our category for an AI2-THOR type: its snake-case name, normalized (``AlarmClock`` ->
    ``alarm_clock``), as the ProcTHOR importer names an object of the type."""
    snake = "".join(f"_{c.lower()}" if c.isupper() else c for c in object_type).lstrip("_")
    return normalize_category(snake)


def room_kind(scene: Scene) -> str | None:
    """The kind of room ``scene`` is (a key of :data:`ROOM_TYPE_FLAGS`), from the room type its source gives (ProcTHOR, Holodeck),
    else from the words of its id or source file; ``None`` when nothing says (every type allowed)."""
    source_kind = scene.provenance.room_type
    words = " ".join(
        str(w).lower()
        for w in (source_kind, scene.id, scene.room.id if scene.room else None, scene.provenance.source_path)
        if w
    )
    for key, kind in (
        ("bath", "bathroom"),
        ("kitchen", "kitchen"),
        ("bed", "bedroom"),
        ("living", "living"),
        ("dining", "dining"),
    ):
        if key in words:
            return kind
    return None


@dataclass(frozen=True)
class ClutterAsset:
    """One entry of the asset database: its id, AI2-THOR type, our category and its box
    ``(width, depth, height)`` in metres (our frame: z up)."""

    asset_id: str
    object_type: str
    category: str
    size: tuple[float, float, float]

    @property
    def footprint_m2(self) -> float:
        """Area of the box's base, square metres."""
        return self.size[0] * self.size[1]

    def mass_kg(self) -> float:
        """Mass from the attributes table's row of the category: fill density times box volume,
        clamped to the row's range (kilograms)."""
        _, row = attribute_row(self.category)
        lo, hi = row.mass_range_kg
        return round(min(max(row.fill_density * math.prod(self.size), lo), hi), 3)

    def friction(self) -> float:
        """Sliding friction from the attributes table's row of the category."""
        return attribute_row(self.category)[1].friction


@dataclass(frozen=True)
class ClutterPriors:
    """The priors a clutter run draws from (:func:`load_clutter_priors`).

    ``held[receptacle][type]``: the share of the receptacle type's instances that held the type
    (``p``); ``typical[receptacle]``: its typical density (small objects per receptacle);
    ``assets[type]``: the database entries of each type that may be drawn; ``rooms[type]``: the
    annotation flags under which the type appears.
    """

    held: dict[str, dict[str, float]]
    typical: dict[str, float]
    assets: dict[str, tuple[ClutterAsset, ...]]
    rooms: dict[str, frozenset[str]]
    source: str = ""
    by_id: dict[str, ClutterAsset] = field(default_factory=dict)

    def receptacle_type(self, category: str) -> str | None:
        """The receptacle type of a furniture category (``dining_table`` -> ``DiningTable``), or
        ``None`` when the priors know no receptacle of that kind."""
        t = load_priors(self.source or None).type_of(category)
        return t if t in self.held else None

    def object_type(self, category: str) -> str | None:
        """The AI2-THOR type of a small object's category, when the priors know it."""
        return load_priors(self.source or None).type_of(category)

    def allows(self, object_type: str, receptacle_type: str) -> bool:
        """Whether ProcTHOR found ``object_type`` on or in ``receptacle_type`` at least once."""
        return self.held.get(receptacle_type, {}).get(object_type, 0.0) > 0.0

    def choices(self, receptacle_type: str, kind: str | None) -> list[tuple[str, float]]:
        """The types that may be drawn for a receptacle in a room of ``kind``, with their weights
        (the priors' ``p``), sorted by type name (a stable order for seeded draws)."""
        flags = ROOM_TYPE_FLAGS.get(kind or "", ())
        out = []
        for t, p in sorted(self.held.get(receptacle_type, {}).items()):
            if p <= 0 or not self.assets.get(t):
                continue
            if flags and not (self.rooms.get(t, frozenset()) & set(flags)):
                continue
            out.append((t, p))
        return out


@lru_cache(maxsize=4)
def _load(folder: str) -> ClutterPriors:
    base = Path(folder)
    receptacles = json.loads((base / "receptacles.json").read_text(encoding="utf-8"))
    annotations = json.loads((base / "placement-annotations.json").read_text(encoding="utf-8"))
    db_path = base / "asset-database.json"
    if not db_path.is_file():  # a priors folder without its own database: the shipped one
        db_path = PROCTHOR_PRIORS_DIR / "asset-database.json"
    database = json.loads(db_path.read_text(encoding="utf-8"))
    priors = load_priors(folder)
    held: dict[str, dict[str, float]] = {}
    typical: dict[str, float] = {}
    for receptacle, kids in sorted(receptacles.items()):
        held[receptacle] = {t: float(v.get("p", 0.0)) for t, v in kids.items()}
        instances = max((float(v["count"]) / float(v["p"]) for v in kids.values() if v.get("p")), default=0.0)
        total = sum(float(v.get("count", 0)) for v in kids.values())
        typical[receptacle] = total / instances if instances else 0.0
    wanted = (priors.pickupable | EXTRA_CLUTTER_TYPES) - LEFT_OUT_TYPES
    assets: dict[str, tuple[ClutterAsset, ...]] = {}
    by_id: dict[str, ClutterAsset] = {}
    for object_type, entries in sorted(database.items()):
        category = thor_category(object_type)
        if object_type not in wanted or priors.type_of(category) != object_type:
            continue
        kept = []
        for entry in entries:
            box = entry.get("boundingBox") or {}
            # Unity y is up: our (width, depth, height) is its (x, z, y)
            size = (float(box.get("x", 0)), float(box.get("z", 0)), float(box.get("y", 0)))
            if min(size) <= 0.005 or max(size) > MAX_CLUTTER_SIDE_M:
                continue
            asset = ClutterAsset(str(entry["assetId"]), object_type, category, size)
            kept.append(asset)
        # a small thing with a lid on a hinge (a laptop, a box) jitters on its joint as it rests
        if kept and not procedural_articulation(category, kept[0].size):
            assets[object_type] = tuple(sorted(kept, key=lambda a: a.asset_id))
            by_id.update((a.asset_id, a) for a in kept)
    rooms = {
        t: frozenset(
            flag
            for flags in ROOM_TYPE_FLAGS.values()
            for flag in flags
            if (annotations.get(flag) or {}).get(t)
        )
        for t in assets
    }
    return ClutterPriors(held=held, typical=typical, assets=assets, rooms=rooms, source=folder, by_id=by_id)


def load_clutter_priors(folder: str | Path | None = None) -> ClutterPriors:
    """The clutter priors of ``folder`` (a ``--priors`` folder), by default the shipped ones."""
    return _load(str(Path(folder).resolve()) if folder is not None else str(PROCTHOR_PRIORS_DIR))

"""Category knowledge shared by the structuring agents.

Two sources, merged:

* a small hand-written table of furniture traits (what can carry things, what opens to the
  front, what hangs from the ceiling, what stands with its back to a wall...) keyed by our
  normalized category names, which are the 3D-FRONT labels plus a few common extras;
* the ProcTHOR placement priors (``receptacles.json``: which object types were found on which
  receptacle types; ``placement-annotations.json``: floor / wall / pickupable flags), keyed by
  AI2-THOR object types. Labels are mapped to AI2-THOR types with :data:`THOR_TYPE`.

The ProcTHOR files ship with the package (:data:`PROCTHOR_PRIORS_DIR`); a folder of the same
shape may be given instead.
"""

from __future__ import annotations

import dataclasses
import json
import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Literal

import structlog

__all__ = [
    "FIXTURE_CATEGORIES",
    "PROCTHOR_PRIORS_DIR",
    "SCREEN_CATEGORIES",
    "CategoryTraits",
    "SupportPriors",
    "is_fixture",
    "is_screen",
    "load_priors",
    "normalize_category",
    "priors_problem",
    "thor_type",
    "traits",
]

log = structlog.get_logger(__name__)

PROCTHOR_PRIORS_DIR = Path(__file__).resolve().parent / "priors" / "procthor"
"""ProcTHOR's published priors, shipped as package data (Apache-2.0, licence beside them):
``receptacles.json``, ``placement-annotations.json``, ``asset_groups/``, ``object-groups.json``
and ``asset-database.json`` (per-asset boxes, for AI2-THOR/ProcTHOR/Holodeck houses)."""

Placement = Literal["floor", "surface", "wall", "ceiling"]
Opening = Literal["front", "top"]


@dataclass(frozen=True)
class CategoryTraits:
    """What a category of object usually does in a room.

    ``placement`` is where it usually rests: ``floor`` (furniture that never stands on other
    furniture), ``surface`` (small things that sit on tables, shelves, the floor), ``wall``
    (mounted), ``ceiling`` (hanging). ``supports`` / ``contains``: whether other objects may
    rest on / inside it. ``opening`` is the side a container opens to. ``against_wall``: it
    usually stands with its back to a wall and its front to the room. ``built_in``: a fixture.
    """

    placement: Placement = "surface"
    supports: bool = False
    contains: bool = False
    opening: Opening | None = None
    against_wall: bool = False
    built_in: bool = False
    seat: bool = False
    table: bool = False


_F = CategoryTraits
# Normalized category -> traits. Keys are 3D-FRONT labels plus common extras (SAM3D / Holodeck names).
_TRAITS: dict[str, CategoryTraits] = {
    # beds
    "double_bed": _F("floor", supports=True, against_wall=True),
    "single_bed": _F("floor", supports=True, against_wall=True),
    "kids_bed": _F("floor", supports=True, against_wall=True),
    "bunk_bed": _F("floor", supports=True, against_wall=True),
    "king_bed": _F("floor", supports=True, against_wall=True),
    "bed": _F("floor", supports=True, against_wall=True),
    # storage
    "wardrobe": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "children_cabinet": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "cabinet": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "wine_cabinet": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "bookshelf": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "bookcase": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "shelf": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "shelving_unit": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "sideboard": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "dresser": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "tv_stand": _F("floor", supports=True, contains=True, opening="front", against_wall=True),
    "nightstand": _F("floor", supports=True, against_wall=True),
    "dressing_table": _F("floor", supports=True, against_wall=True, table=True),
    "console_table": _F("floor", supports=True, against_wall=True),
    "box": _F("surface", supports=True, contains=True, opening="top"),
    "basket": _F("surface", supports=False, contains=True, opening="top"),
    "storage_bin": _F("surface", supports=True, contains=True, opening="top"),
    # tables
    "dining_table": _F("floor", supports=True, table=True),
    "table": _F("floor", supports=True, table=True),
    "desk": _F("floor", supports=True, against_wall=True, table=True),
    "work_desk": _F("floor", supports=True, against_wall=True, table=True),
    "coffee_table": _F("floor", supports=True),
    "corner_side_table": _F("floor", supports=True),
    "round_end_table": _F("floor", supports=True),
    "side_table": _F("floor", supports=True),
    "tea_table": _F("floor", supports=True),
    # seats
    "dining_chair": _F("floor", seat=True),
    "chair": _F("floor", seat=True),
    "office_chair": _F("floor", seat=True),
    "armchair": _F("floor", supports=True, seat=True),
    "lounge_chair": _F("floor", supports=True, seat=True),
    "chinese_chair": _F("floor", seat=True),
    "dressing_chair": _F("floor", seat=True),
    "barstool": _F("floor", seat=True),
    "stool": _F("floor", seat=True),
    "footstool": _F("floor", supports=True),
    "multi_seat_sofa": _F("floor", supports=True, against_wall=True, seat=True),
    "loveseat_sofa": _F("floor", supports=True, against_wall=True, seat=True),
    "l_shaped_sofa": _F("floor", supports=True, against_wall=True, seat=True),
    "lazy_sofa": _F("floor", supports=True, seat=True),
    "chaise_longue_sofa": _F("floor", supports=True, seat=True),
    "sofa": _F("floor", supports=True, against_wall=True, seat=True),
    # lights
    "pendant_lamp": _F("ceiling"),
    "ceiling_lamp": _F("ceiling"),
    "chandelier": _F("ceiling"),
    "floor_lamp": _F("floor"),
    "desk_lamp": _F("surface"),
    "table_lamp": _F("surface"),
    # wall things
    "painting": _F("wall"),
    "picture": _F("wall"),
    "mirror": _F("wall"),
    "wall_clock": _F("wall"),
    "wall_shelf": _F("wall", supports=True),
    "wall_cabinet": _F("wall", supports=True, contains=True, opening="front"),
    # electronics and small things
    "television": _F("surface"),
    "monitor": _F("surface"),
    "computer_monitor": _F("surface"),
    "laptop": _F("surface"),
    "printer": _F("surface", supports=True),
    "mug": _F("surface"),
    "cup": _F("surface"),
    "coffee_mug": _F("surface"),
    "book": _F("surface"),
    "vase": _F("surface"),
    "plant": _F("surface"),
    "bowl": _F("surface"),
    "plate": _F("surface"),
    "pillow": _F("surface"),
    "keyboard": _F("surface"),
    "alarm_clock": _F("surface"),
    # fixtures
    "fridge": _F("floor", supports=True, contains=True, opening="front", against_wall=True, built_in=True),
    "kitchen_cabinet": _F(
        "floor", supports=True, contains=True, opening="front", against_wall=True, built_in=True
    ),
    "counter": _F("floor", supports=True, against_wall=True, built_in=True),
    "countertop": _F("floor", supports=True, against_wall=True, built_in=True),
    "sink": _F("floor", supports=True, built_in=True),
    "garbage_can": _F("floor", contains=True, opening="top"),
    "laundry_hamper": _F("floor", contains=True, opening="top"),
    "toilet": _F("floor", against_wall=True, built_in=True),
    "bathtub": _F("floor", against_wall=True, built_in=True),
    "radiator": _F("floor", against_wall=True, built_in=True),
    "rug": _F("floor", supports=True),
}

_SYNONYMS: dict[str, str] = {
    "tv": "television",
    "tv_monitor": "television",
    "armchair_": "armchair",
    "arm_chair": "armchair",
    "book_shelf": "bookshelf",
    "bookshelves": "bookshelf",
    "night_stand": "nightstand",
    "bedside_table": "nightstand",
    "bedside_cabinet": "nightstand",
    "end_table": "side_table",
    "counter_top": "countertop",
    "kitchen_counter": "countertop",
    "trash_can": "garbage_can",
    "waste_bin": "garbage_can",
    "dust_bin": "garbage_can",
    "couch": "sofa",
    "three_seat_sofa": "multi_seat_sofa",
    "closet": "wardrobe",
    "cupboard": "cabinet",
    "tvstand": "tv_stand",
    "tv_cabinet": "tv_stand",
    "office_desk": "desk",
    "writing_desk": "desk",
    "computer_desk": "desk",
    "ceiling_light": "ceiling_lamp",
    "hanging_lamp": "pendant_lamp",
    "potted_plant": "plant",
    "houseplant": "plant",
    "house_plant": "plant",
}

# Keyword fallbacks for labels not in the table, tried in order.
_KEYWORDS: tuple[tuple[str, str], ...] = (
    ("pendant", "pendant_lamp"),
    ("chandelier", "chandelier"),
    ("ceiling", "ceiling_lamp"),
    ("wardrobe", "wardrobe"),
    ("bookshelf", "bookshelf"),
    ("bookcase", "bookcase"),
    ("shelf", "shelf"),
    ("cabinet", "cabinet"),
    ("nightstand", "nightstand"),
    ("sofa", "sofa"),
    ("bed", "bed"),
    ("desk", "desk"),
    ("stool", "stool"),
    ("chair", "chair"),
    ("table", "table"),
    ("lamp", "table_lamp"),
    ("painting", "painting"),
    ("mirror", "mirror"),
    ("monitor", "monitor"),
    ("mug", "mug"),
    ("cup", "cup"),
)

THOR_TYPE: dict[str, str] = {
    "garbage_can": "GarbageCan",
    "laundry_hamper": "LaundryHamper",
    "double_bed": "Bed",
    "single_bed": "Bed",
    "kids_bed": "Bed",
    "bunk_bed": "Bed",
    "king_bed": "Bed",
    "bed": "Bed",
    "wardrobe": "Dresser",
    "children_cabinet": "Dresser",
    "cabinet": "Dresser",
    "wine_cabinet": "Dresser",
    "dresser": "Dresser",
    "sideboard": "Dresser",
    "dressing_table": "Dresser",
    "bookshelf": "ShelvingUnit",
    "bookcase": "ShelvingUnit",
    "shelf": "ShelvingUnit",
    "shelving_unit": "ShelvingUnit",
    "tv_stand": "TVStand",
    "nightstand": "SideTable",
    "console_table": "SideTable",
    "corner_side_table": "SideTable",
    "round_end_table": "SideTable",
    "side_table": "SideTable",
    "tea_table": "CoffeeTable",
    "coffee_table": "CoffeeTable",
    "dining_table": "DiningTable",
    "table": "DiningTable",
    "desk": "Desk",
    "work_desk": "Desk",
    "dining_chair": "Chair",
    "chair": "Chair",
    "office_chair": "Chair",
    "chinese_chair": "Chair",
    "dressing_chair": "Chair",
    "armchair": "ArmChair",
    "lounge_chair": "ArmChair",
    "barstool": "Stool",
    "stool": "Stool",
    "footstool": "Ottoman",
    "multi_seat_sofa": "Sofa",
    "loveseat_sofa": "Sofa",
    "l_shaped_sofa": "Sofa",
    "lazy_sofa": "Sofa",
    "chaise_longue_sofa": "Sofa",
    "sofa": "Sofa",
    "floor_lamp": "FloorLamp",
    "desk_lamp": "DeskLamp",
    "table_lamp": "DeskLamp",
    "painting": "Painting",
    "picture": "Painting",
    "television": "Television",
    "monitor": "Desktop",
    "computer_monitor": "Desktop",
    "laptop": "Laptop",
    "mug": "Mug",
    "coffee_mug": "Mug",
    "cup": "Cup",
    "book": "Book",
    "vase": "Vase",
    "plant": "HousePlant",
    "bowl": "Bowl",
    "plate": "Plate",
    "pillow": "Pillow",
    "alarm_clock": "AlarmClock",
    "box": "Box",
    "fridge": "Fridge",
    "countertop": "CounterTop",
    "counter": "CounterTop",
    "sink": "Sink",
    "toilet": "Toilet",
}


def normalize_category(label: str) -> str:
    """A canonical snake_case category for a free-form label.

    Lower-cases, turns separators into ``_``, drops trailing instance numbers
    (``"Dining Chair 2"`` -> ``dining_chair``, ``"work_desk_1761578426"`` -> ``work_desk``)
    and maps synonyms (``couch`` -> ``sofa``).
    """
    s = re.sub(r"[^a-z0-9]+", "_", label.strip().lower()).strip("_")
    s = re.sub(r"(_\d+)+$", "", s) or s
    s = _SYNONYMS.get(s, s)
    return s[:64] or "object"


def _known(category: str) -> str | None:
    """The traits entry a category reads as: itself; else its head noun, the longest known tail
    of its words (``bedside_reading_book`` is a ``book``); else a keyword of its last word that
    holds one (``desk_lamp`` is a lamp, not a desk; ``bookshelf`` a shelf)."""
    if category in _TRAITS:
        return category
    words = category.split("_")
    for i in range(1, len(words)):
        tail = "_".join(words[i:])
        if tail in _TRAITS:
            return tail
    for word in reversed(words):
        for key, target in _KEYWORDS:
            if key in word:
                return target
    return None


FIXTURE_CATEGORIES: frozenset[str] = frozenset(
    {
        "bathtub", "countertop", "counter", "dishwasher", "fireplace", "fridge", "kitchen_cabinet", "oven",
        "radiator", "range", "refrigerator", "shower", "shower_door", "shower_head", "sink", "stove",
        "stove_burner", "toilet", "washing_machine", "clothes_dryer", "dryer",
    }
)  # fmt: skip
"""Plumbing, appliances and built-ins: pieces a layout variant never moves (``docs/evolution.md``,
*Fixtures*). A category counts as a fixture when it is one of these (after
:func:`normalize_category`) or its traits say ``built_in``."""


def is_fixture(category: str, fixtures: frozenset[str] | set[str] | None = None) -> bool:
    """Whether pieces of ``category`` stay where they are in every variant: built-in by its
    traits or listed in ``fixtures`` (default :data:`FIXTURE_CATEGORIES`)."""
    c = normalize_category(category)
    table = FIXTURE_CATEGORIES if fixtures is None else fixtures
    joined = {f.replace("_", "") for f in table}  # AI2-THOR's ``WashingMachine`` reads ``washingmachine``
    return c in table or c.replace("_", "") in joined or traits(c).built_in


SCREEN_CATEGORIES: frozenset[str] = frozenset({"television"})
"""Screens: a variant keeps one facing the way its stand does, and no bed backs onto its wall."""


def is_screen(category: str) -> bool:
    """Whether ``category`` is a screen (:data:`SCREEN_CATEGORIES`, after :func:`normalize_category`)."""
    return normalize_category(category) in SCREEN_CATEGORIES


_PET_WORDS = frozenset({"dog", "cat", "pet"})


def is_bed(category: str) -> bool:
    """Whether ``category`` is a bed a person sleeps in: its traits entry is the bed's (its head
    noun is ``bed``: a ``king_bed``, a ``bed_frame``), not a pet's (``dog_bed``), and not a thing
    whose name only holds the letters (``bedside_reading_book``, ``flower_bed``... read by their
    head noun)."""
    c = normalize_category(category)
    known = _known(c)
    return known is not None and known.split("_")[-1] == "bed" and not _PET_WORDS & set(c.split("_"))


def traits(category: str) -> CategoryTraits:
    """Traits of a (normalized or raw) category; unknown categories count as small surface objects."""
    c = normalize_category(category)
    known = _known(c)
    if known is None:
        return CategoryTraits()
    found = _TRAITS[known]
    if c.startswith("wall_") and found.placement == "floor":  # a wall-mounted piece of a floor kind: hung
        return dataclasses.replace(found, placement="wall", against_wall=True)
    return found


def is_known(category: str) -> bool:
    """Whether the traits table knows this category (directly or by keyword)."""
    return _known(normalize_category(category)) is not None


def thor_type(category: str) -> str | None:
    """The AI2-THOR object type closest to a category, if any."""
    c = normalize_category(category)
    if c in THOR_TYPE:
        return THOR_TYPE[c]
    known = _known(c)
    return THOR_TYPE.get(known) if known else None


@dataclass(frozen=True)
class SupportPriors:
    """ProcTHOR placement priors, keyed by AI2-THOR types.

    ``on[receptacle]`` maps child types to the probability they were found on it.
    ``floor`` / ``wall`` / ``pickupable`` are the annotation flags. ``source`` says where the
    figures came from (the folder read).
    """

    on: dict[str, dict[str, float]] = field(default_factory=dict)
    floor: frozenset[str] = frozenset()
    wall: frozenset[str] = frozenset()
    pickupable: frozenset[str] = frozenset()
    source: str = ""

    def can_rest_on(self, child_category: str, parent_category: str) -> bool | None:
        """Whether ProcTHOR saw the child's type on the parent's type; None when either is unmapped."""
        child, parent = thor_type(child_category), thor_type(parent_category)
        if child is None or parent is None or parent not in self.on:
            return None
        return child in self.on[parent]

    def type_of(self, category: str) -> str | None:
        """The AI2-THOR type of a category: :func:`thor_type`, else the category in CamelCase when
        the priors know that type (``baseball_bat`` -> ``BaseballBat``, as ProcTHOR's own labels)."""
        t = thor_type(category)
        if t is not None:
            return t
        camel = "".join(w.capitalize() for w in normalize_category(category).split("_"))
        return camel if camel in self.on or camel in self.floor or camel in self.pickupable else None

    def probability(self, child_category: str, parent_category: str) -> float | None:
        """The share of a receptacle type's items that were of the child's type in ProcTHOR (0 when
        never seen on it); ``None`` when either type is unmapped or the parent is no receptacle."""
        child, parent = self.type_of(child_category), self.type_of(parent_category)
        if child is None or parent is None or parent not in self.on:
            return None
        return self.on[parent].get(child, 0.0)

    def is_pickupable(self, category: str) -> bool:
        """Whether the category's type is a small thing one picks up (AI2-THOR's ``isPickupable``)."""
        t = self.type_of(category)
        return t is not None and t in self.pickupable

    def on_floor(self, category: str) -> bool:
        """Whether the category's type may lie on the floor (AI2-THOR's ``onFloor`` annotation)."""
        t = self.type_of(category)
        return t is not None and t in self.floor

    def is_receptacle(self, category: str) -> bool | None:
        """Whether the category's type is a ProcTHOR receptacle; None when unmapped."""
        t = thor_type(category)
        return None if t is None else t in self.on

    def floor_only(self, category: str) -> bool | None:
        """True for types that stand on the floor and never on another receptacle in ProcTHOR."""
        t = thor_type(category)
        if t is None or t not in self.floor:
            return None if t is None else False
        on_something = any(t in kids for kids in self.on.values())
        return t not in self.pickupable and not on_something


@lru_cache(maxsize=8)
def _load_dir(folder: str) -> SupportPriors:
    base = Path(folder)
    rec = json.loads((base / "receptacles.json").read_text(encoding="utf-8"))
    ann = json.loads((base / "placement-annotations.json").read_text(encoding="utf-8"))
    on = {
        parent: {child: float(v.get("p", 0.0)) for child, v in kids.items()} for parent, kids in rec.items()
    }

    def flagged(key: str) -> frozenset[str]:
        return frozenset(t for t, v in ann.get(key, {}).items() if v is True)

    return SupportPriors(
        on=on,
        floor=flagged("onFloor"),
        wall=flagged("onWall"),
        pickupable=flagged("isPickupable"),
        source=str(base),
    )


def priors_problem(folder: str | Path) -> str | None:
    """Why ``folder`` cannot serve as a priors folder (no such folder, the two files missing,
    unreadable or broken JSON), or ``None`` when it can: what a ``--priors`` setting is checked
    with before a run starts."""
    try:
        _load_dir(str(Path(folder).resolve()))
    except (OSError, ValueError, AttributeError, KeyError, TypeError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def load_priors(folder: str | Path | None = None) -> SupportPriors:
    """ProcTHOR placement priors from ``folder``, by default the ones shipped with the package.

    A given folder that lacks the two files (or holds broken JSON) is logged and the shipped
    priors are used instead, so structuring never fails for want of priors.
    """
    if folder is not None:
        try:
            return _load_dir(str(Path(folder).resolve()))
        except (OSError, ValueError, AttributeError) as exc:
            log.warning("priors_unreadable", folder=str(folder), error=str(exc))
    return _load_dir(str(PROCTHOR_PRIORS_DIR))

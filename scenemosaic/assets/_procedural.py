"""The procedural furniture library: low-poly furniture built from convex primitives.

Every builder fills the box ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]`` exactly
(the union of its parts has those bounds) with the object's **front toward -Y**: a chair's open
side and a wardrobe's doors face -Y, backrests and headboards sit at +Y. Each part is a convex,
watertight primitive (box, few-sided prism or frustum, low-poly blob), so it can serve directly
as a collision geom; part counts stay at or below :data:`MAX_PARTS`.

Sizes come from the caller; builders pick proportions as fractions of the box and cap the
absolute thickness of boards, legs and rails, so any positive size gives a valid model.

Builders of furniture that opens (chests of drawers, cabinets, wardrobes, fridges, microwaves,
washing machines, toilets, boxes) draw each drawer, door and lid as its own pieces and say how it
moves (:class:`~scenemosaic.assets.PartSpec`, read with :func:`procedural_articulation`): the
articulation of a category lives with its builder. The pieces are drawn closed.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Sequence

import numpy as np
import structlog
import trimesh

from scenemosaic.assets._articulation import (
    Box6,
    PartSpec,
)
from scenemosaic.assets._fixtures import (
    _boots,
    _box_layout,
    _coffee_machine,
    _dishwasher,
    _faucet,
    _garbage_can_layout,
    _kettle,
    _microwave,
    _oven,
    _paper_towel_roll,
    _plunger,
    _sink,
    _statue,
    _teddy_bear,
    _toaster,
    _toilet,
    _toilet_paper,
    _towel_holder,
    _vacuum_cleaner,
    _washing_machine,
)
from scenemosaic.assets._furniture import (
    ROOM_DOOR_CATEGORIES,
    _armchair,
    _bed,
    _bookshelf_layout,
    _cabinet_layout,
    _chair,
    _coffee_table,
    _counter_layout,
    _desk,
    _dresser_layout,
    _dressing_table,
    _fridge_layout,
    _l_shaped_sofa,
    _nightstand_layout,
    _office_chair,
    _room_door_left,
    _room_door_right,
    _room_double_door,
    _side_table,
    _sofa,
    _stool,
    _table,
    _tv_stand_layout,
    _wardrobe_layout,
)
from scenemosaic.assets._household import (
    _alarm_clock,
    _ball,
    _baseball_bat,
    _book,
    _bottle,
    _bowl,
    _candle,
    _ceiling_lamp,
    _cell_phone,
    _disc,
    _dumbbell,
    _floor_lamp,
    _fruit,
    _garbage_bag,
    _jar,
    _key_chain,
    _knife,
    _laptop,
    _mug,
    _paddle,
    _painting,
    _pan,
    _pencil,
    _pillow,
    _plain_box,
    _plant,
    _plate,
    _pot,
    _potato,
    _printer,
    _rug,
    _spoon,
    _table_lamp,
    _tv,
    _vase,
    _watch,
)
from scenemosaic.assets._shapes import (
    Articulated,
    Builder,
    Parts,
)
from scenemosaic.exceptions import AssetError
from scenemosaic.scene import normalize_category

__all__ = [
    "MAX_PARTS",
    "interior_boards",
    "known_categories",
    "procedural_articulation",
    "procedural_key",
    "procedural_mesh",
    "procedural_parts",
]

log = structlog.get_logger(__name__)

MAX_PARTS = 32
"""Upper bound on the parts of one procedural model (each part becomes a physics geom). Rigid
models stay within 20; a chest of six drawers, each a front, a handle, a bottom and a back, needs 30."""

_warned_unknown: set[str] = set()


Layout = Callable[[float, float, float], tuple[Parts, list[Box6]]]
ArticulatedBuilder = Callable[[float, float, float], Articulated]

# Furniture that opens: the builder also says how each drawer, door and lid moves.
_ARTICULATED: dict[str, ArticulatedBuilder] = {
    "box": _box_layout,
    "cabinet": _cabinet_layout,
    "counter": _counter_layout,
    "desk": _desk,
    "dishwasher": _dishwasher,
    "dresser": _dresser_layout,
    "dressing_table": _dressing_table,
    "fridge": _fridge_layout,
    "laptop": _laptop,
    "microwave": _microwave,
    "nightstand": _nightstand_layout,
    "oven": _oven,
    ROOM_DOOR_CATEGORIES[("-x",)]: _room_door_left,
    ROOM_DOOR_CATEGORIES[("+x",)]: _room_door_right,
    ROOM_DOOR_CATEGORIES[("-x", "+x")]: _room_double_door,
    "side_table": _side_table,
    "toilet": _toilet,
    "tv_stand": _tv_stand_layout,
    "wardrobe": _wardrobe_layout,
    "washing_machine": _washing_machine,
}


def _layout_of(build: ArticulatedBuilder) -> Layout:
    def layout(w: float, d: float, h: float) -> tuple[Parts, list[Box6]]:
        parts, compartments, _ = build(w, d, h)
        return parts, compartments

    layout.__doc__ = build.__doc__
    return layout


_CONTAINERS_THAT_OPEN = ("box", "cabinet", "counter", "dresser", "fridge", "tv_stand", "wardrobe")
"""Articulated models that are also hollow containers (their compartments are ``interior_boards``)."""

# Hollow containers: their builders also say where the free compartments are (``interior_boards``).
_LAYOUTS: dict[str, Layout] = {
    "bookshelf": _bookshelf_layout,
    "garbage_can": _garbage_can_layout,
    **{key: _layout_of(_ARTICULATED[key]) for key in _CONTAINERS_THAT_OPEN},
}


def _parts_only(layout: Layout) -> Builder:
    def build(w: float, d: float, h: float) -> Parts:
        return layout(w, d, h)[0]

    build.__doc__ = layout.__doc__
    return build


_BUILDERS: dict[str, Builder] = {
    "alarm_clock": _alarm_clock,
    "armchair": _armchair,
    "ball": _ball,
    "baseball_bat": _baseball_bat,
    "bed": _bed,
    "book": _book,
    "boots": _boots,
    "bottle": _bottle,
    "bowl": _bowl,
    "candle": _candle,
    "cd": _disc,
    "ceiling_lamp": _ceiling_lamp,
    "cell_phone": _cell_phone,
    "chair": _chair,
    "coffee_machine": _coffee_machine,
    "coffee_table": _coffee_table,
    "dumbbell": _dumbbell,
    "faucet": _faucet,
    "floor_lamp": _floor_lamp,
    "fruit": _fruit,
    "garbage_bag": _garbage_bag,
    "jar": _jar,
    "kettle": _kettle,
    "key_chain": _key_chain,
    "knife": _knife,
    "l_shaped_sofa": _l_shaped_sofa,
    "mug": _mug,
    "office_chair": _office_chair,
    "paddle": _paddle,
    "painting": _painting,
    "pan": _pan,
    "paper_towel_roll": _paper_towel_roll,
    "pencil": _pencil,
    "pillow": _pillow,
    "plant": _plant,
    "plate": _plate,
    "plunger": _plunger,
    "pot": _pot,
    "potato": _potato,
    "printer": _printer,
    "rug": _rug,
    "sink": _sink,
    "sofa": _sofa,
    "spoon": _spoon,
    "statue": _statue,
    "stool": _stool,
    "table": _table,
    "table_lamp": _table_lamp,
    "teddy_bear": _teddy_bear,
    "television": _tv,
    "toaster": _toaster,
    "toilet_paper": _toilet_paper,
    "towel_holder": _towel_holder,
    "vacuum_cleaner": _vacuum_cleaner,
    "vase": _vase,
    "watch": _watch,
    **{key: _parts_only(layout) for key, layout in _LAYOUTS.items()},
    **{key: _parts_only(_layout_of(build)) for key, build in _ARTICULATED.items()},
}

# Builder keys are categories of the scene vocabulary (``scene.normalize_category``), which maps the
# true synonyms (tv -> television, couch -> sofa...) before the lookup. This table only says which
# builder draws a category that has none of its own (a dining chair is drawn as a chair), as
# ``_snake`` and ``normalize_category`` write the category.
_SYNONYMS: dict[str, tuple[str, ...]] = {
    "bed": ("double_bed", "single_bed", "kids_bed", "king_bed", "queen_bed", "bunk_bed", "dog_bed"),
    "bookshelf": ("bookcase", "shelf", "shelving_unit", "shelves", "cart", "kitchen_cart"),
    "cabinet": (
        "wine_cabinet",
        "children_cabinet",
        "sideboard",
        "kitchen_cabinet",
        "safe",
    ),
    "counter": ("countertop", "kitchen_counter", "kitchen_island"),
    "dresser": ("drawer_chest", "chest_of_drawers"),
    "nightstand": ("nightstand_table",),
    "dressing_table": ("vanity", "makeup_table"),
    "tv_stand": ("media_console", "t_v_stand"),
    "table": ("dining_table", "kitchen_table", "round_table"),
    "side_table": ("corner_side_table", "console_table", "round_end_table"),
    "coffee_table": ("tea_table",),
    "desk": ("work_desk",),
    "chair": ("dining_chair", "chinese_chair", "dressing_chair", "side_chair"),
    "office_chair": ("desk_chair", "swivel_chair", "gaming_chair"),
    "armchair": ("lounge_chair", "lazy_sofa", "accent_chair"),
    "sofa": (
        "multi_seat_sofa",
        "loveseat_sofa",
        "loveseat",
        "chaise_longue_sofa",
        "two_seat_sofa",
    ),
    "l_shaped_sofa": ("l_sofa", "sectional_sofa", "corner_sofa"),
    "stool": ("barstool", "bar_stool", "footstool", "foot_stool", "ottoman"),
    "television": ("tv_set", "t_v", "monitor", "desktop", "computer_monitor", "screen"),
    "laptop": ("notebook_computer",),
    "ceiling_lamp": ("pendant_lamp", "pendant_light", "chandelier"),
    "floor_lamp": ("floor_light", "standing_lamp"),
    "table_lamp": ("desk_lamp", "lamp", "bedside_lamp"),
    "plant": ("flower_pot",),
    "rug": ("carpet", "mat", "floor_mat", "towel", "hand_towel", "cloth", "blanket", "bath_mat"),
    "mug": ("cup", "coffee_mug", "teacup"),
    "book": ("notebook", "newspaper", "magazine"),
    "vase": ("flower_vase",),
    "painting": ("picture", "picture_frame", "poster", "mirror", "wall_art", "artwork", "photo_frame"),
    "pillow": ("cushion", "throw_pillow"),
    # a laundry hamper has a lid (AI2-THOR's opens): a closed box hinged at its back edge
    "box": ("cardboard_box", "storage_box", "crate", "tissue_box", "aluminum_foil", "shoe_box", "laundry_hamper", "hamper"),
    # household objects (AI2-THOR / ProcTHOR object types and common names)
    "fruit": ("apple", "tomato", "orange", "lemon", "lime", "peach", "pear", "plum", "pomegranate", "mango"),
    "potato": ("lettuce", "bread", "egg", "onion", "cabbage", "loaf", "soap_bar", "vegetable", "avocado"),
    "ball": ("basket_ball", "basketball", "soccer_ball", "football", "tennis_ball", "baseball", "volleyball"),
    "baseball_bat": ("bat", "cricket_bat", "rolling_pin"),
    "bottle": ("wine_bottle", "soap_bottle", "spray_bottle", "water_bottle", "beer_bottle", "shampoo"),
    "jar": ("salt_shaker", "pepper_shaker", "shaker", "canister", "spice_jar", "glass_jar"),
    "candle": ("candlestick", "tea_light"),
    "plate": ("dish", "saucer", "platter", "stove_burner"),
    "bowl": ("salad_bowl", "mixing_bowl", "fruit_bowl"),
    "pot": ("cooking_pot", "saucepan", "stock_pot"),
    "pan": ("frying_pan", "skillet", "wok"),
    "knife": ("butter_knife", "kitchen_knife", "fork", "table_knife"),
    "spoon": ("ladle", "teaspoon", "tablespoon"),
    "paddle": ("spatula", "tennis_racket", "racket", "hairbrush"),
    "pencil": ("pen", "marker", "crayon", "chopsticks", "toothbrush"),
    "cell_phone": (
        "remote_control",
        "remote",
        "phone",
        "smartphone",
        "mobile_phone",
        "credit_card",
        "card",
        "tablet",
        "calculator",
        "dish_sponge",
        "sponge",
        "keyboard",
    ),
    "cd": ("disc", "dvd", "coaster"),
    "watch": ("wristwatch", "bracelet"),
    "key_chain": ("keys", "key", "keychain"),
    "alarm_clock": ("clock", "table_clock"),
    "toilet_paper": ("toilet_roll", "toilet_paper_roll"),
    "paper_towel_roll": ("paper_towel", "kitchen_roll"),
    "plunger": ("broom", "mop", "scrub_brush", "toilet_brush"),
    "garbage_can": (
        "basket",
        "storage_bin",
        "bin",
        "trash_bin",
        "recycling_bin",
        "wastebasket",
        "waste_basket",
    ),
    "garbage_bag": ("trash_bag", "sack", "bag"),
    "fridge": ("refrigerator", "freezer"),
    "microwave": ("toaster_oven",),
    "oven": ("stove", "range", "cooker", "wall_oven"),
    "washing_machine": ("clothes_dryer", "dryer", "washer", "laundry_machine"),
    "coffee_machine": ("coffee_maker", "espresso_machine"),
    "kettle": ("watering_can", "teapot", "tea_kettle"),
    "teddy_bear": ("stuffed_animal", "plush_toy", "toy"),
    "statue": ("sculpture", "figurine", "room_decor", "table_top_decor", "decoration", "decor", "trophy"),
    "faucet": ("shower_head", "tap"),
    "sink": ("sink_basin", "wash_basin", "basin"),
    "towel_holder": ("hand_towel_holder", "toilet_paper_hanger", "towel_rack", "towel_bar"),
    "boots": ("shoes", "shoe", "sneakers"),
    "dumbbell": ("kettlebell", "weights"),
}
_ALIASES: dict[str, str] = {synonym: key for key, names in _SYNONYMS.items() for synonym in names}


def _snake(label: str) -> str:
    text = label.strip().split("|", 1)[0]  # AI2-THOR object ids look like "Chair|+01.2|..."
    text = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", text)
    text = re.sub(r"(?<=[A-Z])(?=[A-Z][a-z])", "_", text)
    text = re.sub(r"[^0-9a-zA-Z]+", "_", text).strip("_").lower()
    text = re.sub(r"(_\d+)+$", "", text)  # numbered instances: "dining_chair_2"
    return text


def _lookup(name: str) -> str | None:
    if name in _BUILDERS:
        return name
    return _ALIASES.get(name)


def procedural_key(label: str) -> str:
    """Map a label to a builder key of the procedural library.

    The label is first put in the scene vocabulary (:func:`scenemosaic.scene.normalize_category`:
    snake case, instance numbers dropped, synonyms mapped), then looked up among the builders.
    Accepts 3D-FRONT labels (``double_bed``, ``multi_seat_sofa``, ``pendant_lamp`` ...), AI2-THOR
    object types (``ArmChair``, ``HousePlant``, ``TVStand`` ...) and common synonyms, in any case
    or separator style. A label that is not known outright is matched by its trailing words
    (``modern_floor_lamp`` -> ``floor_lamp``) and then without a plural ``s``. A label that matches
    nothing comes back in snake case; :func:`procedural_parts` then builds a plain box for it.
    """
    name = normalize_category(_snake(label)) if _snake(label) else ""
    if not name or name == "object":
        return "box"
    found = _lookup(name)
    if found:
        return found
    tokens = name.split("_")
    for start in range(1, len(tokens)):
        found = _lookup("_".join(tokens[start:]))
        if found:
            return found
    if name.endswith("s"):
        found = _lookup(name[:-1])
        if found:
            return found
    return name


def known_categories() -> list[str]:
    """Builder keys of the procedural library, sorted."""
    return sorted(_BUILDERS)


def _fit_union(parts: Parts, w: float, d: float, h: float) -> Parts:
    """Map the union's bounds onto the requested box (removes float drift; a no-op for exact builders)."""
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    target_lo = np.array([-w / 2, -d / 2, 0.0])
    target_hi = np.array([w / 2, d / 2, h])
    if np.allclose(lo, target_lo, atol=1e-12, rtol=0) and np.allclose(hi, target_hi, atol=1e-12, rtol=0):
        return parts
    scale = (target_hi - target_lo) / (hi - lo)
    out: Parts = []
    for p in parts:
        vertices = np.clip((np.asarray(p.vertices) - lo) * scale + target_lo, target_lo, target_hi)
        out.append(trimesh.Trimesh(vertices=vertices, faces=np.asarray(p.faces), process=False))
    return out


@functools.lru_cache(maxsize=512)
def _build(key: str, w: float, d: float, h: float) -> tuple[trimesh.Trimesh, ...]:
    builder = _BUILDERS.get(key)
    if builder is None:
        if key not in _warned_unknown:
            _warned_unknown.add(key)
            log.warning("unknown_procedural_category", category=key, fallback="box")
        builder = _plain_box
    parts = _fit_union(builder(w, d, h), w, d, h)
    if len(parts) > MAX_PARTS:  # pragma: no cover - guarded by the tests of every builder
        raise AssetError(f"procedural {key!r} has {len(parts)} parts (max {MAX_PARTS})")
    return tuple(parts)


def _check_extents(category: str, extents: Sequence[float]) -> tuple[float, float, float]:
    if len(extents) != 3:
        raise AssetError(f"procedural {category!r}: extents must be 3 numbers, got {list(extents)}")
    w, d, h = (float(v) for v in extents)
    if not all(np.isfinite(v) and v > 0 for v in (w, d, h)):
        raise AssetError(f"procedural {category!r}: extents must be positive and finite, got {[w, d, h]}")
    return w, d, h


def procedural_parts(category: str, extents: tuple[float, float, float]) -> list[trimesh.Trimesh]:
    """Convex, watertight pieces of a procedural model filling the box ``extents`` exactly.

    ``category`` may be any label :func:`procedural_key` understands. The box is
    ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]`` with ``extents = (w, d, h)``; the
    model's front faces -Y. An unknown category gives one box, with a warning logged once per category.
    Returns fresh copies (safe to modify).
    """
    w, d, h = _check_extents(category, extents)
    key = procedural_key(category)
    return [p.copy() for p in _build(key, w, d, h)]


@functools.lru_cache(maxsize=512)
def _articulation(key: str, w: float, d: float, h: float) -> tuple[PartSpec, ...]:
    build = _ARTICULATED.get(key)
    return tuple(build(w, d, h)[2]) if build is not None else ()


def procedural_articulation(category: str, extents: tuple[float, float, float]) -> list[PartSpec]:
    """The parts of a procedural model that open (drawers, doors, lids), as its builder draws them.

    Each :class:`~scenemosaic.assets.PartSpec` names the indices of its pieces in
    :func:`procedural_parts` (same category and extents), its joint (a slide for a drawer, a hinge
    for a door or a lid, with its axis, a point on it and its limits) and its handle, in the
    object frame with the parts closed. Categories that do not open give ``[]``. See
    ``docs/articulation.md`` for the categories and the hinge-side rule.
    """
    w, d, h = _check_extents(category, extents)
    return list(_articulation(procedural_key(category), w, d, h))


@functools.lru_cache(maxsize=512)
def _compartments(key: str, w: float, d: float, h: float) -> tuple[Box6, ...]:
    layout = _LAYOUTS.get(key)
    if layout is None:
        return ()
    parts, compartments = layout(w, d, h)
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    if not (
        np.allclose(lo, [-w / 2, -d / 2, 0.0], atol=1e-9) and np.allclose(hi, [w / 2, d / 2, h], atol=1e-9)
    ):
        raise AssetError(f"procedural {key!r}: container layout does not fill its box")  # pragma: no cover
    out: list[Box6] = []
    for x0, x1, y0, y1, z0, z1 in compartments:
        if x1 > x0 and y1 > y0 and z1 > z0:
            out.append((float(x0), float(x1), float(y0), float(y1), float(z0), float(z1)))
    return tuple(out)


def interior_boards(category: str, extents: tuple[float, float, float]) -> list[Box6]:
    """The free compartments of a hollow procedural container, bottom to top (left to right
    within a row of drawers).

    Each is an axis-aligned box ``(x0, x1, y0, y1, z_bottom, z_top)`` in the object frame (the
    frame of :func:`procedural_parts`: ``x in [-w/2, w/2]``, ``y in [-d/2, d/2]``, ``z in [0, h]``,
    front toward -Y): inside the side walls, from the inner face of the doors/drawer fronts (or the
    open front of a bookshelf) to the back panel, from the top of one board to the underside of the
    next; in a chest of drawers (dresser), the inside of each drawer, over its bottom, up to the
    top of its front. An item whose box lies inside a compartment, resting on ``z_bottom``,
    touches no part.
    Front-opening containers (cabinet, wardrobe, dresser, tv stand, fridge, bookshelf and what the
    alias table draws with them) have one compartment per board; top-opening ones (garbage can,
    hamper, basket, box) have one, above the floor. Any other category gives ``[]``.
    """
    w, d, h = _check_extents(category, extents)
    return list(_compartments(procedural_key(category), w, d, h))


COMPARTMENT_CLEARANCE_M = 0.005
"""Headroom an item needs under the next board to count as fitting a compartment, metres."""


def compartment_fits(size: tuple[float, float, float], compartment: Box6) -> bool:
    """Whether a box of ``size`` (width, depth, height) fits ``compartment`` (one of
    :func:`interior_boards`), either way round in plan and under the next board."""
    x0, x1, y0, y1, zb, zt = compartment
    w, d = sorted(size[:2], reverse=True)
    a, b = sorted((x1 - x0, y1 - y0), reverse=True)
    return w <= a and d <= b and size[2] + COMPARTMENT_CLEARANCE_M <= zt - zb


def procedural_mesh(category: str, extents: tuple[float, float, float]) -> trimesh.Trimesh:
    """The procedural model as one mesh: the concatenation of :func:`procedural_parts` (a fresh
    copy: safe to modify)."""
    w, d, h = _check_extents(category, extents)
    return _joined(procedural_key(category), w, d, h).copy()


@functools.lru_cache(maxsize=512)
def _joined(key: str, w: float, d: float, h: float) -> trimesh.Trimesh:
    parts = _build(key, w, d, h)
    if len(parts) == 1:
        return parts[0]
    mesh = trimesh.util.concatenate(list(parts))
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh

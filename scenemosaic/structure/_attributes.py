"""Simulation attributes: mass, friction and static/dynamic per object.

Rule solver: a documented per-category table (see ``docs/structuring.md`` for where the figures
come from). Mass is the box volume times an effective fill density (a wardrobe's box is mostly
air), clamped to the category's typical range, so a small nightstand weighs less than a big one
but never less than any nightstand sold. Fixtures (built-ins) are static; furniture, however
heavy, stays dynamic so physics can settle it. Objects hung from a wall or the ceiling (pictures,
mirrors, pendant lamps) are dynamic too: their unit is simulated with gravity toward its anchor,
so a picture settles onto its wall; in the whole scene under real gravity they are held where
they hang (``scenemosaic.physics.is_fixed``), as their hooks and cords would hold them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, Need, SceneState, TaskAgent
from scenemosaic.scene import CEILING, FLOOR, SimAttributes, normalize_category, traits
from scenemosaic.structure._facts import CHUNK_OBJECTS, ObjectFacts, chunk_ids, object_facts, replace_scene

if TYPE_CHECKING:
    from scenemosaic.structure._manager import SceneSummary

__all__ = [
    "ATTRIBUTE_TABLE",
    "AttributeRow",
    "AttributesAgent",
    "AttributesEvidence",
    "AttributesOutput",
    "ObjectAttributes",
]


@dataclass(frozen=True)
class AttributeRow:
    """Typical figures for one category.

    ``mass_range_kg``: lightest and heaviest typical retail item; ``fill_density``: kg per m³
    of the bounding box; ``friction``: sliding coefficient of its base on a wooden floor or
    table top; ``static``: a fixture that never moves.
    """

    mass_range_kg: tuple[float, float]
    fill_density: float
    friction: float
    static: bool = False


_R = AttributeRow
ATTRIBUTE_TABLE: dict[str, AttributeRow] = {
    "bed": _R((35, 150), 60, 0.5),
    "wardrobe": _R((45, 200), 70, 0.45),
    "cabinet": _R((20, 120), 80, 0.45),
    "bookshelf": _R((15, 90), 50, 0.45),
    "tv_stand": _R((15, 70), 90, 0.45),
    "nightstand": _R((6, 30), 80, 0.45),
    "dressing_table": _R((15, 60), 60, 0.45),
    "table": _R((15, 80), 40, 0.45),
    "coffee_table": _R((8, 40), 50, 0.45),
    "side_table": _R((3, 20), 50, 0.45),
    "desk": _R((15, 60), 45, 0.45),
    "chair": _R((3.5, 12), 25, 0.5),
    "office_chair": _R((9, 20), 30, 0.5),
    "armchair": _R((12, 45), 40, 0.55),
    "sofa": _R((30, 120), 45, 0.55),
    "stool": _R((2, 8), 30, 0.5),
    "floor_lamp": _R((2, 10), 20, 0.5),
    "ceiling_lamp": _R((0.5, 8), 15, 0.5),
    "painting": _R((0.5, 8), 60, 0.4),
    "mirror": _R((2, 15), 150, 0.4),
    "television": _R((4, 25), 120, 0.5),
    "monitor": _R((2.5, 8), 100, 0.5),
    "printer": _R((4, 80), 120, 0.5),
    "laptop": _R((1, 3), 500, 0.4),
    "mug": _R((0.2, 0.5), 400, 0.4),
    "book": _R((0.15, 1.5), 600, 0.4),
    "vase": _R((0.3, 4), 300, 0.4),
    "plant": _R((0.5, 12), 200, 0.5),
    "pillow": _R((0.2, 1.2), 60, 0.6),
    "box": _R((0.3, 8), 80, 0.45),
    "rug": _R((1, 15), 300, 0.7),
    "fixture": _R((20, 200), 200, 0.6, static=True),
    "faucet": _R((0.5, 4), 400, 0.5, static=True),
    "small": _R((0.1, 3), 300, 0.45),
}
"""Category group -> figures. Sources and reasoning: ``docs/structuring.md``."""

_UNKNOWN_LARGE = AttributeRow((1.0, 150.0), 60, 0.5)

_GROUP: dict[str, str] = {
    "double_bed": "bed",
    "single_bed": "bed",
    "kids_bed": "bed",
    "bunk_bed": "bed",
    "king_bed": "bed",
    "children_cabinet": "cabinet",
    "wine_cabinet": "cabinet",
    "sideboard": "cabinet",
    "dresser": "cabinet",
    "shelf": "bookshelf",
    "bookcase": "bookshelf",
    "shelving_unit": "bookshelf",
    "console_table": "side_table",
    "corner_side_table": "side_table",
    "round_end_table": "side_table",
    "tea_table": "coffee_table",
    "dining_table": "table",
    "work_desk": "desk",
    "dining_chair": "chair",
    "chinese_chair": "chair",
    "dressing_chair": "chair",
    "lounge_chair": "armchair",
    "barstool": "stool",
    "footstool": "stool",
    "multi_seat_sofa": "sofa",
    "loveseat_sofa": "sofa",
    "l_shaped_sofa": "sofa",
    "lazy_sofa": "sofa",
    "chaise_longue_sofa": "sofa",
    "pendant_lamp": "ceiling_lamp",
    "chandelier": "ceiling_lamp",
    "desk_lamp": "small",
    "table_lamp": "small",
    "picture": "painting",
    "wall_clock": "painting",
    "computer_monitor": "monitor",
    "coffee_mug": "mug",
    "cup": "mug",
    "alarm_clock": "small",
    "storage_bin": "box",
    "basket": "box",
    "keyboard": "small",
    "bowl": "small",
    "towel_holder": "faucet",
    "toilet_paper_hanger": "faucet",
    "soap_dispenser": "faucet",
    "plate": "small",
}


def attribute_row(category: str) -> tuple[str, AttributeRow]:
    """The table row (and its key) for a category; built-ins map to ``fixture``, unknowns by size."""
    c = normalize_category(category)
    if traits(c).built_in:
        return "fixture", ATTRIBUTE_TABLE["fixture"]
    key = c if c in ATTRIBUTE_TABLE else _GROUP.get(c)
    if key is None:
        for k in ATTRIBUTE_TABLE:
            if k in c:
                key = k
                break
    key = key or "small"
    return key, ATTRIBUTE_TABLE[key]


class ObjectAttributes(AgentOutput):
    """Simulation figures for one object."""

    object_id: str = Field(max_length=64)
    mass_kg: float = Field(gt=0, le=2000)
    friction: float = Field(ge=0, le=2)
    static: bool = False
    basis: str = Field(default="", max_length=200)


class AttributesOutput(AgentOutput):
    """Simulation attributes per object."""

    objects: list[ObjectAttributes] = Field(max_length=MAX_ITEMS)


SOFT_FURNISHINGS = frozenset(
    {"pillow", "throw_pillow", "cushion", "blanket", "towel", "teddy_bear", "plush_toy"}
)
"""Soft things that mould to what they lie on; a rigid stand-in of one rocks and tips, so one resting
on an object is fixed there (a pillow on a bed, a cushion on a sofa)."""
THIN_BASE_RATIO = 0.15
"""A standing object whose narrower base side is below this fraction of its height (a TV plate, a
picture frame, a book on edge) is fixed on its support rather than left to tip over."""


class AttributesEvidence(AgentOutput):
    """Objects with their boxes and current parents."""

    objects: list[ObjectFacts] = Field(max_length=MAX_ITEMS)


def solve_attributes(evidence: AttributesEvidence) -> AttributesOutput:
    """The attributes rule solver (see the module docstring)."""
    items: list[ObjectAttributes] = []
    for o in evidence.objects:
        key, row = attribute_row(o.category)
        volume = o.size[0] * o.size[1] * o.size[2]
        if key == "small" and volume > 0.05:  # an unknown object too big to be a small thing
            key, row = "unknown_large", _UNKNOWN_LARGE
        lo, hi = row.mass_range_kg
        mass = min(max(row.fill_density * volume, lo), hi)
        hung = (
            o.parent == CEILING
            or (o.parent or "").startswith("wall")
            or traits(o.category).placement == "ceiling"
        )
        # a screen or picture standing on furniture as a thin plate cannot stand by itself (its real
        # foot is not in the stand-in); real ones are fixed to their stand, so it is held in place
        base = min(o.size[0], o.size[1])
        thin = (
            not hung
            and traits(o.category).placement != "floor"
            and o.size[2] > 0.1
            and base / o.size[2] < THIN_BASE_RATIO
        )
        soft = o.category in SOFT_FURNISHINGS and o.parent not in (None, FLOOR)
        static = row.static or thin or soft
        items.append(
            ObjectAttributes(
                object_id=o.id,
                mass_kg=round(mass, 3),
                friction=row.friction,
                static=static,
                basis=f"table row {key!r}"
                + (
                    "; hangs: settles toward its anchor, held there under real gravity"
                    if hung and not row.static
                    else ""
                )
                + ("; fixed on its support (too thin to stand)" if thin and not row.static else "")
                + ("; soft: keeps its shape on its support" if soft and not (row.static or thin) else ""),
            )
        )
    return AttributesOutput(objects=items)


class AttributesAgent(TaskAgent[SceneState, AttributesEvidence, AttributesOutput]):
    """Estimates mass, friction and static/dynamic per object."""

    name: ClassVar[str] = "attributes"
    depends_on: ClassVar[tuple[str, ...]] = ("support",)
    prompt: ClassVar[str] = "attributes"
    reply_tokens: ClassVar[tuple[int, int] | None] = (200, 50)
    chunk_size: ClassVar[int | None] = CHUNK_OBJECTS
    items_field: ClassVar[str | None] = "objects"
    object_id_fields: ClassVar[tuple[str, ...]] = ("objects.object_id",)
    prompt_omit: ClassVar[frozenset[str]] = frozenset({"center", "yaw_deg", "bottom", "top", "relation"})

    def needed(self, summary: SceneSummary) -> Need:
        """Always (a plan may leave it out)."""
        del summary
        return Need(True, "mass, friction, static flags")

    def gather(self, state: SceneState) -> AttributesEvidence:
        return AttributesEvidence(objects=object_facts(state.scene))

    def solve(self, evidence: AttributesEvidence) -> AttributesOutput:
        return solve_attributes(evidence)

    def split(self, evidence: AttributesEvidence, size: int) -> list[tuple[list[str], AttributesEvidence]]:
        """Chunks of objects; each object's figures depend on it alone."""
        return [
            (ids, AttributesEvidence(objects=[o for o in evidence.objects if o.id in set(ids)]))
            for ids in chunk_ids(evidence.objects, size)
        ]

    def check(self, output: AttributesOutput, state: SceneState) -> list[str]:
        cats = {o.id: o.category for o in state.scene.objects}
        problems: list[str] = []
        for a in output.objects:
            if a.object_id not in cats:
                continue  # the base check reports it
            key, row = attribute_row(cats[a.object_id])
            lo, hi = row.mass_range_kg
            if key != "small" and not lo / 4 <= a.mass_kg <= hi * 4:
                problems.append(
                    f"mass {a.mass_kg:g} kg of {a.object_id!r} ({cats[a.object_id]}) is implausible; "
                    f"typical {lo:g}-{hi:g} kg"
                )
        return problems

    def _merged(self, given: SimAttributes, estimate: ObjectAttributes) -> SimAttributes:
        """The estimate, except where the input measured a value (e.g. an SDF's mass): that is kept."""
        measured = given.source is not None and not given.source.startswith(f"{self.name}:")
        if measured and (given.mass_kg is not None or given.density_kg_m3 is not None):
            return given.model_copy(
                update={"static": estimate.static, "source": f"{given.source}; static: {self.name}"}
            )
        return SimAttributes(
            mass_kg=estimate.mass_kg,
            friction=estimate.friction,
            static=estimate.static,
            source=f"{self.name}: {estimate.basis}",
        )

    def apply(self, output: AttributesOutput, state: SceneState) -> None:
        by_id = {a.object_id: a for a in output.objects}
        objects = [
            o.model_copy(update={"sim": self._merged(o.sim, by_id[o.id])}) if o.id in by_id else o
            for o in state.scene.objects
        ]
        state.scene = replace_scene(state.scene, objects=objects)

"""The procedural furniture library: exact sizes, convex parts, fronts toward -Y, category names."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from structlog.testing import capture_logs

from scenemosaic.assets import (
    MAX_PARTS,
    known_categories,
    procedural_key,
    procedural_mesh,
    procedural_parts,
)
from scenemosaic.exceptions import AssetError

SIZES = st.tuples(
    st.floats(0.03, 3.5, allow_nan=False),
    st.floats(0.03, 3.5, allow_nan=False),
    st.floats(0.01, 3.0, allow_nan=False),
)


def _union_bounds(parts: list[trimesh.Trimesh]) -> tuple[np.ndarray, np.ndarray]:
    return np.min([p.bounds[0] for p in parts], axis=0), np.max([p.bounds[1] for p in parts], axis=0)


def _is_convex(part: trimesh.Trimesh) -> bool:
    return bool(part.is_convex) or math.isclose(part.convex_hull.volume, part.volume, rel_tol=1e-6)


@pytest.mark.parametrize("category", known_categories())
@settings(max_examples=3, deadline=None, derandomize=False)
@given(size=SIZES)
def test_every_category_fills_its_box_with_convex_parts(
    category: str, size: tuple[float, float, float]
) -> None:
    w, d, h = size
    parts = procedural_parts(category, size)
    assert 1 <= len(parts) <= MAX_PARTS
    lo, hi = _union_bounds(parts)
    np.testing.assert_allclose(lo, [-w / 2, -d / 2, 0.0], atol=1e-6)
    np.testing.assert_allclose(hi, [w / 2, d / 2, h], atol=1e-6)
    for part in parts:
        assert np.all(part.bounds[0] >= [-w / 2 - 1e-9, -d / 2 - 1e-9, -1e-9]), category
        assert np.all(part.bounds[1] <= [w / 2 + 1e-9, d / 2 + 1e-9, h + 1e-9]), category
        assert part.is_watertight, category
        assert part.volume > 0, category
        assert _is_convex(part), category


def test_mesh_is_the_concatenation_of_the_parts() -> None:
    size = (0.9, 0.4, 1.8)
    parts = procedural_parts("bookshelf", size)
    mesh = procedural_mesh("bookshelf", size)
    assert len(mesh.faces) == sum(len(p.faces) for p in parts)
    np.testing.assert_allclose(mesh.bounds, [[-0.45, -0.2, 0.0], [0.45, 0.2, 1.8]], atol=1e-9)


def test_parts_are_fresh_copies() -> None:
    first = procedural_parts("table", (1.2, 0.8, 0.75))
    first[0].apply_translation((5.0, 5.0, 5.0))
    again = procedural_parts("table", (1.2, 0.8, 0.75))
    assert again[0].bounds[1][2] == pytest.approx(0.75)


def test_unknown_category_gives_a_box_and_warns_once(monkeypatch: pytest.MonkeyPatch) -> None:
    # a fixed label and a fresh warn-once memory: no randomness (a random all-digit suffix would
    # be read as an instance number and dropped by the category normalization)
    from scenemosaic.assets import _procedural

    monkeypatch.setattr(_procedural, "_warned_unknown", set())
    label = "flux_capacitor_mk2"
    with capture_logs() as logs:
        parts = procedural_parts(label, (0.3, 0.2, 0.5))
        procedural_parts(label, (0.6, 0.2, 0.5))
    assert len(parts) == 1
    np.testing.assert_allclose(parts[0].bounds, [[-0.15, -0.1, 0.0], [0.15, 0.1, 0.5]], atol=1e-12)
    assert parts[0].volume == pytest.approx(0.3 * 0.2 * 0.5)
    warnings = [e for e in logs if e["log_level"] == "warning"]
    assert len(warnings) == 1
    assert warnings[0]["category"] == label


@pytest.mark.parametrize("bad", [(0.0, 1.0, 1.0), (1.0, -0.5, 1.0), (1.0, 1.0, float("nan")), (1.0, 1.0)])
def test_bad_extents_raise(bad: tuple[float, ...]) -> None:
    with pytest.raises(AssetError):
        procedural_parts("chair", bad)  # type: ignore[arg-type]


def _mean_y_above(parts: list[trimesh.Trimesh], z_min: float) -> float:
    """Mean y of the material above ``z_min``, weighted by each part's volume above it."""
    total, weighted = 0.0, 0.0
    for p in parts:
        lo, hi = p.bounds
        if hi[2] <= z_min:
            continue
        slab = (hi[2] - max(lo[2], z_min)) * (hi[0] - lo[0]) * (hi[1] - lo[1])
        total += slab
        weighted += slab * 0.5 * (lo[1] + hi[1])
    assert total > 0
    return weighted / total


@pytest.mark.parametrize(
    ("category", "size"),
    [
        ("chair", (0.45, 0.5, 0.9)),
        ("dining_chair", (0.5, 0.55, 1.0)),
        ("office_chair", (0.65, 0.65, 1.1)),
        ("armchair", (0.85, 0.85, 0.85)),
        ("multi_seat_sofa", (2.2, 0.9, 0.85)),
        ("l_shaped_sofa", (2.8, 1.7, 0.85)),
        ("double_bed", (1.8, 2.1, 1.1)),
        ("dressing_table", (1.0, 0.45, 1.5)),
    ],
)
def test_backrests_and_headboards_are_at_plus_y(category: str, size: tuple[float, float, float]) -> None:
    parts = procedural_parts(category, size)
    assert _mean_y_above(parts, 0.8 * size[2]) > 0.15 * size[1]


def test_chair_seat_is_open_toward_minus_y() -> None:
    w, d, h = 0.45, 0.5, 0.9
    parts = procedural_parts("chair", (w, d, h))
    # nothing above the seat in the front half: that is where a person sits down
    for p in parts:
        lo, hi = p.bounds
        if hi[2] > 0.55 * h:
            assert lo[1] > 0.0, "a part above the seat reaches into the front half"


def test_wardrobe_doors_and_handles_face_minus_y() -> None:
    w, d, h = 1.2, 0.6, 2.0
    parts = procedural_parts("wardrobe", (w, d, h))
    front = [p for p in parts if p.bounds[0][1] <= -d / 2 + 1e-9]
    # only the top (cornice) and small handles reach the front plane; the handles are small and mid-height
    handles = [p for p in front if p.bounds[1][2] < h * 0.9]
    assert len(handles) >= 1
    for hnd in handles:
        assert hnd.volume < 0.01 * w * d * h


def test_ceiling_lamp_hangs_from_the_top() -> None:
    w, d, h = 0.5, 0.5, 0.8
    parts = procedural_parts("pendant_lamp", (w, d, h))
    top = [p for p in parts if p.bounds[1][2] == pytest.approx(h)]
    assert len(top) == 1, "one canopy touches the ceiling"
    canopy = top[0]
    assert canopy.extents[0] < 0.5 * w, "the canopy is small, the wide shade is below"
    shade = max(parts, key=lambda p: p.extents[0])
    assert shade.bounds[0][2] == pytest.approx(0.0)
    assert shade.bounds[1][2] < 0.6 * h
    # the shade and the canopy are connected by a cord
    cord = [p for p in parts if p.bounds[0][2] < shade.bounds[1][2] and p.bounds[1][2] >= canopy.bounds[0][2]]
    assert cord


def test_bookshelf_compartments_are_open_and_can_hold_books() -> None:
    w, d, h = 0.9, 0.35, 1.8
    parts = procedural_parts("bookshelf", (w, d, h))
    boards = sorted(
        (p for p in parts if p.extents[0] > 0.8 * w and p.extents[2] < 0.05 and p.extents[1] > 0.8 * d),
        key=lambda p: p.bounds[0][2],
    )
    assert len(boards) >= 4  # bottom, top and at least two shelves
    for lower, upper in itertools.pairwise(boards):
        gap_lo, gap_hi = lower.bounds[1][2], upper.bounds[0][2]
        assert gap_hi - gap_lo > 0.2
        # a book standing in the compartment, near the open front, touches no part
        book_lo = np.array([-0.02, -d / 2 + 0.02, gap_lo + 0.001])
        book_hi = np.array([0.02, -d / 2 + 0.2, gap_lo + 0.2])
        for p in parts:
            overlap = np.all(book_hi > p.bounds[0]) and np.all(book_lo < p.bounds[1])
            assert not overlap


@pytest.mark.parametrize(
    ("label", "key"),
    [
        ("double_bed", "bed"),
        ("kids_bed", "bed"),
        ("multi_seat_sofa", "sofa"),
        ("loveseat_sofa", "sofa"),
        ("l_shaped_sofa", "l_shaped_sofa"),
        ("corner_side_table", "side_table"),
        ("console_table", "side_table"),
        ("pendant_lamp", "ceiling_lamp"),
        ("ceiling_lamp", "ceiling_lamp"),
        ("dressing_table", "dressing_table"),
        ("tv_stand", "tv_stand"),
        ("dining_chair", "chair"),
        ("ArmChair", "armchair"),
        ("DiningTable", "table"),
        ("FloorLamp", "floor_lamp"),
        ("HousePlant", "plant"),
        ("Television", "television"),
        ("TV", "television"),
        ("couch", "sofa"),
        ("three_seat_sofa", "sofa"),
        ("counter_top", "counter"),
        ("TVStand", "tv_stand"),
        ("DeskLamp", "table_lamp"),
        ("ShelvingUnit", "bookshelf"),
        ("Chair|+01.25|+00.00|-02.50", "chair"),
        ("dining_chair_3", "chair"),
        ("Modern Floor-Lamp", "floor_lamp"),
        ("Books", "book"),
    ],
)
def test_normalize_category(label: str, key: str) -> None:
    assert procedural_key(label) == key
    assert key in known_categories()


def test_unknown_labels_come_back_in_snake_case() -> None:
    # (WashingMachine, the example here before, has a builder since ProcTHOR houses ship with one)
    assert procedural_key("FluxCapacitor") == "flux_capacitor"
    assert procedural_key("flux_capacitor") not in known_categories()


def test_every_label_of_the_physcene_layouts_has_a_builder(physcene_files: list) -> None:
    labels = set()
    for path in physcene_files:
        data = json.loads(path.read_text())
        for objects in data["ThreedFront"].values():
            labels |= {o["label"] for o in objects}
    assert labels
    unknown = {label for label in labels if procedural_key(label) not in known_categories()}
    assert not unknown


def test_one_category_vocabulary_underlies_the_builder_keys() -> None:
    """The builder lookup starts from the scene vocabulary, so both agree on what a label means."""
    from scenemosaic.scene import normalize_category

    for label in ("Dining Chair 2", "work_desk_1761578426", "Couch", "double_bed"):
        assert procedural_key(label) == procedural_key(normalize_category(label)), label
    assert normalize_category("Dining Chair 2") == "dining_chair"

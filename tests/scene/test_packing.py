"""Packing a crowded surface: items keep their place when they can, never overlap, stay on the surface."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon

from scenemosaic.scene import PACK_CLEARANCE_M, PackItem, pack_surface


def _box(cx: float, cy: float, w: float, d: float, yaw: float = 0.0) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    half = np.array([[-w / 2, -d / 2], [w / 2, -d / 2], [w / 2, d / 2], [-w / 2, d / 2]])
    return half @ np.array([[c, s], [-s, c]]) + [cx, cy]


def _placed(items: list[PackItem], result) -> dict[str, Polygon]:  # type: ignore[no-untyped-def]
    out = {}
    for i in items:
        if i.id in result.unplaced:
            continue
        corners = i.corners
        if i.id in result.turned:
            centre = corners.mean(axis=0)
            rel = corners - centre
            corners = np.stack([-rel[:, 1], rel[:, 0]], axis=1) + centre
        out[i.id] = Polygon(corners + result.shifts.get(i.id, np.zeros(2)))
    return out


def test_items_that_fit_where_they_stand_are_not_moved() -> None:
    top = Polygon(_box(0, 0, 1.0, 0.6))
    items = [PackItem("a", _box(-0.3, 0, 0.2, 0.2)), PackItem("b", _box(0.3, 0.1, 0.1, 0.1))]
    result = pack_surface(top, items)
    assert result.fits and sorted(result.kept) == ["a", "b"]
    assert all(np.allclose(v, 0) for v in result.shifts.values())


def test_an_item_hanging_over_the_edge_comes_back_on_by_the_least_shift() -> None:
    top = Polygon(_box(0, 0, 1.0, 0.6))
    result = pack_surface(top, [PackItem("mug", _box(0.55, 0, 0.1, 0.1))])
    assert result.fits
    assert -0.11 < result.shifts["mug"][0] < -0.09 and abs(result.shifts["mug"][1]) < 1e-9


def test_a_crowded_top_takes_what_fits_and_names_the_rest() -> None:
    top = Polygon(_box(0, 0, 1.2, 0.5))
    items = [
        PackItem("tv", _box(0, 0.05, 1.0, 0.25), movable=False),
        PackItem("pencil", _box(0, 0, 0.02, 0.18), may_turn=True),
        PackItem("plate", _box(0, 0, 0.25, 0.25), may_turn=True),
        PackItem("candle", _box(0.5, 0, 0.08, 0.08)),
    ]
    result = pack_surface(top, items)
    assert result.unplaced == ["plate"]  # 0.25 m deep, 0.15 m of free depth in front of the TV
    assert "pencil" in result.turned  # it only fits lying across the front strip
    placed = _placed(items, result)
    for a, b in itertools.combinations(placed, 2):
        assert placed[a].distance(placed[b]) >= PACK_CLEARANCE_M - 1e-9, (a, b)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(-0.5, 0.5), st.floats(-0.3, 0.3), st.floats(0.03, 0.3), st.floats(0.03, 0.3), st.floats(-3.2, 3.2)
        ),
        min_size=1,
        max_size=9,
    )
)
def test_packed_items_never_overlap_and_stay_on_the_surface(boxes: list[tuple[float, float, float, float, float]]) -> None:
    top = Polygon(_box(0, 0, 1.0, 0.6))
    items = [PackItem(f"o{k}", _box(*b), may_turn=k % 2 == 0) for k, b in enumerate(boxes)]
    result = pack_surface(top, items)
    placed = _placed(items, result)
    assert set(placed) | set(result.unplaced) == {i.id for i in items}
    for poly in placed.values():
        assert top.buffer(1e-9).contains(poly)
    for a, b in itertools.combinations(placed, 2):
        assert placed[a].distance(placed[b]) >= PACK_CLEARANCE_M / 2 - 1e-9, (a, b)


def test_the_free_space_correlation_matches_a_direct_count() -> None:
    from scenemosaic.scene._packing import _correlate_valid

    rng = np.random.default_rng(7)
    for _ in range(10):
        image = (rng.random((23, 31)) > 0.6).astype(float)
        kernel = (rng.random((4, 6)) > 0.3).astype(float)
        got = _correlate_valid(image, kernel)
        want = np.array(
            [[float((image[i : i + 4, j : j + 6] * kernel).sum()) for j in range(31 - 6 + 1)] for i in range(23 - 4 + 1)]
        )
        assert got.shape == want.shape and np.allclose(got, want, atol=1e-9)

"""The novelty distance against hand-computed cases, the table-based pool against the direct
formula, the greedy against brute-force max-min, and the grafting transforms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenemosaic.compose import (
    MIN_NOVELTY,
    Arrangement,
    CandidatePool,
    GroupVariants,
    compose_transform,
    decompose_transform,
    distance_terms,
    novelty_distance,
    select_diverse,
)
from scenemosaic.scene import quat_from_yaw, quat_to_matrix


def _arr(points: list[tuple[float, float, float]], yaws: list[float] | None = None) -> Arrangement:
    yaws = yaws or [0.0] * len(points)
    q = np.array([quat_from_yaw(y) for y in yaws])
    return Arrangement(np.array(points, dtype=float), np.array([quat_to_matrix(x) for x in q]), q)


def test_identical_arrangements_are_at_distance_zero() -> None:
    a = _arr([(0, 0, 0), (1, 0, 0), (0, 2, 0)], [0.1, 0.5, -1.0])
    assert novelty_distance(a, a) == pytest.approx(0.0, abs=1e-8)  # arccos near 1: ~1e-9


def test_a_rigid_move_of_the_whole_scene_changes_only_the_rotation_term() -> None:
    a = _arr([(0, 0, 0), (1, 0, 0)])
    b = _arr([(5, 5, 0), (6, 5, 0)])  # pure translation: nothing changes
    assert distance_terms(a, b) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    t = math.pi / 2  # the pair turned a quarter about the first object, each object turned with it
    c = _arr([(0, 0, 0), (0, 1, 0)], [t, t])
    d_pos, d_dist, d_rot = distance_terms(a, c)
    assert d_pos == pytest.approx(0.0, abs=1e-12) and d_dist == pytest.approx(0.0, abs=1e-12)
    assert d_rot == pytest.approx(2 * (t / 2) * 2 / (math.pi * 2))  # 2 arccos(cos(t/2)) = t per object


def test_two_objects_by_hand() -> None:
    a = _arr([(0, 0, 0), (1, 0, 0)])
    b = _arr([(0, 0, 0), (3, 0, 0)])  # the second object moved 2 m further away
    # each sees the other 1 m (A) vs 3 m (B) away: |1 - 3|^2 twice over |1|^2 twice
    d_pos, d_dist, d_rot = distance_terms(a, b)
    assert d_pos == pytest.approx(2.0) and d_dist == pytest.approx(2.0) and d_rot == 0.0
    assert novelty_distance(a, b) == pytest.approx(0.4 * 2 + 0.4 * 2)
    # not symmetric: the reference's spread normalizes
    assert novelty_distance(b, a) == pytest.approx(0.4 * 2 / 3 + 0.4 * 2 / 3)


def test_turning_one_object_in_place_changes_pos_and_rot_not_dist() -> None:
    a = _arr([(0, 0, 0), (1, 0, 0)])
    b = _arr([(0, 0, 0), (1, 0, 0)], [math.pi, 0.0])  # the first object turned around
    d_pos, d_dist, d_rot = distance_terms(a, b)
    # object 0 now sees object 1 at (-1, 0) instead of (1, 0): |2|^2 over 2 pairs of |1|^2
    assert d_pos == pytest.approx(math.sqrt(4 / 2)) and d_dist == pytest.approx(0.0, abs=1e-12)
    assert d_rot == pytest.approx(math.pi / (math.pi * 2))


def _random_group(rng: np.random.Generator, name: str, n: int, variants: int) -> GroupVariants:
    pos = rng.uniform(-3, 3, size=(variants, n, 3))
    yaws = rng.uniform(-math.pi, math.pi, size=(variants, n))
    q = np.array([[quat_from_yaw(y) for y in row] for row in yaws])
    r = np.array([[quat_to_matrix(x) for x in row] for row in q])
    return GroupVariants(name, tuple(f"{name}_{i}" for i in range(n)), pos, r, q)


def test_pool_tables_equal_the_direct_formula() -> None:
    rng = np.random.default_rng(3)
    pool = CandidatePool([_random_group(rng, "a", 4, 3), _random_group(rng, "b", 2, 4), _random_group(rng, "c", 3, 2)])
    assert pool.size == 24
    rows = pool.choices(np.arange(pool.size))
    for ref_flat in (0, 7, 23):
        ref = tuple(int(x) for x in rows[ref_flat])
        assert pool.flat_index(ref) == ref_flat
        got = pool.distances(ref, rows)
        want = [novelty_distance(pool.arrangement(ref), pool.arrangement(tuple(c))) for c in rows]
        assert got == pytest.approx(want, abs=1e-9)


def _brute_force(pool: CandidatePool, m: int, alpha: float, tie_band: float = 0.0) -> list[int]:
    """The max-min greedy written out plainly; near ties (within ``tie_band`` of the largest
    minimum) go to the candidate farthest in sum from the variants picked (the original not
    counted), N standing in for the footprint distance of a pool without occupancy."""
    arr = {k: pool.arrangement(tuple(pool.choices(np.array([k]))[0])) for k in range(pool.size)}
    picked = [0]
    alive = set(range(1, pool.size))
    while len(picked) < m + 1 and alive:
        mins = {k: min(novelty_distance(arr[p], arr[k]) for p in picked) for k in alive}
        top = max(mins.values())
        near = {k for k in alive if mins[k] >= (1.0 - tie_band) * top}
        sums = {k: sum(novelty_distance(arr[p], arr[k]) for p in picked[1:]) for k in near}
        best = max(sorted(near), key=lambda k: (sums[k], mins[k], -k)) if len(picked) > 1 else max(sorted(alive), key=lambda k: (mins[k], -k))
        picked.append(best)
        alive.discard(best)
        d_max = mins[best]
        mins = {k: min(mins[k], novelty_distance(arr[best], arr[k])) for k in alive}
        alive = {k for k in alive if mins[k] >= alpha * d_max}
    return picked


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("tie_band", [0.0, 0.2])
def test_greedy_matches_brute_force_max_min(seed: int, tie_band: float) -> None:
    rng = np.random.default_rng(seed)
    pool = CandidatePool([_random_group(rng, "a", 3, 4), _random_group(rng, "b", 2, 3), _random_group(rng, "c", 2, 2)])
    sel = select_diverse(pool, m=5, alpha=0.1, tie_band=tie_band)
    assert [pool.flat_index(c) for c in sel.picked] == _brute_force(pool, 5, 0.1, tie_band)


def test_a_rejected_candidate_is_skipped_and_sampling_is_reported() -> None:
    rng = np.random.default_rng(5)
    pool = CandidatePool([_random_group(rng, "a", 3, 5), _random_group(rng, "b", 2, 5)])
    bad = select_diverse(pool, m=2).picked[1]
    sel = select_diverse(pool, m=2, valid=lambda c: c != bad)
    assert sel.rejected == [bad] and bad not in sel.picked and len(sel.picked) == 3
    sampled = select_diverse(pool, m=2, max_candidates=10, seed=1)
    assert sampled.sampled and sampled.considered <= 10 and sampled.pool_size == 25


def test_the_pool_is_lazy_and_its_size_exact_when_huge() -> None:
    rng = np.random.default_rng(0)
    groups = [_random_group(rng, f"g{i}", 1, 40) for i in range(12)]
    pool = CandidatePool(groups)
    assert pool.size == 40**12  # 1.7e19: reported, never materialized
    sel = select_diverse(pool, m=3, max_candidates=2000, seed=0)
    assert sel.sampled and len(sel.picked) == 4


@pytest.mark.parametrize("seed", range(5))
def test_grafting_chains_round_trip_through_the_polar_decomposition(seed: int) -> None:
    rng = np.random.default_rng(seed)

    def pose(scale: bool) -> np.ndarray:
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        m = np.eye(4)
        m[:3, :3] = quat_to_matrix(q) @ (np.diag(rng.uniform(0.3, 3.0, size=3)) if scale else np.eye(3))
        m[:3, 3] = rng.uniform(-5, 5, size=3)
        return m

    anchor_local, anchor_scene = pose(False), pose(False)
    local = pose(True)
    m = compose_transform(anchor_scene, anchor_local, local)
    p, r, s = decompose_transform(m)
    rebuilt = np.eye(4)
    rebuilt[:3, :3] = r @ np.diag(s)
    rebuilt[:3, 3] = p
    assert np.allclose(rebuilt, m, atol=1e-9) and np.allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    # the object's own scale survives the chain
    assert np.allclose(np.sort(s), np.sort(np.linalg.svd(local[:3, :3], compute_uv=False)), atol=1e-9)


def test_near_copies_are_never_selected() -> None:
    """A pool whose variants are tiny nudges of the original yields no variant at all rather than
    a near-copy (``MIN_NOVELTY``); far variants still are selected, none within the minimum."""
    rng = np.random.default_rng(7)
    group = _random_group(rng, "a", 4, 6)
    group.positions[1:4] = group.positions[0] + rng.normal(0, 1e-3, size=(3, 4, 3))  # near-copies of variant 0
    group.rotations[1:4] = group.rotations[0]
    group.quaternions[1:4] = group.quaternions[0]
    pool = CandidatePool([group])
    sel = select_diverse(pool, m=5, alpha=0.0)  # no pruning by the greedy's own step: the minimum alone
    assert sel.near_copies >= 3
    assert all(d >= MIN_NOVELTY for d in sel.min_distances[1:])
    assert not {(1,), (2,), (3,)} & set(sel.picked)
    allowed = select_diverse(pool, m=5, alpha=0.0, min_distance=0.0)
    assert len(allowed.picked) > len(sel.picked)

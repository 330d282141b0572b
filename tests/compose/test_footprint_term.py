"""The selection's footprint term: of two candidates N finds alike in novelty, the one that puts
the furniture on other floor wins; without occupancy, N alone decides."""

from __future__ import annotations

import numpy as np

from scenemosaic.compose import OCCUPANCY_WEIGHT, CandidatePool, GroupVariants, select_diverse
from scenemosaic.scene import quat_from_yaw, quat_to_matrix


def _group() -> GroupVariants:
    """Two objects. Variant 1 turns both half a turn in place (same footprint, large turn);
    variant 2 carries the second 0.3 m further along x (new floor, no turn)."""
    base = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    poses = [(base, 0.0), (base, np.pi), (base + np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]]), 0.0)]
    pos = np.stack([p for p, _ in poses])
    quats = np.stack([np.array([quat_from_yaw(y)] * 2) for _, y in poses])
    rots = np.stack([np.stack([quat_to_matrix(q) for q in qs]) for qs in quats])
    return GroupVariants("floor", ("a", "b"), pos, rots, quats, ("base", "turned", "moved"))


def _bits(cells: list[int]) -> np.ndarray:
    mask = np.zeros(64, dtype=bool)
    mask[cells] = True
    return np.packbits(mask)


def test_without_occupancy_the_turned_copy_is_picked_first() -> None:
    sel = select_diverse(CandidatePool([_group()]), m=1)
    assert sel.picked[1] == (1,)


def test_the_footprint_term_prefers_new_floor() -> None:
    occ = np.stack([_bits([0, 1, 2, 3]), _bits([0, 1, 2, 3]), _bits([10, 11, 12, 13])])
    pool = CandidatePool([_group()], [occ])
    sel = select_diverse(pool, m=1)
    assert sel.picked[1] == (2,)
    d = pool.distances((0,), np.array([[1], [2]]))
    plain = CandidatePool([_group()]).distances((0,), np.array([[1], [2]]))
    assert plain[0] > plain[1] > 0.0
    assert np.allclose(d - plain, [0.0, OCCUPANCY_WEIGHT])  # IoU 1 adds nothing; disjoint floor adds the whole weight


class _Table(CandidatePool):
    """A pool of one group whose distances are given: ``n[i][j]`` (N plus footprint) and
    ``apart[i][j]`` (1 - IoU) between variants i and j."""

    def __init__(self, n: list[list[float]], apart: list[list[float]]) -> None:
        k = len(n)
        base = np.zeros((k, 1, 3))
        quats = np.tile(np.array(quat_from_yaw(0.0)), (k, 1, 1))
        rots = np.tile(np.eye(3), (k, 1, 1, 1))
        super().__init__([GroupVariants("floor", ("a",), base, rots, quats, tuple(f"v{i}" for i in range(k)))])
        self.n, self.apart = np.asarray(n), np.asarray(apart)

    def distances(self, ref, choices, weights=(0.4, 0.4, 0.2)):  # type: ignore[no-untyped-def]
        c = self.choices(choices) if choices.ndim == 1 else choices
        return self.n[ref[0], c[:, 0]]

    def footprint_distances(self, ref, choices):  # type: ignore[no-untyped-def]
        c = self.choices(choices) if choices.ndim == 1 else choices
        return self.apart[ref[0], c[:, 0]]


def test_a_near_tie_goes_to_the_variant_on_other_floor() -> None:
    """Variant 1 is farthest from the original and is taken first. Variant 2 is a little farther
    from the original than variant 3, but stands where variant 1 stands (a mirror image: large N,
    same footprint); within the tie band, variant 3, on other floor, is taken. Plain max-min
    (no band) takes variant 2."""
    n = [[0, 3.0, 2.9, 2.7], [3.0, 0, 2.95, 2.8], [2.9, 2.95, 0, 2.9], [2.7, 2.8, 2.9, 0]]
    apart = [[0, 0.8, 0.8, 0.6], [0.8, 0, 0.05, 0.9], [0.8, 0.05, 0, 0.9], [0.6, 0.9, 0.9, 0]]
    assert select_diverse(_Table(n, apart), m=2).picked == [(0,), (1,), (3,)]
    assert select_diverse(_Table(n, apart), m=2, tie_band=0.0).picked == [(0,), (1,), (2,)]
    # outside the band the max-min order stands: variant 3 far below variant 2
    far = [row[:] for row in n]
    far[0][3] = far[3][0] = 1.5
    assert select_diverse(_Table(far, apart), m=2).picked == [(0,), (1,), (2,)]

"""The selection's footprint term: of two candidates N finds alike in novelty, the one that puts
the furniture on other floor wins; without occupancy, N alone decides."""

from __future__ import annotations

import numpy as np

from scenemosaic.compose import CandidatePool, GroupVariants, select_diverse
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
    assert np.allclose(d - plain, [0.0, 1.0])  # IoU 1 adds nothing; disjoint floor adds the whole weight

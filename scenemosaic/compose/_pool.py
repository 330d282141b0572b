"""The candidate pool: a lazy Cartesian product of group variants, and max-min selection over it.

A scene splits into **groups** (the root subtrees of the scene tree: the floor with everything on
its furniture, each wall, the ceiling); a group's **variants** are its materialized arrangements
(the product of its units' variants, composed in their anchors' frames). A candidate is one
variant per group, identified by its flat index into the product, so the pool is never built: a
10^6-candidate pool is a range of integers.

Distances from a reference scene to many candidates use the product structure: the sums of the
novelty distance split into pairs within a group (which depend on that group's variant only) and
pairs across two groups (which depend on those two variants only), so per reference they are
tabulated once per group variant and per pair of group variants, and a candidate's sums are a
few table lookups (:meth:`CandidatePool.distances`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from scenemosaic.compose._distance import WEIGHTS, Arrangement, relative
from scenemosaic.scene import FloatArray

__all__ = [
    "ALPHA",
    "CHUNK",
    "MAX_ENUMERATED",
    "MIN_NOVELTY",
    "OCCUPANCY_WEIGHT",
    "TIE_BAND",
    "VETO_MAX_ROWS",
    "CandidatePool",
    "GroupVariants",
    "Selection",
    "Veto",
    "select_diverse",
]

ALPHA = 0.1
"""Pruning factor of the dynamic max-min greedy: candidates closer than ALPHA * d_max to the
selected set are dropped after each pick (the method's value)."""
CHUNK = 100_000
"""Candidates scored per vectorized chunk (bounds the memory of a pass over a huge pool)."""
MAX_ENUMERATED = 20_000_000
"""Largest pool scored whole (17 bytes a candidate: flat index, minimum distance, alive flag);
a larger one is sampled uniformly (seeded) to this many, and the selection says ``sampled``."""


@dataclass(frozen=True)
class GroupVariants:
    """The variants of one group: positions (V, n, 3), rotations (V, n, 3, 3), quaternions (V, n, 4).

    Variant 0 is the refined original.
    """

    name: str
    ids: tuple[str, ...]
    positions: FloatArray
    rotations: FloatArray
    quaternions: FloatArray
    labels: tuple[str, ...] = ()
    """A name per variant (e.g. ``floor:rotated_180``)."""

    @property
    def count(self) -> int:
        return int(self.positions.shape[0])


@dataclass
class _Tables:
    within_pos: list[FloatArray]
    within_dist: list[FloatArray]
    rot: list[FloatArray]
    cross_pos: dict[tuple[int, int], FloatArray]
    cross_dist: dict[tuple[int, int], FloatArray]
    norm: float


OCCUPANCY_WEIGHT = 2.0
"""Weight of the footprint term added to the novelty distance in a room's selection:
``N + OCCUPANCY_WEIGHT * (1 - IoU)`` of the two candidates' top-down occupancy. A deliberate
addition to the method (``docs/composition.md``): N alone ranks a mirror image of a symmetric
room as very novel though a person sees the same room; the footprint term prefers variants that
put furniture on other floor."""
MIN_NOVELTY = 0.1
"""No near-copies: a candidate whose novelty distance to a scene already selected (the original
included) is below this is never selected; a run with fewer candidates this far apart delivers
fewer variants and says so (``docs/composition.md``)."""
TIE_BAND = 0.2
"""Candidates whose minimum distance to the selected set is within this fraction of the largest
count as near ties in :func:`select_diverse`, and the one whose footprint overlaps least, in
sum, with the variants already selected is taken. A deliberate refinement of the method's max-min (``docs/composition.md``):
every variant of a small room is far from the original, and plain max-min then takes several
that are far from the original but close to each other (three beds on one wall)."""
_OCC_BLOCK = 2048
_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)


class CandidatePool:
    """All combinations of group variants, lazily.

    ``occupancy``, when given, is per group a (variants, bytes) array of packed top-down
    occupancy bits (the same raster for every group); :meth:`distances` then adds the footprint
    term (:data:`OCCUPANCY_WEIGHT`)."""

    def __init__(self, groups: Sequence[GroupVariants], occupancy: Sequence[np.ndarray] | None = None) -> None:
        self.groups = list(groups)
        self.shape = tuple(g.count for g in self.groups)
        self.n_objects = sum(len(g.ids) for g in self.groups)
        self.occupancy = list(occupancy) if occupancy is not None else None
        self._within_all: dict[int, tuple[FloatArray, FloatArray]] = {}
        self._cross_all: dict[tuple[int, int], tuple[FloatArray, FloatArray, FloatArray]] = {}

    @property
    def size(self) -> int:
        """Number of candidates k (a Python int: exact even when astronomically large)."""
        return math.prod(self.shape) if self.shape else 0

    def choices(self, flat: np.ndarray) -> np.ndarray:
        """(K, G) variant index per group of flat candidate indices."""
        if not self.shape:
            return np.zeros((len(flat), 0), dtype=np.int64)
        return np.stack(np.unravel_index(np.asarray(flat, dtype=np.int64), self.shape), axis=1)

    def arrangement(self, choice: Sequence[int]) -> Arrangement:
        """The whole arrangement (groups concatenated) of one candidate."""
        parts = [(g.positions[k], g.rotations[k], g.quaternions[k]) for g, k in zip(self.groups, choice, strict=True)]
        return Arrangement(
            positions=np.concatenate([p for p, _, _ in parts]) if parts else np.zeros((0, 3)),
            rotations=np.concatenate([r for _, r, _ in parts]) if parts else np.zeros((0, 3, 3)),
            quaternions=np.concatenate([q for _, _, q in parts]) if parts else np.zeros((0, 4)),
        )

    # -- tables for one reference ---------------------------------------------------------------------

    def _within(self, gi: int) -> tuple[FloatArray, FloatArray]:
        """Group ``gi``'s relative positions (V, n, n, 3) and pairwise distances (V, n, n) in
        every variant: the same for every reference, so computed once per pool."""
        known = self._within_all.get(gi)
        if known is None:
            g = self.groups[gi]
            rel_all = _rel_many(g.positions, g.rotations, g.positions)
            d_all = np.linalg.norm(g.positions[:, None, :, :] - g.positions[:, :, None, :], axis=3)
            known = self._within_all[gi] = (rel_all, d_all)
        return known

    def _cross(self, a: int, b: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Groups ``a`` and ``b``'s relative positions both ways ((Va, Vb, na, nb, 3) and
        (Vb, Va, nb, na, 3)) and distances (Va, Vb, na, nb) in every pair of their variants: the
        same for every reference, so computed once per pool (the bulk of a reference's tables)."""
        known = self._cross_all.get((a, b))
        if known is None:
            ga, gb = self.groups[a], self.groups[b]
            all_ab = _rel_cross(ga.positions, ga.rotations, gb.positions)
            all_ba = _rel_cross(gb.positions, gb.rotations, ga.positions)
            d_all = np.linalg.norm(gb.positions[None, :, None, :, :] - ga.positions[:, None, :, None, :], axis=4)
            known = self._cross_all[(a, b)] = (all_ab, all_ba, d_all)
        return known

    def _tables(self, ref: Sequence[int]) -> _Tables:
        g = self.groups
        within_pos, within_dist, rot = [], [], []
        for index, (gi, k) in enumerate(zip(g, ref, strict=True)):
            rel_a = relative(gi.positions[k], gi.rotations[k], gi.positions[k])  # (n, n, 3)
            rel_all, d_all = self._within(index)  # (V, n, n, 3), (V, n, n)
            within_pos.append(((rel_all - rel_a[None]) ** 2).sum(axis=(1, 2, 3)))
            d_a = np.linalg.norm(gi.positions[k][None] - gi.positions[k][:, None], axis=2)
            within_dist.append(((d_all - d_a[None]) ** 2).sum(axis=(1, 2)))
            dots = np.clip(np.abs((gi.quaternions * gi.quaternions[k][None]).sum(axis=2)), 0.0, 1.0)
            rot.append((2.0 * np.arccos(dots)).sum(axis=1))
        cross_pos: dict[tuple[int, int], FloatArray] = {}
        cross_dist: dict[tuple[int, int], FloatArray] = {}
        for a in range(len(g)):
            for b in range(a + 1, len(g)):
                ga, gb = g[a], g[b]
                ka, kb = ref[a], ref[b]
                # i in a, j in b, and i in b, j in a
                ref_ab = relative(ga.positions[ka], ga.rotations[ka], gb.positions[kb])  # (na, nb, 3)
                ref_ba = relative(gb.positions[kb], gb.rotations[kb], ga.positions[ka])  # (nb, na, 3)
                all_ab, all_ba, d_all = self._cross(a, b)
                pos = ((all_ab - ref_ab) ** 2).sum(axis=(2, 3, 4)) + ((all_ba - ref_ba) ** 2).sum(axis=(2, 3, 4)).T
                d_ref = np.linalg.norm(gb.positions[kb][None, :, :] - ga.positions[ka][:, None, :], axis=2)
                dist = 2.0 * ((d_all - d_ref) ** 2).sum(axis=(2, 3))
                cross_pos[(a, b)], cross_dist[(a, b)] = pos, dist
        whole = self.arrangement(ref)
        d = np.linalg.norm(whole.positions[None] - whole.positions[:, None], axis=2)
        return _Tables(within_pos, within_dist, rot, cross_pos, cross_dist, float((d**2).sum()))

    def flat_index(self, choice: Sequence[int]) -> int:
        """The flat index (a Python int, exact for any pool size) of a candidate's choices."""
        index = 0
        for k, n in zip(choice, self.shape, strict=True):
            index = index * n + int(k)
        return index

    def distances(
        self, ref: Sequence[int], choices: np.ndarray, weights: tuple[float, float, float] = WEIGHTS
    ) -> FloatArray:
        """N(ref, candidate) for each candidate, in chunks: ``choices`` is (K, G) variant indices, or
        (K,) flat indices unravelled chunk by chunk (a large pool then costs 8 bytes a candidate)."""
        t = self._tables(ref)
        out = np.empty(len(choices), dtype=np.float64)
        for start in range(0, len(choices), CHUNK):
            c = choices[start : start + CHUNK]
            if c.ndim == 1:
                c = self.choices(c)
            pos = np.zeros(len(c))
            dist = np.zeros(len(c))
            rot = np.zeros(len(c))
            for gi in range(len(self.groups)):
                col = c[:, gi]
                pos += t.within_pos[gi].take(col)
                dist += t.within_dist[gi].take(col)
                rot += t.rot[gi].take(col)
            for (a, b), table in t.cross_pos.items():
                # one flat take per table: a house pool has a table for each pair of rooms, and
                # two-axis fancy indexing cost most of a selection; the same values, added in the same order
                at = c[:, a] * table.shape[1] + c[:, b]
                pos += table.ravel().take(at)
                dist += t.cross_dist[(a, b)].ravel().take(at)
            if t.norm > 0:
                d_pos, d_dist = np.sqrt(pos / t.norm), np.sqrt(dist / t.norm)
            else:
                d_pos = d_dist = np.zeros(len(c))
            d_rot = rot / (math.pi * max(self.n_objects, 1))
            out[start : start + len(c)] = weights[0] * d_pos + weights[1] * d_dist + weights[2] * d_rot
            if self.occupancy is not None:
                out[start : start + len(c)] += OCCUPANCY_WEIGHT * (1.0 - self._iou(ref, c))
        return out

    def footprint_distances(self, ref: Sequence[int], choices: np.ndarray) -> FloatArray | None:
        """1 - IoU of ``ref``'s top-down occupancy with each candidate's (``choices`` as in
        :meth:`distances`); ``None`` without occupancy."""
        if self.occupancy is None:
            return None
        out = np.empty(len(choices), dtype=np.float64)
        for start in range(0, len(choices), CHUNK):
            c = choices[start : start + CHUNK]
            out[start : start + len(c)] = 1.0 - self._iou(ref, self.choices(c) if c.ndim == 1 else c)
        return out

    def _iou(self, ref: Sequence[int], c: np.ndarray) -> FloatArray:
        """Top-down occupancy IoU of ``ref`` with each candidate of ``c`` ((K, G) choices)."""
        assert self.occupancy is not None
        occ = self.occupancy
        mine = np.bitwise_or.reduce(np.stack([o[k] for o, k in zip(occ, ref, strict=True)]), axis=0)
        out = np.empty(len(c), dtype=np.float64)
        for lo in range(0, len(c), _OCC_BLOCK):
            part = c[lo : lo + _OCC_BLOCK]
            bits = occ[0][part[:, 0]].copy()
            for g in range(1, len(occ)):
                bits |= occ[g][part[:, g]]
            inter = _POPCOUNT[bits & mine].sum(axis=1)
            union = _POPCOUNT[bits | mine].sum(axis=1)
            out[lo : lo + len(part)] = np.where(union > 0, inter / np.maximum(union, 1), 1.0)
        return out

    def candidates(self, max_candidates: int | None, seed: int) -> tuple[np.ndarray, bool]:
        """Every candidate but the original as flat indices, or a seeded uniform sample of at most
        ``max_candidates`` distinct ones as (K, G) choices (second value True). Pools larger than
        :data:`MAX_ENUMERATED` are always sampled (to that many)."""
        size = self.size
        if max_candidates is None and size > MAX_ENUMERATED:
            max_candidates = MAX_ENUMERATED
        if max_candidates is not None and size - 1 > max_candidates:
            rng = np.random.default_rng(seed)
            rows = np.stack([rng.integers(0, n, size=max_candidates) for n in self.shape], axis=1)
            if size < 2**62:  # distinct rows, sorted, through their flat indices (row order is flat-index order)
                flat = np.unique(np.ravel_multi_index(tuple(rows.T), self.shape))
                rows = self.choices(flat[flat != 0])  # not the original
            else:
                rows = np.unique(rows, axis=0)
                rows = rows[np.any(rows != 0, axis=1)]  # not the original
            return rows.astype(np.int64), True
        return np.arange(1, size, dtype=np.int64), False


def _rel_many(p_from: FloatArray, r_from: FloatArray, p_to: FloatArray) -> FloatArray:
    diff = p_to[:, None, :, :] - p_from[:, :, None, :]  # (V, n, m, 3)
    out: FloatArray = np.einsum("viab,vija->vijb", r_from, diff)
    return out


def _rel_cross(p_from: FloatArray, r_from: FloatArray, p_to: FloatArray) -> FloatArray:
    diff = p_to[None, :, None, :, :] - p_from[:, None, :, None, :]  # (Va, Vb, na, nb, 3)
    out: FloatArray = np.einsum("kiab,klija->klijb", r_from, diff)
    return out


@dataclass
class Selection:
    """What the max-min greedy picked (the original first) and the path there."""

    picked: list[tuple[int, ...]] = field(default_factory=list)
    """Each pick's variant per group (the original, all zeros, first)."""
    min_distances: list[float] = field(default_factory=list)
    """Each pick's minimum distance to what was picked before it (0 for the original)."""
    pool_size: int = 0
    considered: int = 0
    """Candidates scored (the whole pool, or a seeded sample of it)."""
    sampled: bool = False
    rejected: list[tuple[int, ...]] = field(default_factory=list)
    """Candidates the scene-level check turned down when the greedy reached them."""
    vetoed: int = 0
    """Candidates dropped unchecked because they share a turned-down part (a :data:`Veto`)."""
    pruned: int = 0
    near_copies: int = 0
    """Candidates dropped for lying closer than the minimum novelty distance to a selected scene."""


Veto = tuple[tuple[int, int], ...]
"""Why a candidate is invalid, as ``((group, variant), ...)``: every candidate that takes all of
these group variants is invalid too (a group variant that interpenetrates itself, a pair that
interpenetrates each other, a room arrangement turned down)."""
VETO_MAX_ROWS = 2_000_000
"""Vetoes are applied to the candidates scored when there are at most this many (the (K, G) table
of their group variants is built for it); above, each candidate is checked on its own."""


def select_diverse(
    pool: CandidatePool,
    m: int = 5,
    *,
    alpha: float = ALPHA,
    tie_band: float = TIE_BAND,
    valid: Callable[[tuple[int, ...]], bool | Veto] | None = None,
    max_candidates: int | None = None,
    seed: int = 0,
    min_distance: float = MIN_NOVELTY,
) -> Selection:
    """Dynamic max-min greedy: start from the original (every group's variant 0); repeatedly add the
    candidate whose minimum distance to the selected set is largest (near ties, within
    ``tie_band`` of the largest: the one whose footprint overlaps least, in sum, with the variants
    already selected, the original not counted (N when the pool has no occupancy); exact ties: the
    lowest index); when
    ``valid`` turns it down (scene-level interpenetration), drop it and take the next; after each
    addition drop every candidate whose minimum distance is below ``alpha`` times the added one's
    (the d_max of that step), and every candidate closer than ``min_distance`` to a selected
    scene (:data:`MIN_NOVELTY`: no near-copies); stop at ``m`` + 1 scenes or an empty pool.

    ``max_candidates`` scores a seeded uniform sample of that many candidates instead of the whole
    pool (``Selection.sampled`` says so). Each ordered (selected, candidate) distance is computed
    once: the minimum is updated with the newly selected scene only. ``valid`` may answer a
    :data:`Veto` instead of ``False``: every candidate scored that takes those group variants is
    dropped with it (``Selection.vetoed``).
    """
    size = pool.size
    sel = Selection(pool_size=size)
    origin = (0,) * len(pool.shape)
    sel.picked.append(origin)
    sel.min_distances.append(0.0)
    if size <= 1 or m <= 0:
        return sel
    rows, sel.sampled = pool.candidates(max_candidates, seed)
    sel.considered = len(rows)
    min_d = pool.distances(origin, rows)
    sum_d = np.zeros(len(rows), dtype=np.float64)  # summed footprint distance to the variants picked
    alive = np.ones(len(rows), dtype=bool)
    copies = min_d < min_distance
    sel.near_copies += int(copies.sum())
    alive &= ~copies
    grid = rows if rows.ndim == 2 else (pool.choices(rows) if len(rows) <= VETO_MAX_ROWS else None)
    while len(sel.picked) < m + 1 and alive.any():
        # the alive rows, farthest first (a stable sort: ties in flat-index order); those within
        # TIE_BAND of the farthest come first, the farthest from the variants already picked
        # first among them; a rejection changes no distance, so the next best is the next alive
        # one in this order
        idx = np.flatnonzero(alive)
        order = idx[np.argsort(-min_d[idx], kind="stable")]
        near = min_d[order] >= (1.0 - tie_band) * float(min_d[order[0]])
        head = order[near]
        order = np.concatenate([head[np.argsort(-sum_d[head], kind="stable")], order[~near]])
        picked = None
        for best in order:
            best = int(best)
            if not alive[best]:
                continue  # vetoed with an earlier rejection
            alive[best] = False
            row = rows[best : best + 1]
            choice = tuple(int(x) for x in (pool.choices(row)[0] if rows.ndim == 1 else row[0]))
            verdict = True if valid is None else valid(choice)
            if verdict is True:
                picked = (best, choice)
                break
            sel.rejected.append(choice)
            if verdict and grid is not None:  # a veto: drop every candidate sharing the parts
                hit = np.ones(len(rows), dtype=bool)
                for g, k in verdict:
                    hit &= grid[:, g] == k
                hit &= alive
                sel.vetoed += int(hit.sum())
                alive &= ~hit
        if picked is None:
            break
        best, choice = picked
        d_max = float(min_d[best])
        sel.picked.append(choice)
        sel.min_distances.append(d_max)
        if alive.any():
            idx = np.flatnonzero(alive)
            step = pool.distances(choice, rows[idx])
            min_d[idx] = np.minimum(min_d[idx], step)
            apart = pool.footprint_distances(choice, rows[idx])
            sum_d[idx] += step if apart is None else apart
            low = alive & (min_d < alpha * d_max)
            sel.pruned += int(low.sum())
            alive &= ~low
            copies = alive & (min_d < min_distance)
            sel.near_copies += int(copies.sum())
            alive &= ~copies
    return sel

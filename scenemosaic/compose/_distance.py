"""The novelty-aware distance between two arrangements of the same objects.

N(A, B) = w_p D_pos + w_u D_dist + w_r D_rot with (w_p, w_u, w_r) = (0.4, 0.4, 0.2):

* ``D_pos`` = sqrt( sum_{i != j} |R_i^A^T (p_j^A - p_i^A) - R_i^B^T (p_j^B - p_i^B)|^2 / sum_{i != j} |p_j^A - p_i^A|^2 ):
  how differently each object sees every other one, in its own frame;
* ``D_dist`` = sqrt( sum_{i != j} (d_ij^A - d_ij^B)^2 / sum_{i != j} (d_ij^A)^2 ), d_ij = |p_j - p_i|;
* ``D_rot`` = (1 / (pi N)) sum_i 2 arccos(|q_i^A . q_i^B|): the mean turn between the two, over pi.

``A`` is the reference: the normalizers are ``A``'s, so N is not symmetric; in selection ``A`` is
always the scene already selected. Positions are the objects' pose positions (bottom centres).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from scenemosaic.clutter import clutter_distance
from scenemosaic.scene import FloatArray, Scene, quat_to_matrix

__all__ = ["CLUTTER_WEIGHT", "WEIGHTS", "Arrangement", "distance_terms", "novelty_distance", "novelty_with_clutter"]

WEIGHTS = (0.4, 0.4, 0.2)
"""(w_p, w_u, w_r): the method's weights of D_pos, D_dist and D_rot."""


@dataclass(frozen=True)
class Arrangement:
    """Poses of N objects in a fixed order: positions (N, 3), rotations (N, 3, 3), quaternions (N, 4)."""

    positions: FloatArray
    rotations: FloatArray
    quaternions: FloatArray

    @classmethod
    def of(cls, scene: Scene, ids: list[str] | None = None) -> Arrangement:
        """The arrangement of ``ids`` (default: every object, in scene order) in ``scene``."""
        objs = [scene.get(i) for i in ids] if ids is not None else list(scene.objects)
        q = np.array([o.pose.quaternion for o in objs], dtype=np.float64).reshape(-1, 4)
        return cls(
            positions=np.array([o.pose.position for o in objs], dtype=np.float64).reshape(-1, 3),
            rotations=np.array([quat_to_matrix(o.pose.quaternion) for o in objs]).reshape(-1, 3, 3),
            quaternions=q,
        )


def relative(p_from: FloatArray, r_from: FloatArray, p_to: FloatArray | None = None) -> FloatArray:
    """(n, m, 3): entry [i, j] is R_i^T (q_j - p_i), point j of ``p_to`` (default ``p_from``:
    every object seen from every other) seen from object i."""
    to = p_from if p_to is None else p_to
    diff = to[None, :, :] - p_from[:, None, :]
    out: FloatArray = np.einsum("iab,ija->ijb", r_from, diff)
    return out


def distance_terms(a: Arrangement, b: Arrangement) -> tuple[float, float, float]:
    """``(D_pos, D_dist, D_rot)`` of ``b`` against the reference ``a`` (same objects, same order)."""
    n = len(a.positions)
    if n == 0:
        return 0.0, 0.0, 0.0
    rel_a, rel_b = relative(a.positions, a.rotations), relative(b.positions, b.rotations)
    d_a = np.linalg.norm(a.positions[None] - a.positions[:, None], axis=2)
    d_b = np.linalg.norm(b.positions[None] - b.positions[:, None], axis=2)
    norm = float((d_a**2).sum())  # the diagonal is zero, so i == j adds nothing
    d_pos = math.sqrt(float(((rel_a - rel_b) ** 2).sum()) / norm) if norm > 0 else 0.0
    d_dist = math.sqrt(float(((d_a - d_b) ** 2).sum()) / norm) if norm > 0 else 0.0
    dots = np.clip(np.abs((a.quaternions * b.quaternions).sum(axis=1)), 0.0, 1.0)
    d_rot = float((2.0 * np.arccos(dots)).sum()) / (math.pi * n)
    return d_pos, d_dist, d_rot


def novelty_distance(a: Arrangement, b: Arrangement, weights: tuple[float, float, float] = WEIGHTS) -> float:
    """N(A, B) with ``a`` the reference (the already selected scene)."""
    d_pos, d_dist, d_rot = distance_terms(a, b)
    return weights[0] * d_pos + weights[1] * d_dist + weights[2] * d_rot


CLUTTER_WEIGHT = 0.5
"""Weight of the clutter term in :func:`novelty_with_clutter` (ours: the method has no small
objects that vary). At 0.5 a variant whose small objects all sit on other receptacles counts as
novel as a furniture arrangement half as far as the most novel one the selection meets in a room."""


def novelty_with_clutter(a: Scene, b: Scene, small: Sequence[str], weight: float = CLUTTER_WEIGHT) -> float:
    """N(A, B) over the objects both scenes hold that are not among ``small``, plus ``weight``
    times :func:`scenemosaic.clutter.clutter_distance` over ``small``: the distance the selection
    uses when a run's clutter varies (``--clutter vary|fill``); a run that keeps its clutter uses
    :func:`novelty_distance` alone."""
    skip = set(small)
    present = {o.id for o in b.objects}
    furniture = [o.id for o in a.objects if o.id not in skip and o.id in present]
    base = novelty_distance(Arrangement.of(a, furniture), Arrangement.of(b, furniture)) if len(furniture) > 1 else 0.0
    return base + weight * clutter_distance(a, b, list(small))

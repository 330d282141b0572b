"""Small rigid-transform helpers shared by the scene model and every layer above it.

Conventions (see ``docs/conventions.md``): quaternions are scalar-first ``(w, x, y, z)``,
world frame Z-up, metres; an object's *front* is its local **-Y** axis, so ``yaw = 0``
faces world -Y and yaw is measured counter-clockwise about +Z.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "FloatArray",
    "front_vector",
    "quat_from_matrix",
    "quat_from_yaw",
    "quat_multiply",
    "quat_to_matrix",
    "yaw_from_quat",
]


def quat_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion ``(w, x, y, z)`` for a rotation of ``yaw`` radians about +Z."""
    half = 0.5 * yaw
    return (math.cos(half), 0.0, 0.0, math.sin(half))


def quat_to_matrix(q: Sequence[float]) -> FloatArray:
    """3x3 rotation matrix of a unit quaternion ``(w, x, y, z)``."""
    w, x, y, z = (float(v) for v in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ],
        dtype=np.float64,
    )


def quat_multiply(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    """Hamilton product ``a * b`` (apply ``b`` first, then ``a``)."""
    aw, ax, ay, az = (float(v) for v in a)
    bw, bx, by, bz = (float(v) for v in b)
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def yaw_from_quat(q: Sequence[float]) -> float:
    """Heading about +Z in radians, in (-pi, pi], read from where the local -Y (front) axis points."""
    f = front_vector(q)
    # front of yaw 0 is (0, -1); rotating by yaw gives (sin yaw, -cos yaw)
    return math.atan2(float(f[0]), float(-f[1]))


def front_vector(q: Sequence[float]) -> FloatArray:
    """World direction of the object's front (local -Y)."""
    front: FloatArray = quat_to_matrix(q) @ np.array([0.0, -1.0, 0.0])
    return front


def quat_from_matrix(r: FloatArray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a 3x3 rotation matrix (Shepperd's method)."""
    t = float(np.trace(r))
    if t > 0:
        s = 2.0 * np.sqrt(t + 1.0)
        q = (0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s)
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * np.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = ((r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s)
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * np.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = ((r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s)
    else:
        s = 2.0 * np.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = ((r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s)
    n = float(np.sqrt(sum(float(c) * float(c) for c in q)))
    w, x, y, z = (float(c) / n for c in q)
    return (w, x, y, z) if w >= 0 else (-w, -x, -y, -z)

"""Anchor-relative grafting: M_scene = M_anchor_scene (M_anchor_local)^-1 M_local, then polar decomposition."""

from __future__ import annotations

import numpy as np

from scenemosaic.scene import FloatArray

__all__ = ["compose_transform", "decompose_transform"]


def compose_transform(anchor_scene: FloatArray, anchor_local: FloatArray, local: FloatArray) -> FloatArray:
    """The scene transform of an object laid out under an anchor: its layout was made with the
    anchor at ``anchor_local``; the anchor now sits at ``anchor_scene`` (4x4 each)."""
    out: FloatArray = np.asarray(anchor_scene) @ np.linalg.inv(np.asarray(anchor_local)) @ np.asarray(local)
    return out


def decompose_transform(matrix: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(position, rotation, scale)`` of a 4x4 transform ``T R S`` by polar decomposition of its
    linear part (``A = R P`` with ``P`` symmetric positive definite; the scale is ``P``'s diagonal
    in the object's frame, exact when the scale is axis-aligned to the object, as poses are)."""
    m = np.asarray(matrix, dtype=np.float64)
    a = m[:3, :3]
    u, _s, vt = np.linalg.svd(a)
    r = u @ vt
    if np.linalg.det(r) < 0:  # a reflection: not a pose; keep a proper rotation
        u[:, -1] *= -1
        r = u @ vt
    p = r.T @ a  # symmetric positive (semi)definite stretch
    scale = np.diag(p).copy()
    return m[:3, 3].copy(), r, scale

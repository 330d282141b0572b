"""How close perception lands: a result scored against a render's truth (``data/images/*/truth.json``).

Everything is compared in the true camera's frame, so the recovered world's free turn and shift
(the room's axes are known only modulo 90 degrees, its origin is the camera's foot) do not count:

* **position**: the distance (metres, 3D) between the recovered and the true bottom centre;
* **heading**: the angle about the true up axis between the recovered and the true front
  (local -Y), taken modulo the object's symmetry (:func:`heading_symmetry`); objects without a
  front (lamps, plants, round things) have no heading error;
* **camera**: the height above the floor against the true one, and the tilt, the angle between
  the recovered and the true up direction.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from scenemosaic.perception._reconstruct import Reconstruction
from scenemosaic.scene import normalize_category, traits

__all__ = ["ObjectScore", "TruthScore", "heading_symmetry", "score_against_truth"]

_NO_FRONT = ("lamp", "plant", "vase", "mug", "cup", "bowl", "bottle", "candle", "chandelier", "stool", "pouf", "ottoman", "book")
"""Words of categories (whole words of the normalized name) whose heading is not scored: round
things, and books (lying at any angle)."""
_SQUARE_TOLERANCE = 0.1
"""A table whose footprint's sides differ by less than this share is square (90-degree symmetry)."""


def heading_symmetry(category: str, extents: tuple[float, float, float] | None = None) -> int:
    """How many headings of an object look alike: 1 for an object with a front (a bed, a chair),
    2 for a rectangular table or rug (a half turn), 4 for a square one, 0 for an object with no
    front at all (a lamp, a plant: its heading is not scored)."""
    c = normalize_category(category)
    if any(word in c.split("_") for word in _NO_FRONT) or traits(c).placement == "ceiling":
        return 0
    tableish = (("table" in c or traits(c).table) and not traits(c).against_wall) or "rug" in c or "carpet" in c
    if not tableish:
        return 1
    if extents is not None and abs(extents[0] - extents[1]) <= _SQUARE_TOLERANCE * max(extents[0], extents[1]):
        return 4
    return 2


@dataclass(frozen=True)
class ObjectScore:
    """One object against its truth: ``position_error_m`` (3D, camera frame), ``heading_error_deg``
    (``None`` when it has no front), its symmetry, where perception placed it, and whether its
    box touches the picture's border (``cut``)."""

    id: str
    category: str
    placement: str
    position_error_m: float
    heading_error_deg: float | None
    symmetry: int
    cut: bool


@dataclass(frozen=True)
class TruthScore:
    """A whole photograph against its truth (see the module's docstring)."""

    objects: list[ObjectScore]
    camera_height_m: float
    true_camera_height_m: float
    tilt_deg: float
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def camera_height_error_m(self) -> float:
        """Recovered minus true camera height, metres."""
        return self.camera_height_m - self.true_camera_height_m

    def figures(self) -> dict[str, float | int]:
        """The headline figures: position median / p90 / share within 0.5 m, heading median and share
        within 20 degrees (objects with a front), camera height error and tilt."""
        pos = np.array([o.position_error_m for o in self.objects])
        head = np.array([o.heading_error_deg for o in self.objects if o.heading_error_deg is not None])
        out: dict[str, float | int] = {
            "objects": len(pos),
            "position_median_m": round(float(np.median(pos)), 3) if len(pos) else math.nan,
            "position_p90_m": round(float(np.quantile(pos, 0.9)), 3) if len(pos) else math.nan,
            "position_within_0_5m": round(float(np.mean(pos <= 0.5)), 3) if len(pos) else math.nan,
            "headed_objects": len(head),
            "heading_median_deg": round(float(np.median(head)), 1) if len(head) else math.nan,
            "heading_within_20deg": round(float(np.mean(head <= 20.0)), 3) if len(head) else math.nan,
            "camera_height_error_m": round(self.camera_height_error_m, 3),
            "tilt_deg": round(self.tilt_deg, 2),
        }
        return out


def _angle_about(a: np.ndarray, b: np.ndarray, up: np.ndarray) -> float | None:
    """Unsigned angle (degrees) from ``a`` to ``b`` about ``up``, both projected onto the plane
    normal to it; ``None`` when either is (nearly) along ``up``."""
    a = a - (a @ up) * up
    b = b - (b @ up) * up
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na < 1e-6 or nb < 1e-6:
        return None
    return math.degrees(math.atan2(float(np.cross(a, b) @ up) / (na * nb), float(a @ b) / (na * nb)))


def score_against_truth(
    reconstruction: Reconstruction,
    truth: Mapping[str, Any],
    camera_height_m: float,
    boxes: Mapping[str, tuple[float, float, float, float]] | None = None,
) -> TruthScore:
    """Score a reconstruction (camera frame) against a render's ``truth.json`` (see the module's
    docstring). ``camera_height_m``: the recovered camera height; ``boxes``: the objects' pixel
    boxes, to tell which ones the picture's border cuts."""
    cam = truth["camera"]
    world_from_camera = np.array(cam["world_from_camera"], dtype=np.float64).reshape(4, 4)
    rot, origin = world_from_camera[:3, :3], world_from_camera[:3, 3]
    up_cam = rot.T @ np.array([0.0, 0.0, 1.0])
    width, height = truth["image"]["width"], truth["image"]["height"]
    true = {o["id"]: o for o in truth["objects"]}
    scores: list[ObjectScore] = []
    for o in reconstruction.objects:
        t = true[o.id]
        true_pos = rot.T @ (np.asarray(t["position"], dtype=np.float64) - origin)
        err = float(np.linalg.norm(np.asarray(o.position) - true_pos))
        extents = tuple(float(v) for v in t["extents"])
        sym = heading_symmetry(t["category"], (extents[0], extents[1], extents[2]))
        heading: float | None = None
        if sym:
            yaw = math.radians(float(t["yaw_deg"]))
            true_front = rot.T @ np.array([math.sin(yaw), -math.cos(yaw), 0.0])
            got_front = np.asarray(o.rotation) @ np.array([0.0, -1.0, 0.0])
            angle = _angle_about(true_front, got_front, up_cam)
            if angle is not None:
                period = 360.0 / sym
                heading = abs(math.remainder(angle, period))
        cut = False
        if boxes is not None and o.id in boxes:
            x0, y0, x1, y1 = boxes[o.id]
            cut = x0 <= 1.5 or y0 <= 1.5 or x1 >= width - 1.5 or y1 >= height - 1.5
        scores.append(ObjectScore(o.id, t["category"], o.placement, err, heading, sym, cut))
    tilt = math.nan
    if reconstruction.floor_up is not None:
        up_rec = np.asarray(reconstruction.floor_up, dtype=np.float64)
        tilt = math.degrees(math.acos(float(np.clip(up_rec @ up_cam / np.linalg.norm(up_rec), -1.0, 1.0))))
    return TruthScore(scores, float(camera_height_m), float(cam["position"][2]), tilt)

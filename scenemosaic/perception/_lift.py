"""The offline reconstructor: single-view metrology from boxes and category sizes.

What it assumes (``docs/perception.md``): a pinhole camera without roll whose focal length is
known (EXIF or the default field of view); a flat floor; every floor object an upright box
standing on it, with the size of its category (the median of the ProcTHOR asset database's
boxes) up to a scale of its footprint and one of its height, each with a log-normal prior; its
front turned to the camera along one of the room's two horizontal directions, read from the
straight edges of the photograph. One least-squares fit finds the camera's height and pitch
and every floor object's place and size from the box edges; objects on the wall, the ceiling
or other furniture follow with the camera fixed. The result is a coarse prior: sizes within
tens of percent, places within a few decimetres (see the tests), which the later stages
(room, support, physics, the critic) correct.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import structlog

from scenemosaic.perception._image import Camera, SceneImage
from scenemosaic.perception._inventory import Placement
from scenemosaic.perception._reconstruct import LiftedObject, Reconstruction, SeenObject
from scenemosaic.scene import FloatArray, load_priors, normalize_category, thor_type, traits

__all__ = [
    "CAMERA_HEIGHT_SIGMA",
    "DEFAULT_CAMERA_HEIGHT",
    "DEFAULT_PITCH_DEG",
    "BoxLifter",
    "CameraPose",
    "size_prior",
]

log = structlog.get_logger(__name__)

DEFAULT_CAMERA_HEIGHT = 1.6
"""Camera height (metres) assumed when no floor object constrains it, and the prior's centre: a
photograph taken standing, at eye level."""
CAMERA_HEIGHT_SIGMA = 0.15
"""Standard deviation (metres) of the camera height's prior."""
DEFAULT_PITCH_DEG = 15.0
"""Downward pitch (degrees) assumed when no floor object constrains it, and the prior's centre."""

# Sizes (w, d, h) for categories the ProcTHOR database has no type for, or lumps with others
# (its "Chair" holds stools and office chairs, its "SideTable" nightstands and end tables, its
# "Dresser" wardrobes): common retail dimensions of the piece.
_OWN_PRIORS: dict[str, tuple[float, float, float]] = {
    "wardrobe": (1.2, 0.6, 2.0),
    "dining_chair": (0.46, 0.53, 0.95),
    "dining_table": (1.6, 0.9, 0.75),
    "coffee_table": (1.1, 0.6, 0.42),
    "nightstand": (0.5, 0.4, 0.55),
    "tv_stand": (1.6, 0.45, 0.5),
    "rug": (2.0, 1.4, 0.01),
    "pendant_lamp": (0.5, 0.5, 0.6),
    "ceiling_lamp": (0.5, 0.5, 0.3),
    "chandelier": (0.7, 0.7, 0.6),
    "double_bed": (1.6, 2.1, 0.9),
    "single_bed": (1.0, 2.0, 0.8),
    "l_shaped_sofa": (2.6, 1.7, 0.85),
}
_GENERIC: dict[str, tuple[float, float, float]] = {
    "floor": (0.6, 0.5, 0.8),
    "surface": (0.2, 0.2, 0.2),
    "wall": (0.8, 0.06, 0.6),
    "ceiling": (0.5, 0.5, 0.4),
}
_SIGMA_KNOWN = 0.3
"""Log-scale standard deviation of a known category's size."""
_SIGMA_UNKNOWN = 0.8


@functools.lru_cache(maxsize=512)
def size_prior(category: str) -> tuple[tuple[float, float, float], bool]:
    """The usual size (w, d, h) of a category, metres, and whether it is known (else a generic
    size by placement): the ProcTHOR asset database's median box for its AI2-THOR type."""
    c = normalize_category(category)
    if c in _OWN_PRIORS:
        return _OWN_PRIORS[c], True
    kind = thor_type(c)
    if kind is not None:
        from scenemosaic.exchange import load_asset_database

        db = load_asset_database(None)
        boxes = [db.boxes[a] for a, t in db.types.items() if t == kind]
        if boxes:
            x, y, z = np.median(np.asarray(boxes), axis=0)
            return (float(x), float(z), float(y)), True  # Unity: x width, y height, z depth
    return _GENERIC[traits(c).placement], False


@dataclass(frozen=True)
class CameraPose:
    """The camera above the floor: ``height`` metres, pitched down by ``pitch`` radians, no roll."""

    height: float
    pitch: float

    @property
    def camera_from_floor(self) -> FloatArray:
        """Rotation taking floor-frame vectors (X right, Y ahead, Z up) to the camera's (OpenCV)."""
        s, c = math.sin(self.pitch), math.cos(self.pitch)
        return np.array([[1.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]])

    def to_camera(self, points: FloatArray) -> FloatArray:
        """Floor-frame points (origin on the floor below the camera) in the camera frame."""
        p = np.asarray(points, dtype=np.float64) - np.array([0.0, 0.0, self.height])
        out: FloatArray = p @ self.camera_from_floor.T
        return out

    def floor_ray(self, camera: Camera, u: float, v: float) -> FloatArray | None:
        """Where the ray through pixel (u, v) meets the floor (floor frame), ``None`` above the horizon."""
        d = self.camera_from_floor.T @ camera.ray(u, v)
        if d[2] > -1e-3:
            return None
        pt: FloatArray = d * (self.height / -d[2])
        pt[2] = 0.0
        return pt


def _yaw_matrices(yaws: FloatArray) -> FloatArray:
    c, s = np.cos(yaws), np.sin(yaws)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


_UNIT_CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (0.0, 1.0)])


def _boxes(camera: Camera, pose: CameraPose, centres: FloatArray, sizes: FloatArray, yaws: FloatArray) -> FloatArray:
    """Projected 2D boxes (n, 4) of upright boxes: bottom centres (n, 3), sizes (n, 3), yaws (n,)."""
    local = _UNIT_CORNERS[None, :, :] * sizes[:, None, :]
    world = np.einsum("nij,nkj->nki", _yaw_matrices(yaws), local) + centres[:, None, :]
    cam = pose.to_camera(world.reshape(-1, 3)).reshape(world.shape)
    z = np.maximum(cam[..., 2], 0.05)
    u = camera.fx * cam[..., 0] / z + camera.cx
    v = camera.fy * cam[..., 1] / z + camera.cy
    return np.stack([u.min(1), v.min(1), u.max(1), v.max(1)], axis=1)


def _facing_yaw(x: float, y: float, room_yaw: float, quarter: int = 0) -> float:
    """Of the room's four directions, the yaw whose front (local -Y) turns most toward the camera;
    ``quarter`` = 1 turns it by a further 90 degrees (the object shows its side to the camera)."""
    to_cam = math.atan2(-y, -x)  # direction from the object to the camera, floor frame
    best, best_gap = room_yaw, math.inf
    for k in range(4):
        yaw = room_yaw + k * math.pi / 2
        front = math.atan2(-math.cos(yaw), math.sin(yaw))
        gap = abs(math.remainder(front - to_cam, 2 * math.pi))
        if gap < best_gap:
            best, best_gap = yaw, gap
    return math.remainder(best + quarter * math.pi / 2, 2 * math.pi)


class BoxLifter:
    """Offline reconstructor from boxes (see the module's docstring). ``room_lines``: read the
    room's direction from the photograph's straight edges (needs OpenCV; else the camera's axis)."""

    name = "box-lifter"

    def __init__(self, *, room_lines: bool = True) -> None:
        self.room_lines = room_lines

    # -- the fit ---------------------------------------------------------------------------------
    def reconstruct(self, image: SceneImage, camera: Camera, objects: Sequence[SeenObject]) -> Reconstruction:
        from scipy.optimize import least_squares

        floor = [o for o in objects if o.placement == "floor"]
        others = [o for o in objects if o.placement != "floor"]
        priors = {o.detection.id: size_prior(o.detection.category) for o in objects}
        report: dict[str, object] = {"reconstructor": self.name}

        obs = np.array([o.detection.box for o in floor]).reshape(-1, 4)
        base = np.array([priors[o.detection.id][0] for o in floor]).reshape(-1, 3)
        sig = np.array([_SIGMA_KNOWN if priors[o.detection.id][1] else _SIGMA_UNKNOWN for o in floor])
        weights = _edge_weights(obs, camera)

        def solve(x0: FloatArray, room_yaw: float, quarters: list[int]) -> tuple[float, FloatArray]:
            result = least_squares(
                _floor_residuals,
                x0,
                args=(camera, obs, base, sig, weights, room_yaw, quarters),
                bounds=_floor_bounds(len(floor)),
                x_scale="jac",
                max_nfev=400,
            )
            return float(result.cost), result.x

        def fit_floor(room_yaw: float) -> tuple[CameraPose, FloatArray, float, list[int]]:
            if not floor:
                return CameraPose(DEFAULT_CAMERA_HEIGHT, math.radians(DEFAULT_PITCH_DEG)), np.zeros((0, 4)), 0.0, []
            quarters = [0] * len(floor)
            best: tuple[float, FloatArray] | None = None
            for h0 in (1.2, 1.6, 2.0):
                for p0 in (5.0, 20.0, 35.0):
                    pose0 = CameraPose(h0, math.radians(p0))
                    x0 = [h0, math.radians(p0)]
                    for o, size in zip(floor, base, strict=True):
                        x0 += [*self._init_xy(camera, pose0, o.detection.box, size), 0.0, 0.0]
                    found = solve(np.array(x0), room_yaw, quarters)
                    if best is None or found[0] < best[0]:
                        best = found
            assert best is not None
            # each object may show its side rather than its front: keep the turn that fits better
            for i in range(len(floor)):
                trial = list(quarters)
                trial[i] = 1 - trial[i]
                found = solve(best[1], room_yaw, trial)
                if found[0] < best[0] - 1e-6:
                    best, quarters = found, trial
            x = best[1]
            return CameraPose(float(x[0]), float(x[1])), x[2:].reshape(-1, 4), best[0], quarters

        room_yaw = 0.0
        pose, params, cost, quarters = fit_floor(room_yaw)
        if self.room_lines:
            measured = _room_direction(image, camera, pose)
            if measured is not None:
                room_yaw, share = measured
                report["room_direction_deg"] = round(math.degrees(room_yaw), 2)
                report["room_direction_support"] = round(share, 3)
                if abs(room_yaw) > math.radians(1.0):
                    pose, params, cost, quarters = fit_floor(room_yaw)
        report["camera_height_m"] = round(pose.height, 3)
        report["camera_pitch_deg"] = round(math.degrees(pose.pitch), 2)
        report["floor_fit_cost"] = round(cost, 3)

        lifted: list[LiftedObject] = []
        placed: dict[str, tuple[FloatArray, FloatArray]] = {}  # id -> (bottom centre, size), floor frame
        report["side_on"] = [o.detection.id for o, q in zip(floor, quarters, strict=True) if q]
        yaws: dict[str, float] = {}
        for o, p, q in zip(floor, params, quarters, strict=True):
            size = np.asarray(priors[o.detection.id][0]) * np.exp([p[2], p[2], p[3]])
            centre = np.array([p[0], p[1], 0.0])
            placed[o.detection.id] = (centre, size)
            yaws[o.detection.id] = _facing_yaw(p[0], p[1], room_yaw, q)
            lifted.append(self._lifted(o, pose, centre, size, yaws[o.detection.id]))
        rests: dict[str, str] = {}
        for o in sorted(others, key=lambda s: _support_depth(s, others)):  # supports before what they hold
            centre, size, rest = self._fit_single(camera, pose, o, priors[o.detection.id], placed, room_yaw)
            if rest == "on" and o.parent is not None:  # what rests on a top stands over it
                centre = _onto(centre, size, *placed[o.parent], yaws[o.parent])
            placed[o.detection.id] = (centre, size)
            yaws[o.detection.id] = _facing_yaw(centre[0], centre[1], room_yaw)
            rests[o.detection.id] = rest
            lifted.append(self._lifted(o, pose, centre, size, yaws[o.detection.id], rest))
        report["resting"] = rests
        up = pose.camera_from_floor @ np.array([0.0, 0.0, 1.0])
        return Reconstruction(lifted, floor_up=up, camera_height=pose.height, yaw_hint=room_yaw, report=report)

    @staticmethod
    def _init_xy(camera: Camera, pose: CameraPose, box: Sequence[float], size: FloatArray) -> list[float]:
        x0, _y0, x1, y1 = box
        hit = pose.floor_ray(camera, (x0 + x1) / 2, y1)
        if hit is None or math.hypot(hit[0], hit[1]) > 15.0:
            d = pose.camera_from_floor.T @ camera.ray((x0 + x1) / 2, y1)
            hit = np.array([d[0], d[1], 0.0]) / max(math.hypot(d[0], d[1]), 1e-6) * 6.0
        ahead = hit[:2] / max(math.hypot(hit[0], hit[1]), 1e-6)
        xy = hit[:2] + ahead * size[1] / 2
        return [float(xy[0]), float(max(xy[1], 0.3))]

    def _fit_single(
        self,
        camera: Camera,
        pose: CameraPose,
        o: SeenObject,
        prior: tuple[tuple[float, float, float], bool],
        placed: dict[str, tuple[FloatArray, FloatArray]],
        room_yaw: float,
    ) -> tuple[FloatArray, FloatArray, str]:
        """An object off the floor fit, the camera fixed: its place and size from its box, under
        each hypothesis of where it rests (:func:`_hypotheses`); the one costing least wins."""
        from scipy.optimize import least_squares

        base = np.asarray(prior[0])
        sig = _SIGMA_KNOWN if prior[1] else _SIGMA_UNKNOWN
        box = np.asarray(o.detection.box, dtype=np.float64)
        weights = _edge_weights(box[None, :], camera)[0]
        # first guess: at the depth where the prior's width fills the box
        width_px = max(box[2] - box[0], 2.0)
        depth = float(np.clip(camera.fx * max(base[0], base[1]) / width_px, 0.3, 20.0))
        ray = pose.camera_from_floor.T @ camera.ray((box[0] + box[2]) / 2, (box[1] + box[3]) / 2)
        guess = (ray / ray[1] * depth if ray[1] > 1e-3 else ray * depth) + np.array([0.0, 0.0, pose.height])
        best: tuple[float, FloatArray, FloatArray, str] | None = None
        for name, z_mean, z_sigma in _hypotheses(o, placed):

            def residuals(x: FloatArray, z_mean: float = z_mean, z_sigma: float | None = z_sigma) -> FloatArray:
                z = z_mean if z_sigma == 0.0 else x[4]
                size = base * np.exp([x[2], x[2], x[3]])
                yaw = _facing_yaw(x[0], x[1], room_yaw)
                pred = _boxes(camera, pose, np.array([[x[0], x[1], z]]), size[None, :], np.array([yaw]))[0]
                extra = [] if not z_sigma else [(z - z_mean) / z_sigma]
                return np.concatenate([(pred - box) * weights, [x[2] / sig, x[3] / sig], extra])

            z0 = z_mean if z_sigma is not None else max(0.0, float(guess[2] - base[2] / 2))
            x0 = np.array([guess[0], guess[1], 0.0, 0.0] + ([] if z_sigma == 0.0 else [z0]))
            result = least_squares(residuals, x0, x_scale="jac", max_nfev=300)
            x = result.x
            z = z_mean if z_sigma == 0.0 else max(0.0, float(x[4]))
            if best is None or result.cost < best[0]:
                best = (float(result.cost), np.array([x[0], x[1], z]), base * np.exp([x[2], x[2], x[3]]), name)
        assert best is not None
        return best[1], best[2], best[3]

    @staticmethod
    def _lifted(
        o: SeenObject, pose: CameraPose, centre: FloatArray, size: FloatArray, yaw: float, rest: str = "floor"
    ) -> LiftedObject:
        r_floor_obj = _yaw_matrices(np.array([yaw]))[0]
        placement: Placement = "floor" if rest == "floor" else o.placement
        return LiftedObject(
            id=o.detection.id,
            category=o.detection.category,
            placement=placement,
            position=pose.to_camera(centre[None, :])[0],
            rotation=pose.camera_from_floor @ r_floor_obj,
            extents=(float(size[0]), float(size[1]), float(size[2])),
            parent=o.parent,
            description=o.detection.description,
        )


def _support_depth(o: SeenObject, objects: Sequence[SeenObject]) -> int:
    """How many supports stand between ``o`` and the floor (its parents have no loops)."""
    parent_of = {s.detection.id: s.parent for s in objects}
    depth, cur = 0, o.parent
    while cur is not None and depth <= len(objects):
        depth += 1
        cur = parent_of.get(cur)
    return depth


def _onto(centre: FloatArray, size: FloatArray, top_centre: FloatArray, top_size: FloatArray, top_yaw: float) -> FloatArray:
    """``centre`` moved the least so a footprint of ``size`` lies over the top of the object at
    ``top_centre`` (size ``top_size``, turned by ``top_yaw``); its height is kept."""
    c, s = math.cos(top_yaw), math.sin(top_yaw)
    rel = centre[:2] - top_centre[:2]
    local = np.array([c * rel[0] + s * rel[1], -s * rel[0] + c * rel[1]])
    room = np.maximum(0.0, (top_size[:2] - size[:2]) / 2)
    local = np.clip(local, -room, room)
    back = np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]]) + top_centre[:2]
    return np.array([back[0], back[1], centre[2]])


RAISED_HEIGHT = (0.75, 0.25)
"""Prior (mean, standard deviation, metres) of the bottom of a small object resting on furniture
that is not in view: a table's or desk's top."""
WALL_HEIGHT = (1.2, 0.6)
"""Prior (mean, standard deviation, metres) of the bottom of a wall-mounted object."""


def _hypotheses(o: SeenObject, placed: dict[str, tuple[FloatArray, FloatArray]]) -> list[tuple[str, float, float | None]]:
    """Where an object off the floor fit may rest, as (name, bottom height, its standard
    deviation): 0 fixes the height, ``None`` leaves it free. On its support's top when it has
    one in view; on a wall or the ceiling when the inventory says so; else, for a small object
    resting on nothing in view: on the floor, on furniture out of view (:data:`RAISED_HEIGHT`),
    or on a wall (:data:`WALL_HEIGHT`) when its type may hang there."""
    if o.parent is not None and o.parent in placed:
        pc, ps = placed[o.parent]
        return [("on", float(pc[2] + ps[2]), 0.0)]
    if o.placement == "wall":
        return [("wall", *WALL_HEIGHT)]
    if o.placement == "ceiling":
        return [("ceiling", 0.0, None)]
    out: list[tuple[str, float, float | None]] = [("floor", 0.0, 0.0), ("raised", *RAISED_HEIGHT)]
    kind = thor_type(o.detection.category)
    if traits(o.detection.category).placement == "wall" or (kind is not None and kind in load_priors().wall):
        out.append(("wall", *WALL_HEIGHT))
    return out


def _edge_weights(obs: FloatArray, camera: Camera) -> FloatArray:
    """1/sigma (pixels) of each observed box edge; 0 for an edge on the image's border (cut off)."""
    span = np.maximum(obs[:, 2] - obs[:, 0], obs[:, 3] - obs[:, 1])
    sigma = 3.0 + 0.02 * span
    w = np.repeat((1.0 / sigma)[:, None], 4, axis=1)
    border = np.stack(
        [obs[:, 0] <= 1.5, obs[:, 1] <= 1.5, obs[:, 2] >= camera.width - 1.5, obs[:, 3] >= camera.height - 1.5], axis=1
    )
    w[border] = 0.0
    return w


def _floor_bounds(n: int) -> tuple[FloatArray, FloatArray]:
    lo = [0.3, math.radians(-30.0)] + [-30.0, 0.2, -1.5, -1.5] * n
    hi = [4.0, math.radians(80.0)] + [30.0, 30.0, 1.5, 1.5] * n
    return np.array(lo), np.array(hi)


def _floor_residuals(
    x: FloatArray,
    camera: Camera,
    obs: FloatArray,
    base: FloatArray,
    sig: FloatArray,
    weights: FloatArray,
    room_yaw: float,
    quarters: Sequence[int],
) -> FloatArray:
    pose = CameraPose(float(x[0]), float(x[1]))
    p = x[2:].reshape(-1, 4)
    sizes = base * np.exp(np.stack([p[:, 2], p[:, 2], p[:, 3]], axis=1))
    centres = np.stack([p[:, 0], p[:, 1], np.zeros(len(p))], axis=1)
    yaws = np.array([_facing_yaw(a, b, room_yaw, q) for (a, b), q in zip(p[:, :2], quarters, strict=True)])
    pred = _boxes(camera, pose, centres, sizes, yaws)
    priors = np.concatenate([p[:, 2] / sig, p[:, 3] / sig])
    camera_prior = [(x[0] - DEFAULT_CAMERA_HEIGHT) / CAMERA_HEIGHT_SIGMA, (x[1] - math.radians(DEFAULT_PITCH_DEG)) / math.radians(45.0)]
    return np.concatenate([((pred - obs) * weights).ravel(), priors, camera_prior])


def _room_direction(image: SceneImage, camera: Camera, pose: CameraPose) -> tuple[float, float] | None:
    """The room's horizontal direction modulo 90 degrees (radians in [-pi/4, pi/4)) from the
    photograph's straight edges below the horizon, carried onto the floor plane (a horizontal
    edge keeps its direction there at any height; vertical edges, which fall onto lines through
    the camera's foot, are left out); and the share of edge length that agrees within 5 degrees.
    ``None`` without OpenCV or without enough edges."""
    try:
        import cv2
    except ImportError:
        return None
    gray = cv2.cvtColor(image.pixels, cv2.COLOR_RGB2GRAY)
    scale = min(1.0, 1024.0 / max(gray.shape))
    if scale < 1.0:
        gray = cv2.resize(gray, (round(gray.shape[1] * scale), round(gray.shape[0] * scale)), interpolation=cv2.INTER_AREA)
    edges = cv2.Canny(gray, 50, 150)
    lines = cv2.HoughLinesP(edges, 1, np.pi / 360, threshold=50, minLineLength=max(20, int(0.05 * gray.shape[1])), maxLineGap=4)
    if lines is None:
        return None
    angles: list[float] = []
    weights: list[float] = []
    for x1, y1, x2, y2 in np.asarray(lines, dtype=np.float64).reshape(-1, 4) / scale:
        a = pose.floor_ray(camera, float(x1), float(y1))
        b = pose.floor_ray(camera, float(x2), float(y2))
        if a is None or b is None:
            continue
        d = b[:2] - a[:2]
        length = float(np.hypot(*d))
        if length < 0.05 or max(np.hypot(*a[:2]), np.hypot(*b[:2])) > 12.0:
            continue
        # distance from the camera's foot to the line: ~0 for the image of a vertical edge
        dist = abs(float(a[0] * d[1] - a[1] * d[0])) / length
        if dist < 0.3:
            continue
        angles.append(math.atan2(d[1], d[0]))
        weights.append(math.hypot(float(x2 - x1), float(y2 - y1)))
    if len(angles) < 3:
        return None
    ang = np.asarray(angles)
    w = np.asarray(weights)
    # vote modulo 90 degrees: 4 x the angle on the circle, 1-degree bins smoothed over 3 degrees
    bins = np.zeros(90)
    idx = np.floor(np.mod(np.degrees(ang), 90.0)).astype(int) % 90
    np.add.at(bins, idx, w)
    smooth = sum(np.roll(bins, k) for k in range(-3, 4))
    peak = int(np.argmax(smooth))
    near = np.abs(np.mod(np.degrees(ang) - peak + 45.0, 90.0) - 45.0) <= 5.0
    share = float(w[near].sum() / w.sum())
    if share < 0.25:
        return None
    c = float(np.sum(w[near] * np.cos(4 * ang[near])))
    s = float(np.sum(w[near] * np.sin(4 * ang[near])))
    return math.remainder(math.atan2(s, c) / 4.0, math.pi / 2), share

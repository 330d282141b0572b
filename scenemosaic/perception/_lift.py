"""The offline reconstructor: single-view metrology from boxes and category sizes.

What it assumes (``docs/perception.md``): a pinhole camera without roll whose focal length is
known (EXIF or the default field of view); a flat floor; every floor object an upright box
standing on it, with the size of its category (the median of the ProcTHOR asset database's
boxes) up to a scale of its footprint and one of its height, each with a log-normal prior;
the room's horizontal directions and the camera's pitch read from the photograph's straight
edges (:func:`_vertical_votes`, :func:`_horizontal_votes`). One least-squares fit finds the
camera's height and pitch, the picture's shared furniture scale (:data:`FURNITURE_SCALE_SIGMA`)
and every floor object's place and size from the box edges; each
floor object's heading is then chosen from the evidence (``_headings.py``: the box, the walls,
what it belongs to); objects on the wall, the ceiling or other furniture follow with the
camera fixed, hung on the walls seen behind wall furniture and over the beds and tables in view
(or the table a dining group's chairs point at, when the picture leaves it out). The result is a coarse prior: sizes within
tens of percent, places within a few decimetres (see the tests), which the later stages
(room, support, physics, the critic) correct.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import structlog

from scenemosaic.perception._headings import (
    HeadingChoice,
    HeadingItem,
    bed_nightstands,
    choose_headings,
    front_of,
    furniture_role,
    half_extent,
    nearest_item,
)
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
CAMERA_HEIGHT_SIGMA = 0.4
"""Standard deviation (metres) of the camera height's prior: a weak term (a photograph may be
taken seated or from a step), so the objects' sizes, not the prior, set the scale."""
PITCH_SD_FLOOR_DEG = 0.3
"""The least standard deviation (degrees) given to the pitch measured from vertical lines."""
DEFAULT_CEILING_HEIGHT = 2.7
"""Height (metres) of the ceiling a ceiling object hangs from when the picture does not show it:
a common residential storey (2.4-3.0 m)."""
CEILING_HEIGHT_SIGMA = 0.3
"""Standard deviation (metres) of that default."""
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
_SIGMA_HANGING = 0.6
"""Log-scale standard deviation of a hanging object's size."""
FURNITURE_SCALE_SIGMA = 0.2
"""Log-scale standard deviation of the picture's shared furniture scale: how far one room's
furniture as a whole may run larger or smaller than the catalogue (a maker's, an era's, a
market's sizes). Every floor object's own scale is a deviation from it (:data:`_SIGMA_KNOWN`)."""
PINNED_SCALE_SIGMA = 1e-4
"""The shared scale's standard deviation in the first floor fit, which the room's lines are read
against: pinned to the catalogue, so the lines see the same first pose whatever the furniture."""


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
    room's direction from the photograph's straight edges (needs OpenCV; else the camera's axis).
    ``camera_height``: the camera's height above the floor when known (metres): the floor fit's
    room is scaled to it before anything is placed on, over or against the floor pieces, so a
    lamp hangs from the ceiling's height in metres. The fit itself keeps the weak prior: held in
    it, the catalogue sizes pull against the true height through the pitch (one render came out
    tilted 5 degrees)."""

    name = "box-lifter"

    def __init__(self, *, room_lines: bool = True, camera_height: float | None = None) -> None:
        self.room_lines = room_lines
        self.camera_height = camera_height

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

        segments = _line_segments(image) if self.room_lines else None
        vertical = _vertical_votes(segments, camera) if segments is not None else ([], [])
        measured_pitch = _pitch_from_votes(*vertical)
        pitch_prior = (math.radians(DEFAULT_PITCH_DEG), math.radians(45.0))
        if measured_pitch is not None:
            pitch_prior = (measured_pitch[0], max(measured_pitch[1], math.radians(PITCH_SD_FLOOR_DEG)))
            report["vertical_lines_pitch_deg"] = round(math.degrees(measured_pitch[0]), 2)
            report["vertical_lines_pitch_sd_deg"] = round(math.degrees(measured_pitch[1]), 3)
            report["vertical_lines"] = measured_pitch[2]

        height_prior = (DEFAULT_CAMERA_HEIGHT, CAMERA_HEIGHT_SIGMA)

        def solve(x0: FloatArray, room_yaw: float, quarters: list[int], scale_sd: float) -> tuple[float, FloatArray]:
            result = least_squares(
                _floor_residuals,
                x0,
                args=(camera, obs, base, sig, weights, room_yaw, quarters, pitch_prior, height_prior, scale_sd),
                bounds=_floor_bounds(len(floor)),
                x_scale="jac",
                max_nfev=400,
            )
            return float(result.cost), result.x

        def fit_floor(room_yaw: float, scale_sd: float) -> tuple[CameraPose, FloatArray, float, list[int], FloatArray]:
            if not floor:
                return CameraPose(DEFAULT_CAMERA_HEIGHT, pitch_prior[0]), np.zeros((0, 4)), 0.0, [], np.zeros(3)
            quarters = [0] * len(floor)
            best: tuple[float, FloatArray] | None = None
            starts = (5.0, 20.0, 35.0) if measured_pitch is None else (math.degrees(measured_pitch[0]),)
            for h0 in (1.2, 1.6, 2.0):
                for p0 in starts:
                    pose0 = CameraPose(h0, math.radians(p0))
                    x0 = [h0, math.radians(p0), 0.0]
                    for o, size in zip(floor, base, strict=True):
                        x0 += [*self._init_xy(camera, pose0, o.detection.box, size), 0.0, 0.0]
                    found = solve(np.array(x0), room_yaw, quarters, scale_sd)
                    if best is None or found[0] < best[0]:
                        best = found
            assert best is not None
            # each object may show its side rather than its front: keep the turn that fits better
            for i in range(len(floor)):
                trial = list(quarters)
                trial[i] = 1 - trial[i]
                found = solve(best[1], room_yaw, trial, scale_sd)
                if found[0] < best[0] - 1e-6:
                    best, quarters = found, trial
            x = best[1]
            params = x[3:].reshape(-1, 4).copy()
            params[:, 2:] += x[2]  # each object's scales, the picture's shared one included
            return CameraPose(float(x[0]), float(x[1])), params, best[0], quarters, x

        room_yaw = 0.0
        # the first fit, which the room's lines are read against, keeps the catalogue's scale
        pose, params, cost, quarters, x_fit = fit_floor(room_yaw, PINNED_SCALE_SIGMA)
        if self.room_lines:
            measured = _room_direction(image, camera, pose)
            if measured is not None:
                room_yaw, share = measured
                report["room_direction_deg"] = round(math.degrees(room_yaw), 2)
                report["room_direction_support"] = round(share, 3)
                if segments is not None:  # the room's horizontal edges vote on the pitch too
                    horizontal = _horizontal_votes(segments, camera, room_yaw, pose.pitch)
                    both = _pitch_from_votes(vertical[0] + horizontal[0], vertical[1] + horizontal[1])
                    if both is not None:
                        report["lines_pitch_deg"] = round(math.degrees(both[0]), 2)
                        report["lines_pitch_sd_deg"] = round(math.degrees(both[1]), 3)
                        measured_pitch = both
                        pitch_prior = (both[0], max(both[1], math.radians(PITCH_SD_FLOOR_DEG)))
        # then again in the room's frame, with the pitch the lines read and the shared scale free
        pose, params, cost, quarters, x_fit = fit_floor(room_yaw, FURNITURE_SCALE_SIGMA)
        report["camera_height_m"] = round(pose.height, 3)
        report["camera_pitch_deg"] = round(math.degrees(pose.pitch), 2)
        report["floor_fit_cost"] = round(cost, 3)
        shared = float(x_fit[2])
        report["furniture_scale"] = round(math.exp(shared), 3)
        if floor:
            sd = _fit_sd(
                x_fit, lambda x: _floor_residuals(x, camera, obs, base, sig, weights, room_yaw, quarters, pitch_prior, height_prior, FURNITURE_SCALE_SIGMA)
            )
            report["camera_height_sd_m"] = round(float(sd[0]), 3)
            report["camera_pitch_sd_deg"] = round(math.degrees(float(sd[1])), 3)
        if self.camera_height is not None and floor:
            # a known height sets the scale: the fitted room is scaled about the camera to it (the
            # boxes project the same), before the headings and what rests, hangs or stands on it
            k = float(self.camera_height) / pose.height
            pose = CameraPose(float(self.camera_height), pose.pitch)
            params[:, :2] *= k
            params[:, 2:] += math.log(k)
            shared += math.log(k)
            report["scale_from_camera_height"] = round(k, 4)

        lifted: list[LiftedObject] = []
        placed: dict[str, tuple[FloatArray, FloatArray]] = {}  # id -> (bottom centre, size), floor frame
        yaws: dict[str, float] = {}
        refits: dict[tuple[int, int], tuple[float, FloatArray]] = {}

        def refit(i: int, k: int) -> tuple[float, FloatArray, FloatArray]:
            # a box turned by a half turn projects the same: two fits per object
            if (i, k % 2) not in refits:
                yaw = room_yaw + (k % 2) * math.pi / 2
                cost, p = _refit_floor_object(camera, pose, obs[i], base[i], float(sig[i]), weights[i], yaw, params[i], shared)
                if segments is not None and _flat_topped(floor[i].detection.category):
                    size = base[i] * np.exp([p[2], p[2], p[3]])
                    support = _top_edge_support(segments, camera, pose, np.array([p[0], p[1], 0.0]), size, yaw)
                    cost += TOP_EDGE_WEIGHT * (1.0 - support)
                refits[i, k % 2] = (cost, p)
            cost, p = refits[i, k % 2]
            return cost, np.array([p[0], p[1], 0.0]), base[i] * np.exp([p[2], p[2], p[3]])

        items = [
            HeadingItem(o.detection.id, o.detection.category, np.array([p[0], p[1], 0.0]), base[i] * np.exp([p[2], p[2], p[3]]))
            for i, (o, p) in enumerate(zip(floor, params, strict=True))
        ]
        headings = choose_headings(items, room_yaw, refit)
        report["headings"] = {oid: h.reason for oid, h in headings.items()}
        quarter = [headings[o.detection.id].quarter % 2 for o in floor]
        chosen = [refits[i, quarter[i]][1] if (i, quarter[i]) in refits else params[i] for i in range(len(floor))]
        flush, seats = _held_together(floor, items, headings)
        if flush or seats:  # one refit of the pieces that hold each other in place
            group = sorted({k for pair in (*flush, *seats) for k in pair})
            together = _refit_group(
                camera,
                pose,
                (obs[group], base[group], sig[group], weights[group]),
                [headings[floor[k].detection.id].yaw for k in group],
                [chosen[k] for k in group],
                shared,
                [(group.index(a), group.index(b)) for a, b in flush],
                [(group.index(a), group.index(b)) for a, b in seats],
            )
            for k, p in zip(group, together, strict=True):
                chosen[k] = p
            held: dict[str, list[str]] = {}  # a bed by its nightstands, a table by its chairs
            for piece, holder in [*flush, *((t, c) for c, t in seats)]:
                held.setdefault(floor[piece].detection.id, []).append(floor[holder].detection.id)
            report["held_by"] = held
        for i, o in enumerate(floor):
            h = headings[o.detection.id]
            p = chosen[i]
            size = np.asarray(priors[o.detection.id][0]) * np.exp([p[2], p[2], p[3]])
            centre = np.array([p[0], p[1], 0.0])
            placed[o.detection.id] = (centre, size)
            yaws[o.detection.id] = h.yaw
            lifted.append(self._lifted(o, pose, centre, size, yaws[o.detection.id]))
        ceiling = (DEFAULT_CEILING_HEIGHT, CEILING_HEIGHT_SIGMA)
        report["ceiling_height_m"] = {"value": ceiling[0], "sd": ceiling[1], "source": "default"}
        rests: dict[str, str] = {}
        on_walls: dict[str, str] = {}
        hangs_over: dict[str, str] = {}
        walls = _walls_behind(floor, placed, yaws)
        anchors = [  # what a lamp hangs over: a bed, a table standing free (not a desk against a wall)
            (o.detection.id, placed[o.detection.id][0][:2])
            for o in floor
            if furniture_role(o.detection.category) == "bed"
            or (furniture_role(o.detection.category) in HANG_OVER_ROLES and not traits(o.detection.category).against_wall)
        ]
        if not any(furniture_role(o.detection.category) == "table" for o in floor):
            anchors += _tables_out_of_view(floor, placed, yaws)
        category_of = {o.detection.id: o.detection.category for o in objects}
        for o in sorted(others, key=lambda s: _support_depth(s, others)):  # supports before what they hold
            support = None if o.parent is None or o.parent not in placed else (*placed[o.parent], yaws[o.parent])
            centre, size, rest, wall_yaw, wall_id = self._fit_single(
                camera, pose, o, priors[o.detection.id], placed, room_yaw, ceiling, walls, anchors, support,
                shelved=o.parent is not None and _has_shelves(category_of[o.parent]),
                raised=_support_may_hide(o, objects, camera),
            )  # fmt: skip
            if wall_id is not None and rest == "wall":
                on_walls[o.detection.id] = wall_id
            elif wall_id is not None:
                hangs_over[o.detection.id] = wall_id
            if rest in ("on", "in") and o.parent is not None:  # what rests on a top or a shelf stands over it
                centre = _onto(centre, size, *placed[o.parent], yaws[o.parent])
            placed[o.detection.id] = (centre, size)
            if rest in ("on", "in") and o.parent is not None:  # it faces where its support faces (a laptop on a desk)
                yaws[o.detection.id] = yaws[o.parent]
                report["headings"][o.detection.id] = f"as {o.parent}"  # type: ignore[index]
            elif wall_yaw is not None:  # it faces away from its wall
                yaws[o.detection.id] = wall_yaw
                report["headings"][o.detection.id] = f"on the wall behind {wall_id}"  # type: ignore[index]
            else:
                yaws[o.detection.id] = _facing_yaw(centre[0], centre[1], room_yaw)
            rests[o.detection.id] = rest
            lifted.append(self._lifted(o, pose, centre, size, yaws[o.detection.id], rest))
        report["resting"] = rests
        report["on_walls"] = on_walls
        report["hangs_over"] = hangs_over
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
        ceiling: tuple[float, float] = (DEFAULT_CEILING_HEIGHT, CEILING_HEIGHT_SIGMA),
        walls: Sequence[tuple[str, FloatArray, float]] = (),
        anchors: Sequence[tuple[str, FloatArray]] = (),
        support: tuple[FloatArray, FloatArray, float] | None = None,
        shelved: bool = False,
        raised: bool = True,
    ) -> tuple[FloatArray, FloatArray, str, float | None, str | None]:
        """An object off the floor fit, the camera fixed: its place and size from its box, under
        each hypothesis of where it rests (:func:`_hypotheses`); the one costing least wins.
        ``ceiling``: the ceiling's height (mean, sd, metres) a hanging object's top is held to.
        ``walls``: walls seen as the backs of wall furniture (id, outward unit normal, offset
        along it): an object that may hang on a wall is fitted against each too, and hung on
        the one fitting best when that costs at most :data:`WALL_SNAP_COST` more than the
        cheapest hypothesis. ``anchors``: the tables and beds in view, or a table out of view that
        chairs point at (:func:`_tables_out_of_view`) (id, floor-frame middle): a
        hanging object is fitted over each too, and hangs over the one fitting best when that
        costs at most :data:`HANG_OVER_COST` more than hanging free (a pendant over its table).
        ``support``: the bottom centre, size and yaw of the piece it rests on in view: the fit
        keeps its footprint over that piece's (:data:`FOOTPRINT_SD` beyond it), on its top or,
        when ``shelved`` (the piece is open to the front, :func:`_has_shelves`), on a shelf
        inside (``in``, its height free below the top). ``raised``: whether furniture out of
        view may hold it (:func:`_support_may_hide`).
        Returns its bottom centre, size, where it rests, its yaw when a wall sets it, and the id
        of the wall furniture or the piece it hangs over."""
        from scipy.optimize import least_squares

        base = np.asarray(prior[0])
        sig = _SIGMA_KNOWN if prior[1] else _SIGMA_UNKNOWN
        if o.placement == "ceiling":  # a lamp's cord and shade vary far more than furniture
            sig = max(sig, _SIGMA_HANGING)
        box = np.asarray(o.detection.box, dtype=np.float64)
        weights = _edge_weights(box[None, :], camera)[0]
        # first guess: at the depth where the prior's width fills the box
        width_px = max(box[2] - box[0], 2.0)
        depth = float(np.clip(camera.fx * max(base[0], base[1]) / width_px, 0.3, 20.0))
        ray = pose.camera_from_floor.T @ camera.ray((box[0] + box[2]) / 2, (box[1] + box[3]) / 2)
        guess = (ray / ray[1] * depth if ray[1] > 1e-3 else ray * depth) + np.array([0.0, 0.0, pose.height])
        best: tuple[float, FloatArray, FloatArray, str] | None = None
        snapped: tuple[float, FloatArray, FloatArray, float, str] | None = None
        over: tuple[float, FloatArray, FloatArray, str] | None = None
        for name, z_mean, z_sigma in _hypotheses(o, placed, ceiling, shelved=support is not None and shelved, raised=raised):
            hanging = name == "ceiling"  # x[4] is then the ceiling's height, the top's place
            resting = support if name in ("on", "in") else None

            def residuals(
                x: FloatArray, z_mean: float = z_mean, z_sigma: float | None = z_sigma, hanging: bool = hanging, resting: Any = resting
            ) -> FloatArray:
                size = base * np.exp([x[2], x[2], x[3]])
                z = z_mean if z_sigma == 0.0 else (x[4] - size[2] if hanging else x[4])
                yaw = _facing_yaw(x[0], x[1], room_yaw)
                pred = _boxes(camera, pose, np.array([[x[0], x[1], z]]), size[None, :], np.array([yaw]))[0]
                extra = [] if not z_sigma else [((x[4] if hanging else z) - z_mean) / z_sigma]
                if resting is not None:  # its footprint over its support's; on a shelf, below its top
                    beyond = np.array([x[0], x[1], z]) - _onto(np.array([x[0], x[1], z]), size, *resting)
                    extra = [*extra, *(beyond[:2] / FOOTPRINT_SD)]
                    if z_sigma is None:
                        top = float(resting[0][2] + resting[1][2])
                        extra += [max(0.0, z + size[2] - top) / FOOTPRINT_SD, max(0.0, resting[0][2] - z) / FOOTPRINT_SD]
                return np.concatenate([(pred - box) * weights, [x[2] / sig, x[3] / sig], extra])

            z0 = z_mean if z_sigma is not None or resting is not None else max(0.0, float(guess[2] - base[2] / 2))
            start_xy = guess[:2] if resting is None else resting[0][:2]
            x0 = np.array([start_xy[0], start_xy[1], 0.0, 0.0] + ([] if z_sigma == 0.0 else [z0]))
            if hanging:  # start where the box's lower edge meets the ceiling's prior height less the lamp's
                x0[:2] = self._hanging_start(camera, pose, box, z_mean - base[2], guess)
            result = least_squares(residuals, x0, x_scale="jac", max_nfev=300)
            x = result.x
            z = z_mean if z_sigma == 0.0 else max(0.0, float(x[4]))
            if hanging:
                z = max(0.0, float(x[4] - base[2] * math.exp(x[3])))
            if best is None or result.cost < best[0]:
                best = (float(result.cost), np.array([x[0], x[1], z]), base * np.exp([x[2], x[2], x[3]]), name)
            if name == "wall" and walls:
                snapped = self._on_walls(camera, pose, box, weights, base, sig, (z_mean, z_sigma), x, walls)
            for anchor_id, anchor_xy in anchors if hanging else ():
                # hanging over a table or a bed: its place pulled toward the piece's middle
                def pulled(x: FloatArray, a: FloatArray = anchor_xy) -> FloatArray:
                    return np.concatenate([residuals(x), (x[:2] - a) / HANG_OVER_SD])

                start = np.array([anchor_xy[0], anchor_xy[1], x[2], x[3], x[4]])
                fit = least_squares(pulled, start, x_scale="jac", max_nfev=300)
                if over is None or fit.cost < over[0]:
                    xo = fit.x
                    bottom = max(0.0, float(xo[4] - base[2] * math.exp(xo[3])))
                    over = (float(fit.cost), np.array([xo[0], xo[1], bottom]), base * np.exp([xo[2], xo[2], xo[3]]), anchor_id)
        assert best is not None
        if snapped is not None and snapped[0] <= best[0] + WALL_SNAP_COST:
            _cost, centre, size, yaw, wall_id = snapped
            return centre, size, "wall", yaw, wall_id
        if over is not None and over[0] <= best[0] + HANG_OVER_COST:
            return over[1], over[2], "ceiling", None, over[3]
        return best[1], best[2], best[3], None, None

    @staticmethod
    def _on_walls(
        camera: Camera,
        pose: CameraPose,
        box: FloatArray,
        weights: FloatArray,
        base: FloatArray,
        sig: float,
        height_prior: tuple[float, float | None],
        x0: FloatArray,
        walls: Sequence[tuple[str, FloatArray, float]],
    ) -> tuple[float, FloatArray, FloatArray, float, str] | None:
        """The best fit of a wall object with its back on one of ``walls``, facing away from it:
        (cost, bottom centre, size, yaw, the wall's id); ``None`` when no wall lies ahead of it."""
        from scipy.optimize import least_squares

        z_mean, z_sigma = height_prior
        best: tuple[float, FloatArray, FloatArray, float, str] | None = None
        for wall_id, normal, offset in walls:
            yaw = math.atan2(normal[0], -normal[1]) + math.pi  # front (local -Y) along -normal
            yaw = math.remainder(yaw, 2 * math.pi)

            def residuals(x: FloatArray, normal: FloatArray = normal, offset: float = offset, yaw: float = yaw) -> FloatArray:
                size = base * np.exp([x[2], x[2], x[3]])
                pred = _boxes(camera, pose, np.array([[x[0], x[1], x[4]]]), size[None, :], np.array([yaw]))[0]
                back = float(np.array([x[0], x[1]]) @ normal) + size[1] / 2
                z_term = [] if not z_sigma else [(x[4] - z_mean) / z_sigma]
                return np.concatenate([(pred - box) * weights, [x[2] / sig, x[3] / sig, (back - offset) / WALL_SNAP_SD], z_term])

            start = np.array([x0[0], x0[1], x0[2], x0[3], x0[4] if len(x0) > 4 else z_mean])
            result = least_squares(residuals, start, x_scale="jac", max_nfev=300)
            x = result.x
            if float(np.array([x[0], x[1]]) @ normal) <= 0.0 or x[1] <= 0.0:
                continue  # a wall behind the camera
            if best is None or result.cost < best[0]:
                best = (float(result.cost), np.array([x[0], x[1], max(0.0, float(x[4]))]), base * np.exp([x[2], x[2], x[3]]), yaw, wall_id)
        return best

    @staticmethod
    def _hanging_start(camera: Camera, pose: CameraPose, box: FloatArray, bottom: float, guess: FloatArray) -> FloatArray:
        """Where the ray through the box's lower edge reaches the height ``bottom`` (floor frame XY)."""
        d = pose.camera_from_floor.T @ camera.ray((box[0] + box[2]) / 2, box[3])
        rise = bottom - pose.height
        if d[2] * rise <= 1e-6:
            out: FloatArray = np.asarray(guess[:2], dtype=np.float64)
            return out
        t = rise / d[2]
        return np.array([d[0] * t, d[1] * t])

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


MAY_HANG = frozenset({"television", "mirror", "wall_clock", "clock"})
"""Categories that stand on furniture or hang on a wall alike (ProcTHOR's televisions all stand,
so its priors alone would never hang one)."""
WALL_SNAP_COST = 4.0
"""How much more (chi-square / 2) an object on a wall may cost fitted against a wall seen behind
wall furniture than fitted free, and still be hung on that wall."""
HANG_OVER_ROLES = frozenset({"table", "coffee_table", "bed"})
"""What a ceiling lamp in view may hang over (:func:`~scenemosaic.perception._headings.furniture_role`)."""
HANG_OVER_COST = 4.0
"""How much more (chi-square / 2) a hanging object may cost fitted over a table or bed than
fitted free, and still be hung over it."""
HANG_OVER_SD = 0.35
"""Standard deviation (metres) of a lamp's place about the middle of what it hangs over."""
CHAIR_TO_TABLE = 0.75
"""Metres from a dining chair's middle to the middle of the table it faces, measured along its
front: half a seat's depth and half a dining table's width (0.3 + 0.45)."""


def _tables_out_of_view(
    floor: Sequence[SeenObject], placed: dict[str, tuple[FloatArray, FloatArray]], yaws: dict[str, float]
) -> list[tuple[str, FloatArray]]:
    """Where the table of a dining group stands when the picture does not show it: every chair
    of the group (two or more chairs, each within 2 m of another) points at it, so it is the mean
    of the points :data:`CHAIR_TO_TABLE` ahead of each chair. One anchor (its id, floor-frame
    middle) per group, named after its first chair; what a lamp hangs over."""
    chairs = [o.detection.id for o in floor if furniture_role(o.detection.category) == "chair"]
    groups: list[list[str]] = []
    for cid in chairs:
        near = [g for g in groups if any(float(np.linalg.norm(placed[cid][0][:2] - placed[m][0][:2])) < 2.0 for m in g)]
        merged = [cid] + [m for g in near for m in g]
        groups = [g for g in groups if g not in near] + [merged]
    out: list[tuple[str, FloatArray]] = []
    for g in groups:
        if len(g) < 2:
            continue
        ahead = [placed[m][0][:2] + CHAIR_TO_TABLE * front_of(yaws[m]) for m in g]
        out.append((f"the table of {sorted(g)[0]} (out of view)", np.mean(ahead, axis=0)))
    return out


WALL_SNAP_SD = 0.05
"""Standard deviation (metres) of a wall object's back against its wall."""


TOP_EDGE_WEIGHT = 20.0
"""Cost (chi-square / 2) of a flat top none of whose projected edges the picture's straight
segments trace, against one whose edges they all trace (:func:`_top_edge_support`)."""
TOP_EDGE_PIXELS = 3.0
"""How far (pixels of the 1024-pixel picture the segments come from) a segment may lie from a
projected edge and still trace it."""


def _flat_topped(category: str) -> bool:
    """Whether the top of a category's box is the piece's own flat top (a table's, a desk's, a
    nightstand's), so its four edges are lines the picture shows."""
    return furniture_role(category) in ("table", "coffee_table", "nightstand") or traits(category).table


def _top_edge_support(segments: FloatArray, camera: Camera, pose: CameraPose, centre: FloatArray, size: FloatArray, yaw: float) -> float:
    """The share (0-1, by length) of the four top edges of an upright box, projected into the
    picture, that the picture's straight segments trace: points along each edge within
    :data:`TOP_EDGE_PIXELS` of a segment running its way (within 6 degrees).

    A box alone does not tell a table's long axis (a smaller table across the view and a larger
    one along it fill the same box); the outline of its top does, and a table top's edges are
    among the longest straight lines of a room."""
    c, s = math.cos(yaw), math.sin(yaw)
    half = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]) * size[:2]
    corners = np.column_stack([half @ np.array([[c, s], [-s, c]]) + centre[:2], np.full(4, size[2])])
    cam = pose.to_camera(corners)
    if np.any(cam[:, 2] < 0.1) or len(segments) == 0:
        return 0.0
    uv = np.column_stack([camera.fx * cam[:, 0] / cam[:, 2] + camera.cx, camera.fy * cam[:, 1] / cam[:, 2] + camera.cy])
    tol = TOP_EDGE_PIXELS * max(camera.width, camera.height) / 1024.0
    a, b = segments[:, :2], segments[:, 2:]
    seg_dir = b - a
    seg_len = np.maximum(np.hypot(seg_dir[:, 0], seg_dir[:, 1]), 1e-9)
    seg_unit = seg_dir / seg_len[:, None]
    traced = total = 0.0
    for k in range(4):
        p, q = uv[k], uv[(k + 1) % 4]
        length = float(np.hypot(*(q - p)))
        if length < 2.0:
            continue
        along = (q - p) / length
        aligned = np.abs(seg_unit @ along) > math.cos(math.radians(6.0))
        inside = 0
        points = p + np.outer(np.linspace(0.0, 1.0, 24), q - p)
        visible = (points[:, 0] >= 0) & (points[:, 0] < camera.width) & (points[:, 1] >= 0) & (points[:, 1] < camera.height)
        for pt in points[visible]:
            t = np.clip(np.einsum("ij,ij->i", pt - a, seg_unit), 0.0, seg_len)
            dist = np.hypot(*(a + seg_unit * t[:, None] - pt).T)
            inside += bool(np.any(aligned & (dist <= tol)))
        n_visible = int(visible.sum())
        if n_visible:
            traced += length * inside / n_visible
            total += length
    return traced / total if total > 0 else 0.0


def _walls_behind(
    floor: Sequence[SeenObject], placed: dict[str, tuple[FloatArray, FloatArray]], yaws: dict[str, float]
) -> list[tuple[str, FloatArray, float]]:
    """The walls the picture shows through its wall furniture: behind each floor object that
    stands against a wall (``against_wall``), the line its back lies on, as (its id, the outward
    unit normal, the line's offset along it) in the floor frame."""
    out: list[tuple[str, FloatArray, float]] = []
    for o in floor:
        if not traits(o.detection.category).against_wall:
            continue
        centre, size = placed[o.detection.id]
        yaw = yaws[o.detection.id]
        normal = -front_of(yaw)  # its back
        out.append((o.detection.id, normal, float(centre[:2] @ normal) + float(size[1]) / 2))
    return out


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


FOOTPRINT_SD = 0.05
"""How far (metres, one standard deviation) an object seen resting on a piece may stand beyond
that piece's top, or a shelf's inside, in the fit."""


def _has_shelves(category: str) -> bool:
    """Whether a piece is open to the front (a bookshelf, a shelving unit, a sideboard), so what
    rests on it may stand on a shelf inside rather than on its top."""
    t = traits(category)
    return t.contains and t.opening == "front"


def _support_may_hide(o: SeenObject, objects: Sequence[SeenObject], camera: Camera) -> bool:
    """Whether a piece of furniture holding ``o`` up could be missing from the picture: ``o``'s
    box is cut by the picture's lower border, or another object's box covers the rows just below
    its lower edge over at least a third of its width (it may stand in front of the support).
    Otherwise the top that held it would show right under it, and nothing there was seen."""
    x0, _y0, x1, y1 = o.detection.box
    if y1 >= camera.height - 1.5:
        return True
    reach = y1 + 0.02 * camera.height
    for other in objects:
        if other.detection.id == o.detection.id:
            continue
        b0, c0, b1, c1 = other.detection.box
        overlap = min(x1, b1) - max(x0, b0)
        if overlap >= (x1 - x0) / 3 and c0 <= reach and c1 > y1:
            return True
    return False


def _hypotheses(
    o: SeenObject,
    placed: dict[str, tuple[FloatArray, FloatArray]],
    ceiling: tuple[float, float] = (0.0, 0.0),
    *,
    shelved: bool = False,
    raised: bool = True,
) -> list[tuple[str, float, float | None]]:
    """Where an object off the floor fit may rest, as (name, bottom height, its standard
    deviation): 0 fixes the height, ``None`` leaves it free (the height is then where the fit
    starts: mid-shelf for ``in``). On its support's top when it has one in view, or
    (``shelved``: the support is open shelving) on a shelf inside it; on a wall or the ceiling
    when the inventory says so; else, for a small object resting on nothing in view:
    on the floor, on furniture out of view (:data:`RAISED_HEIGHT`; only when ``raised``: such
    furniture could be hidden, :func:`_support_may_hide`), or on a wall (:data:`WALL_HEIGHT`) when
    its type may hang there."""
    if o.parent is not None and o.parent in placed:
        pc, ps = placed[o.parent]
        top = float(pc[2] + ps[2])
        return [("on", top, 0.0)] + ([("in", top / 2, None)] if shelved else [])
    if o.placement == "wall":
        return [("wall", *WALL_HEIGHT)]
    if o.placement == "ceiling":  # its top at the ceiling: (name, ceiling height, its sd)
        return [("ceiling", *(ceiling if ceiling[1] > 0 else (DEFAULT_CEILING_HEIGHT, CEILING_HEIGHT_SIGMA)))]
    out: list[tuple[str, float, float | None]] = [("floor", 0.0, 0.0)]
    if raised:
        out.append(("raised", *RAISED_HEIGHT))
    kind = thor_type(o.detection.category)
    may_hang = normalize_category(o.detection.category) in MAY_HANG
    if traits(o.detection.category).placement == "wall" or may_hang or (kind is not None and kind in load_priors().wall):
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
    lo = [0.3, math.radians(-30.0), -1.0] + [-30.0, 0.2, -1.5, -1.5] * n
    hi = [4.0, math.radians(80.0), 1.0] + [30.0, 30.0, 1.5, 1.5] * n
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
    pitch_prior: tuple[float, float] = (math.radians(DEFAULT_PITCH_DEG), math.radians(45.0)),
    height_prior: tuple[float, float] = (DEFAULT_CAMERA_HEIGHT, CAMERA_HEIGHT_SIGMA),
    scale_sd: float = FURNITURE_SCALE_SIGMA,
) -> FloatArray:
    """Whitened residuals of the floor fit. ``x``: the camera's height and pitch, the picture's
    shared log furniture scale, then per floor object its place (x, y) and its own log footprint
    and height scales on top of the shared one."""
    pose = CameraPose(float(x[0]), float(x[1]))
    shared = float(x[2])
    p = x[3:].reshape(-1, 4)
    sizes = base * np.exp(shared + np.stack([p[:, 2], p[:, 2], p[:, 3]], axis=1))
    centres = np.stack([p[:, 0], p[:, 1], np.zeros(len(p))], axis=1)
    yaws = np.array([_facing_yaw(a, b, room_yaw, q) for (a, b), q in zip(p[:, :2], quarters, strict=True)])
    pred = _boxes(camera, pose, centres, sizes, yaws)
    priors = np.concatenate([p[:, 2] / sig, p[:, 3] / sig])
    camera_prior = [(x[0] - height_prior[0]) / height_prior[1], (x[1] - pitch_prior[0]) / pitch_prior[1], shared / scale_sd]
    return np.concatenate([((pred - obs) * weights).ravel(), priors, camera_prior])


def _object_residuals(
    camera: Camera, pose: CameraPose, box: FloatArray, base: FloatArray, sig: float, weights: FloatArray, yaw: float, x: FloatArray, shared: float
) -> FloatArray:
    """Whitened residuals of one floor object turned by ``yaw``, the camera fixed: its projected
    box against ``box``, and its log scales ``x[2:]`` against the picture's shared one."""
    size = base * np.exp([x[2], x[2], x[3]])
    pred = _boxes(camera, pose, np.array([[x[0], x[1], 0.0]]), size[None, :], np.array([yaw]))[0]
    return np.concatenate([(pred - box) * weights, [(x[2] - shared) / sig, (x[3] - shared) / sig]])


def _refit_floor_object(
    camera: Camera,
    pose: CameraPose,
    box: FloatArray,
    base: FloatArray,
    sig: float,
    weights: FloatArray,
    yaw: float,
    x0: FloatArray,
    shared: float = 0.0,
) -> tuple[float, FloatArray]:
    """One floor object refitted under a fixed yaw, the camera fixed: the cost (chi-square / 2)
    and its (x, y, log footprint scale, log height scale)."""
    from scipy.optimize import least_squares

    def residuals(x: FloatArray) -> FloatArray:
        return _object_residuals(camera, pose, box, base, sig, weights, yaw, x, shared)

    lo, hi = np.array([-30.0, 0.2, -1.5, -1.5]), np.array([30.0, 30.0, 1.5, 1.5])
    result = least_squares(residuals, np.clip(np.asarray(x0, dtype=np.float64), lo + 1e-6, hi - 1e-6), bounds=(lo, hi), x_scale="jac", max_nfev=200)
    return float(result.cost), np.asarray(result.x)


FLUSH_SD = 0.05
"""Metres (one standard deviation) by which the backs of pieces standing against one wall (a
bed's head and its nightstands) may differ in the joint refit (:func:`_refit_group`)."""
SEAT_REACH = 1.0
"""Metres from a chair's middle to the table edge it faces, beyond which it is not taken as
sitting at that table (a chair set back against a wall, say) and is not refitted with it."""
SEAT_GAP = (0.2, 0.2)
"""Mean and standard deviation (metres) of the distance from a chair's middle to the edge of the
table it faces: half a seat's depth, less what is pushed under the top (:func:`_refit_group`)."""


def _held_together(
    floor: Sequence[SeenObject], items: Sequence[HeadingItem], headings: Mapping[str, HeadingChoice]
) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """The floor objects that hold each other in place, by index: ``(bed, nightstand)`` pairs
    whose backs stand on one wall (the nightstand turned as its bed), and ``(chair, table)``
    pairs, a chair facing the nearest table or desk, its middle within :data:`SEAT_REACH` of the
    edge it faces."""
    flush: list[tuple[int, int]] = []
    seats: list[tuple[int, int]] = []
    for i, o in enumerate(floor):
        role = furniture_role(o.detection.category)
        yaw = headings[o.detection.id].yaw
        if role == "bed":  # its nightstands turned as it is
            turned_as = [j for j in bed_nightstands(items, i) if abs(math.remainder(headings[floor[j].detection.id].yaw - yaw, 2 * math.pi)) < 1e-6]
            flush += [(i, j) for j in turned_as]
        elif role == "chair":
            table = nearest_item(items, i, ("table",))
            if table is not None:
                ahead = front_of(yaw)
                rel = items[table].centre[:2] - items[i].centre[:2]
                gap = float(rel @ ahead) - half_extent(items[table].size, headings[floor[table].detection.id].yaw, ahead)
                if float(rel @ ahead) > 0.0 and gap < SEAT_REACH:  # it faces the table, close enough to sit at it
                    seats.append((i, table))
    return flush, seats


def _refit_group(
    camera: Camera,
    pose: CameraPose,
    observed: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    yaws: Sequence[float],
    x0: Sequence[FloatArray],
    shared: float,
    flush: Sequence[tuple[int, int]],
    seats: Sequence[tuple[int, int]],
) -> list[FloatArray]:
    """Floor objects refitted together under fixed yaws, the camera fixed (``observed``: their
    boxes, catalogue sizes, scale sds and edge weights). Each ``(a, b)`` of ``flush`` has its
    backs on one line (``a``'s back direction, :data:`FLUSH_SD`): a bed cut by the picture's
    borders is held at its head by the nightstands beside it, whose boxes are often whole. Each
    ``(chair, table)`` of ``seats`` keeps the chair's middle :data:`SEAT_GAP` before the table's
    edge it faces, and level with that edge: a table cut by the borders is held by its chairs.
    Returns each object's (x, y, log footprint scale, log height scale)."""
    from scipy.optimize import least_squares

    boxes, bases, sigs, weights = observed
    n = len(x0)

    def half(p: FloatArray, k: int, direction: FloatArray) -> float:
        return half_extent(bases[k] * np.exp([p[2], p[2], p[3]]), yaws[k], direction)

    def residuals(x: FloatArray) -> FloatArray:
        ps = x.reshape(n, 4)
        out = [_object_residuals(camera, pose, boxes[k], bases[k], float(sigs[k]), weights[k], yaws[k], ps[k], shared) for k in range(n)]
        for a, b in flush:
            back = -front_of(yaws[a])
            gap = float((ps[a, :2] - ps[b, :2]) @ back) + half(ps[a], a, back) - half(ps[b], b, back)
            out.append(np.array([gap / FLUSH_SD]))
        for c, t in seats:
            ahead = front_of(yaws[c])
            side = np.array([-ahead[1], ahead[0]])
            rel = ps[t, :2] - ps[c, :2]
            gap = float(rel @ ahead) - half(ps[t], t, ahead)
            beyond = max(0.0, abs(float(rel @ side)) - half(ps[t], t, side))
            out.append(np.array([(gap - SEAT_GAP[0]) / SEAT_GAP[1], beyond / SEAT_GAP[1]]))
        return np.concatenate(out)

    lo, hi = np.tile([-30.0, 0.2, -1.5, -1.5], n), np.tile([30.0, 30.0, 1.5, 1.5], n)
    start = np.clip(np.concatenate([np.asarray(p, dtype=np.float64) for p in x0]), lo + 1e-6, hi - 1e-6)
    result = least_squares(residuals, start, bounds=(lo, hi), x_scale="jac", max_nfev=400)
    return [np.asarray(p) for p in result.x.reshape(n, 4)]


def _fit_sd(x: FloatArray, residuals: Callable[[FloatArray], FloatArray]) -> FloatArray:
    """Standard deviations of the floor fit's parameters at its solution: the residuals are
    whitened (divided by their sigmas), so the covariance is (J^T J)^-1, J by central differences."""
    step = 1e-5 * np.maximum(1.0, np.abs(x))
    cols = []
    for i in range(len(x)):
        dx = np.zeros_like(x)
        dx[i] = step[i]
        cols.append((residuals(x + dx) - residuals(x - dx)) / (2 * step[i]))
    jac = np.stack(cols, axis=1)
    cov = np.linalg.pinv(jac.T @ jac)
    out: FloatArray = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return out


def _gray(image: SceneImage) -> tuple[Any, np.ndarray, float] | None:
    """OpenCV, the photograph in grey at most 1024 px on its longer side, and that scale; ``None``
    without OpenCV. The one preparation of the edge readers."""
    try:
        import cv2
    except ImportError:
        return None
    gray = cv2.cvtColor(image.pixels, cv2.COLOR_RGB2GRAY)
    scale = min(1.0, 1024.0 / max(gray.shape))
    if scale < 1.0:
        gray = cv2.resize(gray, (round(gray.shape[1] * scale), round(gray.shape[0] * scale)), interpolation=cv2.INTER_AREA)
    return cv2, gray, scale


def _line_segments(image: SceneImage) -> FloatArray | None:
    """Straight segments (n, 4: x1, y1, x2, y2, the photograph's pixels) found by OpenCV's line
    segment detector (sub-pixel), at least 4 % of the longer side long; ``None`` without OpenCV."""
    prepared = _gray(image)
    if prepared is None:
        return None
    cv2, gray, scale = prepared
    found = cv2.createLineSegmentDetector().detect(gray)[0]
    if found is None:
        return np.zeros((0, 4))
    seg = np.asarray(found, dtype=np.float64).reshape(-1, 4) / scale
    keep = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]) >= 0.04 * max(image.width, image.height)
    out: FloatArray = seg[keep]
    return out


def _vertical_votes(segments: FloatArray, camera: Camera) -> tuple[list[float], list[float]]:
    """Pitch votes (radians) and weights of the segments within 20 degrees of the image's vertical.

    With no roll, every vertical edge of the room points at the vanishing point of the vertical,
    which lies on the image's centre column at a place set by the pitch alone:
    ``tan(pitch) = -l_y / l_z`` for the segment's line ``l`` in normalized coordinates. A vote
    weighs the segment's length times its distance from the centre column (a segment on that
    column says nothing of the pitch)."""
    pitches: list[float] = []
    weights: list[float] = []
    for x1, y1, x2, y2 in segments:
        if abs(x2 - x1) > 0.35 * abs(y2 - y1):
            continue
        off = abs((x1 + x2) / 2 - camera.cx) / camera.fx
        if off < 0.05:
            continue
        line = np.cross(camera.ray(float(x1), float(y1)), camera.ray(float(x2), float(y2)))
        pitches.append(math.remainder(math.atan2(-line[1], line[2]), math.pi))
        weights.append(math.hypot(x2 - x1, y2 - y1) * off)
    return pitches, weights


def _horizontal_votes(segments: FloatArray, camera: Camera, room_yaw: float, pitch0: float) -> tuple[list[float], list[float]]:
    """Pitch votes from the segments that run along the room's two horizontal directions.

    A horizontal direction at angle ``t`` in the floor frame is ``(cos t, -sin p sin t, cos p
    sin t)`` in the camera's, so the line ``l`` of its segment satisfies ``l_x cos t + sin t
    (-l_y sin p + l_z cos p) = 0``: one pitch per segment and direction. The root within 10
    degrees of ``pitch0`` is the vote; a segment whose floor direction is not one of the room's
    gives no root there, or a scattered one that the vote's peak leaves out."""
    pitches: list[float] = []
    weights: list[float] = []
    for x1, y1, x2, y2 in segments:
        if abs(x2 - x1) <= 0.35 * abs(y2 - y1):
            continue  # a vertical edge
        line = np.cross(camera.ray(float(x1), float(y1)), camera.ray(float(x2), float(y2)))
        line = line / np.linalg.norm(line)
        for t in (room_yaw, room_yaw + math.pi / 2):
            a, b, c = line[0] * math.cos(t), -line[1] * math.sin(t), line[2] * math.sin(t)
            r = math.hypot(b, c)
            if r < 0.05 or abs(a) > r:
                continue
            phi = math.atan2(c, b)
            for root in (math.asin(-a / r) - phi, math.pi - math.asin(-a / r) - phi):
                p = math.remainder(root, 2 * math.pi)
                if abs(p - pitch0) < math.radians(10.0):
                    pitches.append(p)
                    weights.append(math.hypot(x2 - x1, y2 - y1) * r)
    return pitches, weights


def _pitch_from_votes(pitches: Sequence[float], weights: Sequence[float]) -> tuple[float, float, int] | None:
    """The peak of the pitch votes: the weighted mean of the votes within 1.5 degrees of it, its
    standard deviation and how many votes agree; ``None`` with fewer than two agreeing votes or
    when they hold under 30 % of the weight."""
    if len(pitches) < 2:
        return None
    deg = np.degrees(np.asarray(pitches))
    w = np.asarray(weights, dtype=np.float64)
    edges = np.arange(-45.0, 90.01, 0.25)
    hist, _ = np.histogram(deg, bins=edges, weights=w)
    peak = float(edges[int(np.argmax(np.convolve(hist, np.ones(5), "same")))] + 0.125)
    near = np.abs(deg - peak) <= 1.5
    if near.sum() < 2 or w[near].sum() < 0.3 * w.sum():
        return None
    mean = float(np.sum(w[near] * deg[near]) / w[near].sum())
    spread = float(np.sqrt(np.sum(w[near] * (deg[near] - mean) ** 2) / w[near].sum()))
    n_eff = float(w[near].sum() ** 2 / np.sum(w[near] ** 2))
    return math.radians(mean), math.radians(max(spread, 0.1) / math.sqrt(n_eff)), int(near.sum())


def _vertical_pitch(image: SceneImage, camera: Camera) -> tuple[float, float, int] | None:
    """The camera's downward pitch (radians) from the picture's vertical edges alone, its standard
    deviation and how many edges agree (:func:`_vertical_votes`); ``None`` without OpenCV or
    without two agreeing edges."""
    segments = _line_segments(image)
    return None if segments is None else _pitch_from_votes(*_vertical_votes(segments, camera))


def _room_direction(image: SceneImage, camera: Camera, pose: CameraPose) -> tuple[float, float] | None:
    """The room's horizontal direction modulo 90 degrees (radians in [-pi/4, pi/4)) from the
    photograph's straight edges below the horizon, carried onto the floor plane (a horizontal
    edge keeps its direction there at any height; vertical edges, which fall onto lines through
    the camera's foot, are left out); and the share of edge length that agrees within 5 degrees.
    ``None`` without OpenCV or without enough edges."""
    prepared = _gray(image)
    if prepared is None:
        return None
    cv2, gray, scale = prepared
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

"""A local unit seen as a 2D layout: the anchor surface, its (u, v) grid and per-object 2D poses.

Every unit is evolved on an orthographic view of its anchor surface (the method's stage 4).
:class:`UnitSurface` is that surface: an origin, a ``u`` axis drawn to the right and a ``v``
axis drawn up, both in metres, with ``(0, 0)`` at the surface's lower-left corner, so every
in-bounds coordinate is between 0 and the surface size. The viewer looks at the surface along
``-normal`` (``normal = u x v`` points toward the viewer):

==========  ==============================  ==========================  =====================
unit        viewer                          u (right)                   v (up)
==========  ==============================  ==========================  =====================
floor       above, looking down             world +X                    world +Y
ceiling     below, looking up               world +X                    world -Y
wall        inside the room, facing it      along the wall, end->start  world +Z
object      above the anchor's top          anchor +X                   anchor +Y
contained   in front of the anchor          anchor +X                   anchor +Z
==========  ==============================  ==========================  =====================

The surface stores a grid of 3D points (one per ``grid_step`` along each axis, plus the far
edges); a (u, v) point maps to 3D by bilinear interpolation between the four grid points
around it, and back by inverting that map, so a curved or skewed surface would only need
another grid. An object's 2D pose is the centre of its projected box, the box's extent along
u and v, and its in-plane **rotation** in degrees: 0 = facing down (-v), 90 = facing left
(-u), 180 = up, -90 = right, i.e. measured clockwise. The facing direction is the object's
front (local -Y) when the front lies in the plane, else its local -Z (a painting, whose front
points at the viewer, has rotation 0 when hung upright). A new rotation is a turn about the
surface normal composed with the object's current orientation; a new centre moves the box
centre in the plane and keeps its height above the surface. The anchor never moves.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import Polygon

from scenemosaic._memo import Memo
from scenemosaic.exceptions import SceneValidationError
from scenemosaic.scene._geometry import FloatArray, quat_from_matrix
from scenemosaic.scene._ids import CEILING, FLOOR
from scenemosaic.scene._model import LocalUnit, Pose, Scene, SceneObject
from scenemosaic.scene._planar import convex_hull_2d, outline_polygon

__all__ = [
    "GRID_STEP_M",
    "UV",
    "BBox2D",
    "LayoutState2D",
    "ObjectState2D",
    "UnitLayout",
    "UnitSurface",
    "normalize_degrees",
    "surface_for",
]

GRID_STEP_M = 0.25
"""Spacing of the stored grid points (and of the view's grid lines when they fit), metres."""
_FRONT_IN_PLANE = 0.5
"""An object's front is its facing direction when at least this much of it lies in the plane."""


def normalize_degrees(angle: float) -> float:
    """An angle in degrees brought into (-180, 180]."""
    a = math.fmod(float(angle), 360.0)
    if a <= -180.0:
        a += 360.0
    elif a > 180.0:
        a -= 360.0
    return 0.0 if a == 0.0 else a  # no -0.0


# -- the 2D state shown to agents -----------------------------------------------------------------


class _State(BaseModel):
    model_config = ConfigDict(extra="forbid")


class UV(_State):
    """A point or an extent on the anchor surface, metres."""

    u: float
    v: float


class BBox2D(_State):
    """An axis-aligned box on the anchor surface, metres."""

    min_u: float
    min_v: float
    max_u: float
    max_v: float


class ObjectState2D(_State):
    """One object of a unit in the unit's 2D view."""

    id: str
    category: str
    center: UV
    size: UV = Field(description="Extent of the object's projected box along u and v, metres.")
    bbox: BBox2D
    rotation_degrees: float = Field(description="Facing: 0 down, 90 left, 180 up, -90 right (clockwise).")


class LayoutState2D(_State):
    """A unit's layout as the agents see it: the surface size and every child's 2D pose."""

    unit: str = Field(description="The anchor id.")
    projection: str
    surface: UV = Field(description="Size of the anchor surface; in-bounds u is in [0, surface.u], v in [0, surface.v].")
    objects: list[ObjectState2D]

    def get(self, object_id: str) -> ObjectState2D:
        """The object's state; ``KeyError`` when the unit has no such child."""
        for o in self.objects:
            if o.id == object_id:
                return o
        raise KeyError(object_id)


# -- the surface ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class UnitSurface:
    """The anchor surface of a unit: its (u, v) frame, grid of 3D points and allowed region."""

    anchor_id: str
    kind: str
    projection: str
    origin: FloatArray
    """3D point of (u, v) = (0, 0)."""
    u_axis: FloatArray
    v_axis: FloatArray
    size: tuple[float, float]
    """Extent (U, V) of the surface, metres."""
    region: tuple[tuple[float, float], ...]
    """Polygon (u, v) the children must stay inside (the floor polygon of a floor unit)."""
    grid: FloatArray
    """3D points, shape (nu, nv, 3), at ``grid_u[i], grid_v[j]``."""
    grid_u: FloatArray
    grid_v: FloatArray

    @functools.cached_property
    def normal(self) -> FloatArray:
        """Unit vector toward the viewer (``u x v``): the projection axis (worked out once; read-only)."""
        n: FloatArray = np.cross(self.u_axis, self.v_axis)
        n.flags.writeable = False
        return n

    @functools.cached_property
    def _normal_basis(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The identity, and the cross-product matrix of :attr:`normal` and its square: the terms
        of a turn about the normal (:meth:`turn_about_normal`), which a planner asks for by the
        ten thousand."""
        x, y, z = (float(c) for c in self.normal)
        k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        return np.eye(3), k, k @ k

    def turn_about_normal(self, degrees: float) -> FloatArray:
        """3x3 rotation by ``degrees`` counter-clockwise about :attr:`normal` (Rodrigues' formula,
        its terms worked out once per surface)."""
        a = math.radians(degrees)
        eye, k, kk = self._normal_basis
        r: FloatArray = eye + math.sin(a) * k + (1.0 - math.cos(a)) * kk
        return r

    def _cell(self, u: float, v: float) -> tuple[int, int]:
        i = int(np.clip(np.searchsorted(self.grid_u, u, side="right") - 1, 0, len(self.grid_u) - 2))
        j = int(np.clip(np.searchsorted(self.grid_v, v, side="right") - 1, 0, len(self.grid_v) - 2))
        return i, j

    def _bilinear(self, i: int, j: int, s: float, t: float) -> FloatArray:
        g = self.grid
        p: FloatArray = (
            (1 - s) * (1 - t) * g[i, j] + s * (1 - t) * g[i + 1, j] + (1 - s) * t * g[i, j + 1] + s * t * g[i + 1, j + 1]
        )
        return p

    def _local(self, i: int, j: int, u: float, v: float) -> tuple[float, float]:
        du = self.grid_u[i + 1] - self.grid_u[i]
        dv = self.grid_v[j + 1] - self.grid_v[j]
        return (u - self.grid_u[i]) / du, (v - self.grid_v[j]) / dv

    def to_3d(self, u: float, v: float) -> FloatArray:
        """The 3D point of surface coordinates (u, v): bilinear between the surrounding grid points
        (extrapolated from the border cell outside the surface)."""
        i, j = self._cell(u, v)
        s, t = self._local(i, j, u, v)
        return self._bilinear(i, j, s, t)

    def to_uv(self, point: FloatArray) -> tuple[float, float]:
        """Surface coordinates of the foot of ``point`` along the normal (inverse of :meth:`to_3d`).

        Starts from the projection on the axes and refines with Newton steps on the bilinear
        map of the cell the point falls in (exact after the first step on a planar grid).
        """
        p = np.asarray(point, dtype=np.float64)
        n = self.normal
        u = float((p - self.origin) @ self.u_axis)
        v = float((p - self.origin) @ self.v_axis)
        for _ in range(4):
            i, j = self._cell(u, v)
            s, t = self._local(i, j, u, v)
            g = self.grid
            q = self._bilinear(i, j, s, t)
            du = self.grid_u[i + 1] - self.grid_u[i]
            dv = self.grid_v[j + 1] - self.grid_v[j]
            ds = ((1 - t) * (g[i + 1, j] - g[i, j]) + t * (g[i + 1, j + 1] - g[i, j + 1])) / du
            dt = ((1 - s) * (g[i, j + 1] - g[i, j]) + s * (g[i + 1, j + 1] - g[i + 1, j])) / dv
            r = p - q
            r = r - (r @ n) * n  # only the in-plane residual matters
            jac = np.stack([ds, dt], axis=1)  # (3, 2)
            step, *_ = np.linalg.lstsq(jac, r, rcond=None)
            u, v = u + float(step[0]), v + float(step[1])
            if abs(step[0]) < 1e-12 and abs(step[1]) < 1e-12:
                break
        return u, v

    def height(self, point: FloatArray) -> float:
        """Distance of ``point`` from the surface along the normal (toward the viewer)."""
        u, v = self.to_uv(point)
        return float((np.asarray(point, dtype=np.float64) - self.to_3d(u, v)) @ self.normal)

    def project(self, points: FloatArray) -> FloatArray:
        """Surface coordinates (n, 2) of world points (n, 3)."""
        return np.array([self.to_uv(p) for p in np.asarray(points, dtype=np.float64).reshape(-1, 3)])

    def contains(self, polygon: FloatArray, tolerance: float = 0.0) -> bool:
        """True when the convex ``polygon`` (u, v) lies inside the region (grown by ``tolerance``)."""
        from shapely.geometry import Polygon

        region = Polygon(self.region)
        if tolerance:
            region = region.buffer(tolerance, join_style="mitre")
        return bool(region.covers(Polygon(polygon)))


def _grid_axis(extent: float, step: float) -> FloatArray:
    n = max(1, math.ceil(extent / step - 1e-9))
    axis: FloatArray = np.minimum(np.arange(n + 1) * step, extent)
    if len(axis) > 1 and axis[-1] - axis[-2] < 1e-9:
        axis = axis[:-1]
    axis[-1] = extent
    return axis


def _make_surface(
    anchor_id: str,
    kind: str,
    projection: str,
    origin: FloatArray,
    u_axis: FloatArray,
    v_axis: FloatArray,
    size: tuple[float, float],
    region: Iterable[tuple[float, float]] | None = None,
) -> UnitSurface:
    U, V = max(size[0], 1e-3), max(size[1], 1e-3)
    gu, gv = _grid_axis(U, GRID_STEP_M), _grid_axis(V, GRID_STEP_M)
    grid = origin[None, None, :] + gu[:, None, None] * u_axis[None, None, :] + gv[None, :, None] * v_axis[None, None, :]
    poly = tuple((float(a), float(b)) for a, b in region) if region is not None else ((0.0, 0.0), (U, 0.0), (U, V), (0.0, V))
    return UnitSurface(anchor_id, kind, projection, origin, u_axis, v_axis, (U, V), poly, grid, gu, gv)


def surface_for(scene: Scene, unit: LocalUnit | str) -> UnitSurface:
    """The anchor surface of ``unit`` (a :class:`~scenemosaic.scene.LocalUnit` or an anchor id)
    in the scene as it is now."""
    anchor = unit if isinstance(unit, str) else unit.anchor_id
    kind = scene.anchor_kind(anchor)
    ez = np.array([0.0, 0.0, 1.0])
    if kind in ("floor", "ceiling"):
        if scene.room is None:
            raise SceneValidationError(f"unit {anchor!r} needs a room to define its surface")
        floor = np.asarray(scene.room.floor, dtype=np.float64)
        (x0, y0), (x1, y1) = floor.min(axis=0), floor.max(axis=0)
        if anchor == FLOOR:
            origin = np.array([x0, y0, 0.0])
            ua, va = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
            region = [(x - x0, y - y0) for x, y in floor]
            return _make_surface(anchor, kind, "top_down", origin, ua, va, (x1 - x0, y1 - y0), region)
        assert anchor == CEILING
        origin = np.array([x0, y1, scene.room.ceiling_height])
        ua, va = np.array([1.0, 0.0, 0.0]), np.array([0.0, -1.0, 0.0])
        region = [(x - x0, y1 - y) for x, y in floor]
        return _make_surface(anchor, kind, "bottom_up", origin, ua, va, (x1 - x0, y1 - y0), region)
    if kind == "wall":
        assert scene.room is not None
        wall = scene.room.wall(anchor)
        d = wall.direction
        ua = np.array([-d[0], -d[1], 0.0])
        origin = np.array([wall.end[0], wall.end[1], 0.0])
        return _make_surface(anchor, kind, "wall_normal", origin, ua, ez, (wall.length, wall.height))
    obj = scene.get(anchor)
    m = obj.pose.matrix(with_scale=False)
    sx, sy, sz = (float(v) for v in obj.size)
    ax, ay, az = m[:3, 0], m[:3, 1], m[:3, 2]
    base = m[:3, 3]
    contained = bool(scene.children_of(anchor)) and all(
        (r := scene.support_of(k)) is not None and r.kind == "contain" for k in scene.children_of(anchor)
    )
    if contained:
        origin = base - ax * sx / 2 - ay * sy / 2
        return _make_surface(anchor, kind, "anchor_front", origin, ax.copy(), az.copy(), (sx, sz))
    origin = base - ax * sx / 2 - ay * sy / 2 + az * sz
    return _make_surface(anchor, kind, "top_down", origin, ax.copy(), ay.copy(), (sx, sy))


# -- objects on the surface -----------------------------------------------------------------------


def _box_center_local(obj: SceneObject) -> FloatArray:
    """Centre of the object's box in its unscaled local frame (the box spans z in [0, height])."""
    return np.array([0.0, 0.0, float(obj.size[2]) / 2.0])


def _corners_at(obj: SceneObject, rotation: FloatArray, center: FloatArray) -> FloatArray:
    out: FloatArray = _box_corners(tuple(float(v) for v in obj.size)) @ rotation.T + center
    return out


def _projected_corners(obj: SceneObject, rotation: FloatArray, surface: UnitSurface) -> FloatArray:
    """The corners of ``obj``'s box turned by ``rotation``, projected on ``surface`` about its centre (read-only)."""
    corners = _corners_at(obj, rotation, np.zeros(3))
    uv: FloatArray = np.stack([corners @ surface.u_axis, corners @ surface.v_axis], axis=1)
    uv.flags.writeable = False
    return uv


_PROJECTED_CORNERS: Memo[tuple[tuple[float, ...], bytes, bytes, bytes], FloatArray] = Memo(1 << 16)
"""Projected corners by box size, rotation and surface axes: a planner turns each piece to the
same few rotations thousands of times."""


@functools.lru_cache(maxsize=4096)
def _box_corners(size: tuple[float, ...]) -> FloatArray:
    """The eight corners of a box of ``size`` centred at the origin (read-only: shared)."""
    sx, sy, sz = size
    local = np.array([[x, y, z] for x in (-sx / 2, sx / 2) for y in (-sy / 2, sy / 2) for z in (-sz / 2, sz / 2)])
    local.flags.writeable = False
    return local


@dataclass
class _Placed:
    obj: SceneObject
    rotation: FloatArray
    """3x3 world rotation."""
    center_uv: tuple[float, float]
    height: float
    """Box centre's distance from the surface along the normal."""
    reference: FloatArray
    """The object-local axis whose projection defines the in-plane rotation."""
    degrees: float | None = None
    """The in-plane rotation (:meth:`UnitLayout.rotation`) once worked out; reset by a turn."""
    corners_uv: FloatArray | None = None
    """The box's corners projected on the surface about its centre, once worked out (read-only);
    reset by a turn."""
    outline: FloatArray | None = None
    """The outline (:meth:`UnitLayout.polygon`) once worked out (read-only); reset by any move."""


class UnitLayout:
    """A unit's children as 2D poses on its anchor surface, convertible to and from 3D poses.

    Build it from a scene (:meth:`from_scene`); move objects with :meth:`set_center` /
    :meth:`set_rotation`; read :meth:`state` (what the agents see) or :meth:`poses` (world
    poses, for :func:`~scenemosaic.scene.rigid_moves`). Children keep their heights above
    the surface and their orientation apart from the in-plane turn.
    """

    def __init__(self, surface: UnitSurface, placed: Mapping[str, _Placed]) -> None:
        self.surface = surface
        self._placed = dict(placed)

    @classmethod
    def from_scene(cls, scene: Scene, unit: LocalUnit | str, surface: UnitSurface | None = None) -> UnitLayout:
        """The current layout of ``unit``'s children in ``scene``."""
        anchor = unit if isinstance(unit, str) else unit.anchor_id
        surface = surface or surface_for(scene, anchor)
        children = scene.children_of(anchor) if isinstance(unit, str) else list(unit.children)
        placed: dict[str, _Placed] = {}
        for cid in children:
            obj = scene.get(cid)
            placed[cid] = cls._place(surface, obj)
        return cls(surface, placed)

    @staticmethod
    def _place(surface: UnitSurface, obj: SceneObject) -> _Placed:
        rot = obj.pose.rotation
        centre = obj.pose.matrix(with_scale=False)[:3, 3] + rot @ _box_center_local(obj)
        u, v = surface.to_uv(centre)
        height = float((centre - surface.to_3d(u, v)) @ surface.normal)
        reference = np.array([0.0, -1.0, 0.0])
        for axis in (np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0])):
            w = rot @ axis
            if math.hypot(float(w @ surface.u_axis), float(w @ surface.v_axis)) >= _FRONT_IN_PLANE:
                reference = axis
                break
        return _Placed(obj, rot, (u, v), height, reference)

    @property
    def ids(self) -> list[str]:
        """The children, in unit order."""
        return list(self._placed)

    def copy(self, only: Collection[str] | None = None) -> UnitLayout:
        """An independent copy (moves on it leave this one alone); with ``only``, of those
        children alone (a trial move of a few pieces need not copy the rest)."""
        return UnitLayout(
            self.surface,
            {
                k: _Placed(p.obj, p.rotation.copy(), p.center_uv, p.height, p.reference, p.degrees, p.corners_uv, p.outline)
                for k, p in self._placed.items()
                if only is None or k in only
            },
        )

    def object(self, object_id: str) -> SceneObject:
        """The scene object behind ``object_id`` (with its pose when the layout was built)."""
        return self._placed[object_id].obj

    def rotation(self, object_id: str) -> float:
        """In-plane rotation in degrees (0 down, 90 left, 180 up, -90 right)."""
        p = self._placed[object_id]
        if p.degrees is None:
            w = p.rotation @ p.reference
            a, b = float(w @ self.surface.u_axis), float(w @ self.surface.v_axis)
            # clockwise angle from -v: facing (a, b) = (-sin r, -cos r)
            p.degrees = normalize_degrees(math.degrees(math.atan2(-a, -b)))
        return p.degrees

    def center(self, object_id: str) -> tuple[float, float]:
        """Centre of the object's projected box on the surface."""
        return self._placed[object_id].center_uv

    def polygon(self, object_id: str) -> FloatArray:
        """The object's projected box outline (convex, counter-clockwise), (k, 2) surface coordinates."""
        p = self._placed[object_id]
        if p.outline is None:  # a trial move of a few pieces asks again for the rest, unmoved
            if p.corners_uv is None:
                self.reach(object_id)  # works out the projected corners
            assert p.corners_uv is not None
            p.outline = convex_hull_2d(p.corners_uv + np.asarray(p.center_uv)[None, :])
            p.outline.flags.writeable = False
        return p.outline.copy()

    def reach(self, object_id: str) -> tuple[float, float, float, float]:
        """The bounds ``(u_min, v_min, u_max, v_max)`` of the object's projected box corners,
        unrounded (:meth:`polygon` rounds its points to 1e-9): a quick test of where a piece
        reaches, without building its outline."""
        p = self._placed[object_id]
        if p.corners_uv is None:
            surface = self.surface
            key = (tuple(float(v) for v in p.obj.size), p.rotation.tobytes(), surface.u_axis.tobytes(), surface.v_axis.tobytes())
            p.corners_uv = _PROJECTED_CORNERS.get(key, lambda: _projected_corners(p.obj, p.rotation, surface))
        lo, hi = p.corners_uv.min(axis=0), p.corners_uv.max(axis=0)
        u, v = p.center_uv
        return float(lo[0] + u), float(lo[1] + v), float(hi[0] + u), float(hi[1] + v)

    def outline(self, object_id: str) -> Polygon:
        """:meth:`polygon` as a shapely polygon."""
        return outline_polygon(self.polygon(object_id))

    def extent(self, object_id: str) -> tuple[float, float]:
        """Size of the projected box along u and v."""
        poly = self.polygon(object_id)
        span = poly.max(axis=0) - poly.min(axis=0)
        return float(span[0]), float(span[1])

    def span(self, object_id: str) -> tuple[float, float]:
        """The object's box extent along the normal (lowest, highest distance from the surface)."""
        p = self._placed[object_id]
        h = _corners_at(p.obj, p.rotation, np.zeros(3)) @ self.surface.normal + p.height
        return float(h.min()), float(h.max())

    def set_center(self, object_id: str, u: float, v: float) -> None:
        """Move the object's box centre to (u, v), keeping its height and orientation."""
        p = self._placed[object_id]
        if not (math.isfinite(u) and math.isfinite(v)):
            raise SceneValidationError(f"non-finite centre for {object_id!r}: ({u}, {v})", object_id=object_id)
        p.center_uv = (float(u), float(v))
        p.outline = None

    def set_rotation(self, object_id: str, degrees: float) -> None:
        """Turn the object about the surface normal so its in-plane rotation becomes ``degrees``."""
        if not math.isfinite(degrees):
            raise SceneValidationError(f"non-finite rotation for {object_id!r}: {degrees}", object_id=object_id)
        turn = self.rotation(object_id) - normalize_degrees(degrees)  # counter-clockwise seen by the viewer
        p = self._placed[object_id]
        p.rotation = self.surface.turn_about_normal(turn) @ p.rotation
        p.degrees = p.corners_uv = p.outline = None

    def pose(self, object_id: str) -> Pose:
        """The object's world pose for its current 2D pose."""
        p = self._placed[object_id]
        u, v = p.center_uv
        centre = self.surface.to_3d(u, v) + p.height * self.surface.normal
        position = centre - p.rotation @ _box_center_local(p.obj)
        return Pose(
            position=(float(position[0]), float(position[1]), float(position[2])),
            quaternion=quat_from_matrix(p.rotation),
            scale=p.obj.pose.scale,
        )

    def poses(self) -> dict[str, Pose]:
        """World poses of every child."""
        return {k: self.pose(k) for k in self._placed}

    def object_state(self, object_id: str) -> ObjectState2D:
        """What an agent sees of one child."""
        u, v = self.center(object_id)
        su, sv = self.extent(object_id)
        return ObjectState2D(
            id=object_id,
            category=self._placed[object_id].obj.category,
            center=UV(u=u, v=v),
            size=UV(u=su, v=sv),
            bbox=BBox2D(min_u=u - su / 2, min_v=v - sv / 2, max_u=u + su / 2, max_v=v + sv / 2),
            rotation_degrees=self.rotation(object_id),
        )

    def state(self) -> LayoutState2D:
        """The 2D layout state of every child (full precision)."""
        s = self.surface
        return LayoutState2D(
            unit=s.anchor_id,
            projection=s.projection,
            surface=UV(u=s.size[0], v=s.size[1]),
            objects=[self.object_state(k) for k in self._placed],
        )

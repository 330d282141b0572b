"""The scene model: pydantic types for rooms, objects, poses, relations and structure.

Frames and units (the full statement is ``docs/conventions.md``):

* World frame: right-handed, **Z up**, metres.
* An object's local frame has its origin at the **bottom centre of its footprint**,
  +Z up, and its **front along local -Y**. ``yaw = 0`` therefore faces world -Y.
* Quaternions are scalar-first ``(w, x, y, z)``. A quaternion whose norm is off by more
  than ``QUAT_NORM_TOLERANCE`` is normalized and a warning is logged; a zero or
  non-finite quaternion is rejected.
* ``Pose.scale`` multiplies the asset's canonical extents (``AssetRef.extents``), so
  an object's size in its own frame is ``asset.extents * pose.scale``.
* Anchor ids: ``"floor"``, ``"ceiling"``, each wall's id, or an object id. Object ids may
  not collide with them.
* Positions, sizes, scales, heights and the object count are bounded (``_limits.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Annotated, Any, Literal, cast

import numpy as np
import structlog
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from scenemosaic.exceptions import SceneValidationError
from scenemosaic.scene._geometry import FloatArray, quat_from_yaw, quat_to_matrix, yaw_from_quat
from scenemosaic.scene._ids import CEILING, FLOOR, MAX_ID_LENGTH, OBJECT_ID_PATTERN
from scenemosaic.scene._limits import (
    MAX_FLOOR_POINTS,
    MAX_OBJECT_SIZE,
    coordinate_problem,
    object_count_problem,
    scale_problem,
    size_problem,
)

if TYPE_CHECKING:
    from scenemosaic.scene._house import House

__all__ = [
    "CEILING",
    "FLOOR",
    "QUAT_NORM_TOLERANCE",
    "AssetRef",
    "ConstraintClause",
    "CrossUnitConstraint",
    "LocalUnit",
    "Opening",
    "Pose",
    "Provenance",
    "Relation",
    "Room",
    "Scene",
    "SceneObject",
    "SceneStructure",
    "SimAttributes",
    "Wall",
    "register_plan_renderer",
]

log = structlog.get_logger(__name__)

_plan_renderers: list[Callable[[Scene | House], bytes]] = []
"""The one plan renderer :meth:`Scene._repr_png_` and :meth:`House._repr_png_` call (the render
package's; empty before it registers): a scene cannot import the render layer above it, so the
renderer comes to it."""


def register_plan_renderer(renderer: Callable[[Scene | House], bytes]) -> None:
    """Set the function that draws a plan as PNG bytes for Jupyter: a scene's
    (``Scene._repr_png_``) or a whole house's (``House._repr_png_``); it is given either.

    ``scenemosaic.render`` registers its top-down view when it is imported (every reader, writer
    and run imports it; ``import scenemosaic`` registers a stand-in that imports it on first use).
    A later call replaces the earlier renderer.
    """
    _plan_renderers[:] = [renderer]


def _plan_png(model: Scene | House) -> bytes | None:
    """The registered renderer's plan of a scene or a house, for a ``_repr_png_``; ``None`` (the
    text repr) when no renderer is registered or the plan cannot be drawn."""
    if not _plan_renderers:
        return None
    try:
        return _plan_renderers[0](model)
    except Exception as exc:  # a display hook must not raise: the text repr stays
        log.warning("scene_plan_not_drawn", scene=model.id, error=f"{type(exc).__name__}: {exc}")
        return None


QUAT_NORM_TOLERANCE = 1e-6
"""Largest accepted deviation of a quaternion's norm from 1 before it is normalized (with a warning)."""

ObjectId = Annotated[str, Field(min_length=1, max_length=MAX_ID_LENGTH, pattern=OBJECT_ID_PATTERN)]
Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def _check_finite(values: tuple[float, ...], what: str) -> None:
    if not all(map(math.isfinite, values)):
        raise ValueError(f"{what} must be finite, got {list(values)}")


def _finite_or(values: tuple[float, ...], neutral: float) -> tuple[float, ...]:
    """``values`` with every non-finite entry replaced by ``neutral`` (for range-only checks)."""
    if all(map(math.isfinite, values)):  # nearly always: the values themselves
        return values
    return tuple(v if math.isfinite(v) else neutral for v in values)


def _height(v: float) -> float:
    if not math.isfinite(v) or v > MAX_OBJECT_SIZE:
        raise ValueError(f"height {v:g} m is not a finite number up to {MAX_OBJECT_SIZE:g} m")
    return v


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


class Pose(BaseModel):
    """Where an object is: position of its local origin, orientation and anisotropic scale.

    Immutable; use :meth:`model_copy` with ``update=`` or :meth:`with_yaw` to change it.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    position: Vec3 = Field(description="World position of the object's local origin (bottom centre), metres.")
    quaternion: Quat = Field(default=(1.0, 0.0, 0.0, 0.0), description="Unit quaternion (w, x, y, z).")
    scale: Vec3 = Field(
        default=(1.0, 1.0, 1.0), description="Positive per-axis scale of the canonical asset."
    )

    @field_validator("position")
    @classmethod
    def _finite_position(cls, v: Vec3) -> Vec3:
        _check_finite(v, "position")
        return v

    @field_validator("scale")
    @classmethod
    def _positive_scale(cls, v: Vec3) -> Vec3:
        _check_finite(v, "scale")
        if min(v) <= 0:
            raise ValueError(f"scale must be positive on every axis, got {list(v)}")
        return v

    @field_validator("quaternion")
    @classmethod
    def _unit_quaternion(cls, v: Quat) -> Quat:
        _check_finite(v, "quaternion")
        w, x, y, z = v
        norm = math.sqrt(w * w + x * x + y * y + z * z)  # summed in this order, as sum() would
        if norm < 1e-9:
            raise ValueError("quaternion has zero norm")
        if abs(norm - 1.0) > QUAT_NORM_TOLERANCE:
            log.warning("quaternion_normalized", norm=norm, quaternion=list(v))
        if w / norm < 0:  # canonical sign: w >= 0, so equal rotations serialize equally
            return (-(w / norm), -(x / norm), -(y / norm), -(z / norm))
        return (w / norm, x / norm, y / norm, z / norm)

    @classmethod
    def from_yaw(cls, position: Vec3, yaw: float, scale: Vec3 = (1.0, 1.0, 1.0)) -> Pose:
        """An upright pose rotated ``yaw`` radians about +Z."""
        return cls(position=position, quaternion=quat_from_yaw(yaw), scale=scale)

    @property
    def yaw(self) -> float:
        """Heading about +Z in radians (0 = front faces world -Y)."""
        return yaw_from_quat(self.quaternion)

    @property
    def rotation(self) -> FloatArray:
        """3x3 rotation matrix."""
        return quat_to_matrix(self.quaternion)

    def with_yaw(self, yaw: float) -> Pose:
        """The same position and scale, upright, facing ``yaw``."""
        return Pose(position=self.position, quaternion=quat_from_yaw(yaw), scale=self.scale)

    def matrix(self, *, with_scale: bool = True) -> FloatArray:
        """4x4 local-to-world transform ``T @ R @ S`` (``S`` omitted when ``with_scale`` is false)."""
        m = np.eye(4)
        r = self.rotation
        m[:3, :3] = r @ np.diag(self.scale) if with_scale else r
        m[:3, 3] = self.position
        return m


class AssetRef(_Model):
    """What an object looks like: a mesh file, a procedural furniture model, or a plain box.

    ``extents`` is the canonical asset's size in its local frame (x width, y depth,
    z height) in metres, before ``Pose.scale``; it is known without loading any mesh.
    """

    kind: Literal["mesh", "procedural", "box"] = "procedural"
    uri: str | None = Field(default=None, description="Mesh path relative to the scene folder (kind 'mesh').")
    category: str | None = Field(default=None, description="Procedural model to build (kind 'procedural').")
    extents: Vec3 = Field(description="Canonical local size (x, y, z) in metres, before pose scale.")
    sha256: str | None = Field(default=None, description="Content hash of the canonical mesh, when known.")
    source_transform: list[float] | None = Field(
        default=None,
        description="Row-major 4x4 mapping the source file's coordinates to the canonical frame.",
    )

    @field_validator("extents")
    @classmethod
    def _positive_extents(cls, v: Vec3) -> Vec3:
        _check_finite(v, "extents")
        if min(v) <= 0:
            raise ValueError(f"asset extents must be positive, got {list(v)}")
        return v

    @model_validator(mode="after")
    def _kind_fields(self) -> AssetRef:
        if self.kind == "mesh" and not self.uri:
            raise ValueError("a mesh asset needs a uri")
        if self.source_transform is not None and len(self.source_transform) != 16:
            raise ValueError("source_transform must hold 16 numbers (row-major 4x4)")
        return self


class SimAttributes(_Model):
    """Simulation properties. ``mass_kg`` wins over ``density_kg_m3`` when both are set."""

    mass_kg: float | None = Field(default=None, gt=0, description="Total mass in kilograms.")
    density_kg_m3: float | None = Field(default=None, gt=0, description="Density used when mass is unset.")
    friction: float = Field(default=0.6, ge=0, le=5, description="Sliding friction coefficient.")
    static: bool = Field(default=False, description="True for fixtures that never move in simulation.")
    source: str | None = Field(default=None, description="Where the figures came from (agent, file, table).")

    @field_validator("mass_kg", "density_kg_m3", "friction")
    @classmethod
    def _finite(cls, v: float | None) -> float | None:
        if v is not None and not math.isfinite(v):
            raise ValueError("must be finite")
        return v


class SceneObject(_Model):
    """One object of the scene, with a stable id that survives every stage."""

    id: ObjectId
    category: str = Field(
        min_length=1, max_length=64, description="Normalized category, e.g. 'dining_chair'."
    )
    description: str = Field(default="", max_length=500)
    asset: AssetRef
    pose: Pose
    sim: SimAttributes = Field(default_factory=SimAttributes)

    @model_validator(mode="after")
    def _within_limits(self) -> SceneObject:
        """Position, pose scale and size (``asset.extents * pose.scale``) within the scene limits
        (``_limits.py``); the error names the object and the field."""
        # checked on the object rather than on Pose: a Pose is also a transient value (physics
        # measures motions with poses of bodies that flew away), an object is what a scene holds.
        # Only the range is checked here: finiteness is Pose's and AssetRef's own rule, and a NaN
        # smuggled past them (model_copy) is for physics' require_finite_poses to name.
        pose = self.pose
        problem = coordinate_problem(_finite_or(pose.position, 0.0))
        field = "pose.position"
        if problem is None:
            problem, field = scale_problem(_finite_or(pose.scale, 1.0)), "pose.scale"
        if problem is None:
            problem, field = size_problem(_finite_or(self._size(), 1.0)), "asset.extents * pose.scale"
        if problem is not None:
            raise ValueError(f"object {self.id!r}: {field}: {problem}")
        return self

    def _size(self) -> tuple[float, float, float]:
        """:attr:`size` in plain floats (the validator's, without arrays)."""
        (ex, ey, ez), (sx, sy, sz) = self.asset.extents, self.pose.scale
        return float(ex) * float(sx), float(ey) * float(sy), float(ez) * float(sz)

    @property
    def size(self) -> FloatArray:
        """Size in the object's own frame: asset extents times pose scale (metres)."""
        return np.array(self._size(), dtype=np.float64)

    def corners(self) -> FloatArray:
        """World coordinates of the 8 corners of the object's oriented bounding box, shape (8, 3)."""
        sx, sy, sz = self.asset.extents
        local = np.array(
            [[x, y, z] for x in (-sx / 2, sx / 2) for y in (-sy / 2, sy / 2) for z in (0.0, sz)],
            dtype=np.float64,
        )
        m = self.pose.matrix()
        return local @ m[:3, :3].T + m[:3, 3]

    def footprint(self) -> FloatArray:
        """World XY corners (4, 2) of the oriented footprint, counter-clockwise, for upright objects."""
        sx, sy, _ = self.asset.extents
        local = np.array(
            [[-sx / 2, -sy / 2, 0], [sx / 2, -sy / 2, 0], [sx / 2, sy / 2, 0], [-sx / 2, sy / 2, 0]]
        )
        m = self.pose.matrix()
        return (local @ m[:3, :3].T + m[:3, 3])[:, :2]

    def aabb(self) -> tuple[FloatArray, FloatArray]:
        """World axis-aligned bounds (min xyz, max xyz) of the oriented box."""
        c = self.corners()
        return c.min(axis=0), c.max(axis=0)


class Opening(_Model):
    """A door or window in a wall, in (distance along the wall, height) coordinates."""

    kind: Literal["door", "window", "opening"] = "door"
    center: float = Field(description="Distance from the wall's start to the opening's centre, metres.")
    width: float = Field(gt=0)
    bottom: float = Field(default=0.0, ge=0, description="Sill height above the floor, metres.")
    height: float = Field(gt=0)
    leaves: int | None = Field(
        default=None,
        ge=0,
        le=2,
        exclude_if=lambda v: v is None,
        description=(
            "A door's hinged leaves: 0 for a frame without a door (AI2-THOR's Doorframe), 1, or 2 "
            "(a double door); None (the default, left out of scene.json): not said, a door gets "
            "one. The simulator exports hang them on the doorway (docs/articulation.md)."
        ),
    )

    @property
    def leaf_count(self) -> int:
        """How many hinged leaves hang in it: :attr:`leaves` for a door (one when unsaid), none
        for a window or an open stretch of wall."""
        if self.kind != "door":
            return 0
        return 1 if self.leaves is None else self.leaves


class Wall(_Model):
    """A straight wall segment. Its inward normal points left of ``start -> end`` (floor is CCW)."""

    id: ObjectId
    start: Vec2
    end: Vec2
    height: float = Field(gt=0)
    thickness: float = Field(default=0.1, gt=0)
    openings: list[Opening] = Field(default_factory=list)

    @field_validator("start", "end")
    @classmethod
    def _in_range(cls, v: Vec2) -> Vec2:
        problem = coordinate_problem(v)
        if problem is not None:
            raise ValueError(problem)
        return v

    @field_validator("height")
    @classmethod
    def _not_too_tall(cls, v: float) -> float:
        return _height(v)

    @property
    def length(self) -> float:
        return float(math.dist(self.start, self.end))

    @property
    def direction(self) -> FloatArray:
        d = np.subtract(self.end, self.start)
        return d / max(float(np.linalg.norm(d)), 1e-12)

    @property
    def inward_normal(self) -> FloatArray:
        """Unit normal pointing into the room."""
        d = self.direction
        return np.array([-d[1], d[0]])

    @property
    def outward_normal(self) -> FloatArray:
        return -self.inward_normal

    def span(self, op: Opening) -> tuple[float, float]:
        """Where ``op`` (one of its openings) runs along the wall, clipped to the wall's length:
        ``(start, end)``, metres from the wall's start. A hole drawn past a wall's end (a source's
        door beside a corner whose wall was cut back) is only as wide as the wall it is cut in;
        the walls, the doorways and the doors hung in them all read it from here."""
        return max(op.center - op.width / 2.0, 0.0), min(op.center + op.width / 2.0, self.length)

    def gap(self, points: FloatArray) -> float:
        """Distance (metres) from the wall's line into the room to the nearest of ``points``
        (``(n, 2)`` XY, e.g. an object's footprint); negative when one lies behind the wall."""
        return float(((np.asarray(points)[:, :2] - np.asarray(self.start)) @ self.inward_normal).min())


class Room(_Model):
    """A room: floor polygon (counter-clockwise, metres, z = 0), walls and ceiling height."""

    id: ObjectId = "room"
    floor: list[Vec2] = Field(
        min_length=3, max_length=MAX_FLOOR_POINTS, description="Floor polygon, counter-clockwise seen from above."
    )
    walls: list[Wall] = Field(default_factory=list, max_length=MAX_FLOOR_POINTS)
    ceiling_height: float = Field(default=2.8, gt=0)

    @field_validator("ceiling_height")
    @classmethod
    def _not_too_tall(cls, v: float) -> float:
        return _height(v)

    @field_validator("floor")
    @classmethod
    def _ccw_polygon(cls, v: list[Vec2]) -> list[Vec2]:
        for i, p in enumerate(v):
            _check_finite(p, "floor point")
            problem = coordinate_problem(p)
            if problem is not None:
                raise ValueError(f"floor point {i}: {problem}")
        pts = np.asarray(v, dtype=np.float64)
        x, y = pts[:, 0], pts[:, 1]
        area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        if abs(area2) < 1e-9:
            raise ValueError("floor polygon has zero area")
        return v if area2 > 0 else list(reversed(v))

    @classmethod
    def from_polygon(cls, floor: list[Vec2], *, ceiling_height: float = 2.8, room_id: str = "room") -> Room:
        """A room with one wall per polygon edge (``wall_0`` ...), wall height = ceiling height."""
        room = cls(id=room_id, floor=floor, ceiling_height=ceiling_height)
        pts = room.floor
        room.walls = [
            Wall(id=f"wall_{i}", start=pts[i], end=pts[(i + 1) % len(pts)], height=ceiling_height)
            for i in range(len(pts))
        ]
        return room

    @classmethod
    def rectangle(
        cls, xmin: float, ymin: float, xmax: float, ymax: float, *, ceiling_height: float = 2.8
    ) -> Room:
        """An axis-aligned rectangular room."""
        return cls.from_polygon(
            [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)], ceiling_height=ceiling_height
        )

    def wall(self, wall_id: str) -> Wall:
        for w in self.walls:
            if w.id == wall_id:
                return w
        raise KeyError(wall_id)


SupportKind = Literal["attach", "contain"]


class Relation(_Model):
    """A relation between an object (``child``) and an anchor (``parent``).

    * ``attach``: the child rests on / hangs from / is mounted on the parent (its support).
    * ``contain``: the child is inside the parent (also its support); ``opening`` gives the
      side the container opens to, in the container's frame.
    * ``against``: the child stands flush against a wall (not a support); ``distance`` is
      the gap to the wall in metres.
    * ``faces``: the child (a seat, a sofa) is turned toward the parent (its table, desk,
      coffee table, TV stand), both in one local unit; not a support.
    * ``beside``: the child stands beside the parent as one group (nightstands at a bed's head),
      both in one local unit; not a support.

    ``parent`` is an anchor id: ``"floor"``, ``"ceiling"``, a wall id, or an object id.
    """

    kind: Literal["attach", "contain", "against", "faces", "beside"]
    child: ObjectId
    parent: ObjectId
    opening: Literal["front", "top", "back", "left", "right"] | None = None
    distance: float | None = Field(default=None, ge=0)
    source: str | None = Field(default=None, description="Agent or importer that stated the relation.")

    @property
    def is_support(self) -> bool:
        return self.kind in ("attach", "contain")


class ConstraintClause(_Model):
    """One unit's share of a cross-unit constraint; mentions only that unit's anchor and objects."""

    anchor_id: ObjectId
    related_objects: list[ObjectId] = Field(default_factory=list, max_length=32)
    layout_note: str = Field(max_length=400)


class CrossUnitConstraint(_Model):
    """A strong functional relation spanning two units, split into two per-unit clauses."""

    id: ObjectId
    kind: Literal["orientation", "placement"]
    description: str = Field(max_length=400)
    anchor_a: ConstraintClause
    anchor_b: ConstraintClause

    @model_validator(mode="after")
    def _different_anchors(self) -> CrossUnitConstraint:
        if self.anchor_a.anchor_id == self.anchor_b.anchor_id:
            raise ValueError("a cross-unit constraint needs two different anchors")
        return self


class LocalUnit(_Model):
    """An anchor with its immediate children: the unit that evolves independently.

    ``frame`` is the row-major 4x4 anchor frame in world coordinates; children poses in the
    unit frame are ``inv(frame) @ world``. ``projection`` is the view the unit is shown in.
    """

    anchor_id: ObjectId
    anchor_kind: Literal["floor", "wall", "ceiling", "object"]
    children: list[ObjectId] = Field(min_length=1)
    contained: bool = Field(default=False, description="True when the children are inside the anchor.")
    projection: Literal["top_down", "bottom_up", "wall_normal", "anchor_front"]
    frame: list[float] = Field(min_length=16, max_length=16)
    clauses: list[ConstraintClause] = Field(default_factory=list)


class SceneStructure(_Model):
    """Output of the structuring stage: local units in top-down order (parents before children)."""

    units: list[LocalUnit] = Field(default_factory=list)


def _unset(value: object) -> bool:
    return value is None or value == {} or value == []


class Provenance(_Model):
    """Where a scene came from and what has been done to it.

    The source facts below are filled by every reader that knows them (ProcTHOR, Holodeck,
    SceneEval...), so no layer above the readers looks into a format's own ``metadata``; those
    a source does not give are left out of the JSON."""

    source_format: str | None = None
    source_path: str | None = None
    importer: str | None = None
    steps: list[str] = Field(default_factory=list, description="Pipeline stages applied, in order.")
    notes: list[str] = Field(default_factory=list, description="Repairs and fallbacks worth knowing about.")
    room_type: str | None = Field(
        default=None, exclude_if=_unset, description="The room's kind as the source names it (ProcTHOR's 'LivingRoom')."
    )
    source_room_id: str | None = Field(
        default=None, exclude_if=_unset, description="The room's id in the source file (ProcTHOR's 'room|4')."
    )
    source_faults: list[str] = Field(
        default_factory=list,
        exclude_if=_unset,
        description="What the source file got wrong and the reader mended, each said once (an id given twice, a hole past its wall).",
    )
    size_estimates: dict[str, str] = Field(
        default_factory=dict,
        exclude_if=_unset,
        description="Objects whose asset the source's database does not hold, by id: how the reader sized their stand-ins.",
    )
    source_index: int | None = Field(
        default=None, exclude_if=_unset, description="The house's index in a dataset file (one house a line), from 0."
    )
    source_ids: dict[str, str] = Field(
        default_factory=dict, exclude_if=_unset, description="Each object's id in the source file, by object id."
    )
    asset_ids: dict[str, str] = Field(
        default_factory=dict, exclude_if=_unset, description="Each object's asset id in the source's database, by object id."
    )
    asset_database: str | None = Field(
        default=None, exclude_if=_unset, description="The asset database the source's asset ids were read against."
    )
    import_warnings: list[str] = Field(
        default_factory=list,
        exclude_if=_unset,
        description="What the reader accepted only because it was asked to (allow_orphans); a run reports it, degraded.",
    )


CLUTTER_METADATA = "clutter"
"""The key of ``Scene.metadata`` under which a clutter pass records the small objects it added or
moved (``docs/clutter.md``): ``{"mode": ..., "objects": {id: {"asset_id", "receptacle",
"placement"}}}``."""


class Scene(_Model):
    """A whole scene: room, objects, relations, structure, metadata and provenance.

    Construction validates the cross-references: unique object ids that do not collide with
    anchor ids, relation endpoints that exist, at most one support relation per object,
    constraints that name existing anchors and objects. Call :meth:`validate_references`
    again after editing a scene in place.
    """

    id: ObjectId = "scene"
    room: Room | None = None
    objects: list[SceneObject] = Field(default_factory=list)
    relations: list[Relation] = Field(default_factory=list)
    constraints: list[CrossUnitConstraint] = Field(default_factory=list)
    structure: SceneStructure | None = None
    metadata: dict[str, Any] = Field(default_factory=dict)
    provenance: Provenance = Field(default_factory=Provenance)

    @field_validator("objects", mode="before")
    @classmethod
    def _not_too_many(cls, v: Any) -> Any:
        """At most ``MAX_OBJECTS`` objects."""
        # before the items are validated: a huge list is refused without building its objects
        if isinstance(v, list | tuple):
            problem = object_count_problem(len(v))
            if problem is not None:
                raise ValueError(problem)
        return v

    @model_validator(mode="after")
    def _references(self) -> Scene:
        self.validate_references()
        return self

    # -- lookups -----------------------------------------------------------------------------
    def anchor_ids(self) -> set[str]:
        """Every id a relation may point to: floor, ceiling, walls and objects."""
        ids = {FLOOR, CEILING} | {o.id for o in self.objects}
        if self.room is not None:
            ids |= {w.id for w in self.room.walls}
        return ids

    def anchor_kind(self, anchor_id: str) -> Literal["floor", "wall", "ceiling", "object"]:
        """What kind of anchor an id names; raises ``KeyError`` for unknown ids."""
        if anchor_id == FLOOR:
            return "floor"
        if anchor_id == CEILING:
            return "ceiling"
        if self.room is not None and any(w.id == anchor_id for w in self.room.walls):
            return "wall"
        if any(o.id == anchor_id for o in self.objects):
            return "object"
        raise KeyError(anchor_id)

    def floor_root(self, object_id: str) -> str | None:
        """The floor-standing piece ``object_id`` rests on (itself when on the floor; a TV on its
        stand gives the stand), else ``None``: hung from a wall or the ceiling, resting on an id
        the scene does not hold, or a support cycle."""
        seen: set[str] = set()
        oid = object_id
        while oid not in seen:
            seen.add(oid)
            rel = self.support_of(oid)
            if rel is None or rel.parent == FLOOR:
                return oid
            try:
                if self.anchor_kind(rel.parent) != "object":
                    return None
            except KeyError:
                return None
            oid = rel.parent
        return None

    def get(self, object_id: str) -> SceneObject:
        """The object with this id; raises ``KeyError`` naming it."""
        for o in self.objects:
            if o.id == object_id:
                return o
        raise KeyError(f"no object with id {object_id!r}")

    def support_of(self, object_id: str) -> Relation | None:
        """The object's support relation (attach or contain), if it has one."""
        for r in self.relations:
            if r.child == object_id and r.is_support:
                return r
        return None

    def children_of(self, anchor_id: str) -> list[str]:
        """Ids of objects whose support relation points at ``anchor_id``, in object order."""
        kids = {r.child for r in self.relations if r.is_support and r.parent == anchor_id}
        return [o.id for o in self.objects if o.id in kids]

    # -- validation --------------------------------------------------------------------------
    def validate_references(self) -> None:
        """Check ids and cross-references; raise :class:`SceneValidationError` naming the culprit."""
        seen: set[str] = set()
        reserved = {FLOOR, CEILING} | ({w.id for w in self.room.walls} if self.room else set())
        for o in self.objects:
            if o.id in seen:
                raise SceneValidationError(f"duplicate object id {o.id!r}", object_id=o.id)
            if o.id in reserved:
                raise SceneValidationError(f"object id {o.id!r} collides with an anchor id", object_id=o.id)
            seen.add(o.id)
        anchors = seen | reserved
        supported: set[str] = set()
        for r in self.relations:
            if r.child not in seen:
                raise SceneValidationError(f"relation names unknown child {r.child!r}", object_id=r.child)
            if r.parent not in anchors:
                raise SceneValidationError(
                    f"object {r.child!r}: relation {r.kind!r} points at unknown anchor {r.parent!r}",
                    object_id=r.child,
                )
            if r.parent == r.child:
                raise SceneValidationError(f"object {r.child!r} cannot relate to itself", object_id=r.child)
            if r.is_support:
                if r.child in supported:
                    raise SceneValidationError(
                        f"object {r.child!r} has more than one support relation", object_id=r.child
                    )
                supported.add(r.child)
        for c in self.constraints:
            for clause in (c.anchor_a, c.anchor_b):
                if clause.anchor_id not in anchors:
                    raise SceneValidationError(
                        f"constraint {c.id!r} names unknown anchor {clause.anchor_id!r}",
                        object_id=clause.anchor_id,
                    )
                for oid in clause.related_objects:
                    if oid not in seen:
                        raise SceneValidationError(
                            f"constraint {c.id!r} names unknown object {oid!r}", object_id=oid
                        )

    def edit(self, expressions: str | Sequence[str], *, unit: LocalUnit | str | None = None) -> Scene:
        """A NEW scene with exact 2D edits of one local unit, in the pose expression language.

        ``scene.edit("chair_0.center.u = table_0.center.u", unit="floor")`` moves ``chair_0``
        across the floor (u, v in metres on the unit's anchor surface; see
        ``docs/evolution.md``); what rests on a moved object moves with it. ``unit`` (an anchor
        id or a :class:`LocalUnit`) defaults to the one unit every target belongs to. Several
        assignments may be given as a list or one per line. Refused input raises
        :class:`~scenemosaic.exceptions.ExpressionError` and leaves the scene untouched; no
        physics runs here (stabilize afterwards if needed).
        """
        from scenemosaic.scene._expressions import edit_scene

        return edit_scene(self, expressions, unit=unit)

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows the scene's plan (see :func:`register_plan_renderer`); ``None`` (the text
        repr) when no renderer is registered or the plan cannot be drawn."""
        return _plan_png(self)

    def to_json(self, *, indent: int | None = 2) -> str:
        """Canonical JSON text (stable key order, so equal scenes give identical bytes)."""
        return self.model_dump_json(indent=indent)

    @classmethod
    def from_json(cls, text: str | bytes) -> Scene:
        """Parse and validate a scene from JSON text."""
        return cls.model_validate_json(text)

    @classmethod
    def of_objects(cls, objects: list[SceneObject]) -> Scene:
        """A scene of only ``objects``, unchecked (``model_construct``): the world a check of a
        few pieces builds. Its other fields get their defaults here, each factory called as is:
        pydantic fills a constructed model's defaults by first reading each factory's signature,
        which parses text with ``ast``, and two threads parsing at once can fail on CPython 3.11
        (``SystemError: AST constructor recursion depth mismatch``; a unit's variants evolve in threads)."""
        defaults = {
            name: cast(Callable[[], Any], field.default_factory)()
            for name, field in cls.model_fields.items()
            if field.default_factory is not None and name != "objects"
        }
        return cls.model_construct(objects=objects, **defaults)

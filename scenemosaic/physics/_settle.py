"""Stabilizing one local unit: containment, snapping, separation, then gravity settling.

The steps, in order (all in the unit's support plane, see :mod:`._planar`):

1. **Containment** — each child's box footprint is moved by the smallest shift that puts it
   inside the anchor's surface (floor polygon, wall rectangle, anchor top). Children that
   cannot fit are centred on the surface and reported as larger than their anchor.
2. **Snap** — each child is moved along the gravity axis so it just touches its support:
   bottom on the floor or on the anchor's top (``contain``: the highest anchor piece below the
   child's centre), top against the ceiling, back against the wall.
3. **Separation** — deep interpenetrations between siblings, and with already-settled
   neighbours, are resolved in the plane (yaw kept) by pushing pairs apart along the
   separating axis of minimal overlap, re-projecting into the surface after every sweep.
4. **Settling** — the unit in MuJoCo with anchor-dependent gravity; the anchor, the room and
   the neighbours are static. Blow-ups fall back to a halved step with doubled iterations,
   then to rolling the culprits back to their pre-simulation pose.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import structlog
from shapely.geometry import Polygon

from scenemosaic.assets import compartment_fits, interior_boards
from scenemosaic.physics._hulls import ObjectShape
from scenemosaic.physics._planar import UnitFrame, unit_frame
from scenemosaic.physics._reports import UnitReport
from scenemosaic.physics._settings import (
    COLLISION_TOLERANCE_M,
    SEPARATION_GAP_M,
    SettleSettings,
    SimSettings,
)
from scenemosaic.physics._simulate import SimOutcome, run_until_settled
from scenemosaic.physics._units import UnitPlan
from scenemosaic.physics._world import BuiltWorld, JointMode, WorldBuilder
from scenemosaic.scene import (
    FloatArray,
    PackItem,
    PackResult,
    Pose,
    Scene,
    SceneObject,
    convex_hull_2d,
    edge_axes,
    is_thin,
    minimal_containing_shift,
    pack_surface,
    quat_from_matrix,
    quat_multiply,
    sat_overlap,
    traits,
)

__all__ = ["settle_unit"]

log = structlog.get_logger(__name__)

_VERTICAL_EPS = 0.004
"""Pieces overlapping by less than this along the gravity axis cannot collide beyond tolerance."""
_MAX_SWEEPS = 80
_MAX_SETTLE_TILT_DEG = 6.0
"""A child rocking further than this while settling is settled again with its tilt locked."""


@dataclass
class _Piece:
    uv: FloatArray  # convex polygon, CCW
    lo: float  # extent along the unit's up axis
    hi: float
    axes: FloatArray = field(init=False)  # edge normals, translation-invariant
    uv_lo: FloatArray = field(init=False)
    uv_hi: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        self.axes = edge_axes(self.uv) if len(self.uv) > 2 else np.eye(2)
        self.uv_lo = self.uv.min(axis=0)
        self.uv_hi = self.uv.max(axis=0)


@dataclass
class _Body:
    obj: SceneObject
    shape: ObjectShape
    matrix: FloatArray  # local-to-world, no scale, after containment + snap
    pieces: list[_Piece]
    box_uv: FloatArray
    shift: FloatArray  # accumulated in-plane shift during separation
    area: float
    movable: bool

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        allp = np.concatenate([p.uv for p in self.pieces]) + self.shift
        return allp.min(axis=0), allp.max(axis=0)


def _world_pieces(shape: ObjectShape, matrix: FloatArray, frame: UnitFrame) -> list[_Piece]:
    out: list[_Piece] = []
    for v in shape.world_vertices(matrix):
        h = frame.h(v)
        out.append(_Piece(convex_hull_2d(frame.uv(v)), float(h.min()), float(h.max())))
    return out


def _box_uv(obj: SceneObject, matrix: FloatArray, frame: UnitFrame) -> FloatArray:
    sx, sy, sz = (float(v) for v in obj.size)
    corners = np.array([[x, y, z] for x in (-sx / 2, sx / 2) for y in (-sy / 2, sy / 2) for z in (0.0, sz)])
    world = corners @ matrix[:3, :3].T + matrix[:3, 3]
    return convex_hull_2d(frame.uv(world))


def _translate(matrix: FloatArray, delta: FloatArray) -> FloatArray:
    out = matrix.copy()
    out[:3, 3] += delta
    return out


def _support_height(
    child_uv: FloatArray, child_lo: float, child_hi: float, anchor: list[_Piece], contained: bool
) -> float:
    poly = Polygon(child_uv) if len(child_uv) >= 3 else Polygon(child_uv).buffer(1e-4)
    under = [p for p in anchor if len(p.uv) >= 3 and Polygon(p.uv).intersects(poly)]
    if not under:
        under = anchor
    if contained:
        centre = (child_lo + child_hi) / 2
        below = [p.hi for p in under if p.hi <= centre]
        if below:
            return max(below)
    return max(p.hi for p in under)


def _pack_children(
    scene: Scene, plan: UnitPlan, frame: UnitFrame, shapes: Mapping[str, ObjectShape], anchor_pieces: list[_Piece]
) -> tuple[PackResult, dict[str, float]] | None:
    """Lay an object anchor's children out without overlap (``scene.pack_surface``): those on its
    top over the top, those inside it in its compartments (``assets.interior_boards``: each on
    the board its bottom is nearest above, or the next one it fits under). What fits where it
    stands stays; the rest goes to the nearest free place, small loose items may turn a quarter;
    a child wider than the top (a television on a narrower stand) is placed by what it stands on
    (its foot) and its box kept clear of the others. Returns the layout and, for children inside,
    the height (along ``frame.up``) of the board each rests on."""
    if frame.region is None:
        return None
    anchor = scene.get(plan.anchor_id)
    inside = [c for c in plan.children if (rel := scene.support_of(c)) is not None and rel.kind == "contain"]
    compartments = (
        interior_boards(anchor.asset.category or anchor.category, _size(anchor)) if anchor.asset.kind == "procedural" else []
    )
    if not compartments:
        inside = []
    levels: dict[float, tuple[Polygon, list[str]]] = {}
    for cid in plan.children:
        if cid not in inside:
            level, surface = _resting_surface(scene.get(cid), anchor_pieces, frame, frame.region)
            levels.setdefault(level, (surface, []))[1].append(cid)
    result = PackResult()
    for _, (surface, members) in sorted(levels.items()):
        result.merge(_pack_region(scene, members, frame, surface, shapes))
    heights: dict[str, float] = {}
    am = anchor.pose.matrix(with_scale=False)
    placed: dict[int, list[FloatArray]] = {}
    inside.sort(key=lambda c: -float(np.prod(_size(scene.get(c))[:2])))  # largest first, as pack_surface does
    for cid in inside:  # on the board its bottom is nearest above, else the nearest other with room
        child = scene.get(cid)
        if child.sim.static:
            continue  # held in place (a static piece is not packed): it stays where it stands
        bottom = float(child.aabb()[0][2]) - float(anchor.pose.position[2])
        fits = [k for k, c in enumerate(compartments) if compartment_fits(_size(child), c)]
        order = sorted(fits, key=lambda k: (compartments[k][4] > bottom + 0.05, abs(compartments[k][4] - bottom)))
        if not any(_fill_compartment(scene, cid, compartments[k], k, am, frame, placed, result, heights) for k in order):
            result.unplaced.append(cid)
    return result, heights


LEVEL_BAND_M = 0.03
"""Anchor pieces whose tops lie within this height of the level a child rests at make up the
surface it is laid out on (a bed's mattress, not its headboard; a toilet's tank lid, not its bowl)."""


def _resting_surface(
    child: SceneObject, anchor_pieces: list[_Piece], frame: UnitFrame, region: Polygon
) -> tuple[float, Polygon]:
    """The anchor surface ``child`` rests on, and its height rounded to a centimetre: the highest
    piece top under its footprint not above its bottom (by more than the band) that offers a real
    surface (a bed's side rail or built-in pillows just above its mattress do not: the mattress does)."""
    bottom = float(frame.h(child.corners()).min())
    foot = Polygon(_box_uv(child, child.pose.matrix(with_scale=False), frame))
    under = [p for p in anchor_pieces if len(p.uv) >= 3 and Polygon(p.uv).intersects(foot)]
    below = sorted({round(p.hi, 2) for p in under if p.hi <= bottom + LEVEL_BAND_M}, reverse=True)
    if not below:
        below = [round(max((p.hi for p in anchor_pieces), default=bottom), 2)]
    elif any(p.lo > below[0] + 0.01 for p in under):  # a board over it: it was inside, it goes on top
        below = [round(max(p.hi for p in under), 2)]
    elif below[0] < bottom - LEVEL_BAND_M:
        # standing at the height of a top it only overhangs (a roll at the front edge of a toilet's
        # tank, narrower than the asset it stands in for): that top, not the lid far below it
        tops = [p.hi for p in anchor_pieces if len(p.uv) >= 3 and abs(p.hi - bottom) <= LEVEL_BAND_M]
        if tops:
            below = [round(max(tops), 2), *below]
    for level in below:
        surface = _surface_at(level, anchor_pieces, region)
        if surface is not region:
            return level, surface
    return below[0], region


def _surface_at(level: float, anchor_pieces: list[_Piece], region: Polygon) -> Polygon:
    """The anchor's free surface at ``level``: the outline of its pieces whose tops lie there,
    less what rises above it, within ``region``; ``region`` itself when that leaves too little."""
    from shapely.ops import unary_union

    flat = [Polygon(p.uv) for p in anchor_pieces if len(p.uv) >= 3 and abs(p.hi - level) <= LEVEL_BAND_M]
    above = [Polygon(p.uv) for p in anchor_pieces if len(p.uv) >= 3 and p.hi > level + LEVEL_BAND_M and p.lo < level + 0.1]
    if not flat:
        return region
    surface = unary_union(flat)
    if above:
        surface = surface.difference(unary_union(above))
    surface = surface.intersection(region)
    if surface.is_empty or surface.area < 0.2 * region.area or surface.geom_type not in ("Polygon", "MultiPolygon"):
        return region
    return surface


def _child_item(scene: Scene, cid: str, frame: UnitFrame, region: Polygon | None = None) -> PackItem:
    """A child as a packing item: its box in the plane (moved to the middle of ``region`` when it
    stands elsewhere: an item overflowing from another board); loose small things may turn."""
    obj = scene.get(cid)
    box = _box_uv(obj, obj.pose.matrix(with_scale=False), frame)
    if region is not None and not region.contains(Polygon(box).centroid):
        box = box + (np.asarray(region.centroid.coords[0]) - box.mean(axis=0))
    loose = not obj.sim.static and traits(obj.category).placement == "surface"
    return PackItem(cid, box, movable=not obj.sim.static, may_turn=loose)


def _fill_compartment(
    scene: Scene,
    cid: str,
    compartment: tuple[float, float, float, float, float, float],
    k: int,
    am: FloatArray,
    frame: UnitFrame,
    placed: dict[int, list[FloatArray]],
    result: PackResult,
    heights: dict[str, float],
) -> bool:
    """Pack child ``cid`` into compartment ``k`` beside what it holds already (``placed``); on
    success record its shift and its board's height in ``result`` / ``heights``."""
    x0, x1, y0, y1, zb, _ = compartment
    rect = np.array([[x0, y0, zb], [x1, y0, zb], [x1, y1, zb], [x0, y1, zb]]) @ am[:3, :3].T + am[:3, 3]
    region = Polygon(convex_hull_2d(frame.uv(rect)))
    item = _child_item(scene, cid, frame, region)
    fixed = [PackItem(f"placed_{n}", c, movable=False) for n, c in enumerate(placed.get(k, []))]
    part = pack_surface(region, [*fixed, item])
    if cid in part.unplaced:
        return False
    own = _box_uv(scene.get(cid), scene.get(cid).pose.matrix(with_scale=False), frame)
    result.shifts[cid] = part.shifts[cid] + item.corners.mean(axis=0) - own.mean(axis=0)
    if cid in part.turned:
        result.turned.add(cid)
    heights[cid] = float(frame.h(rect[:1])[0])
    placed.setdefault(k, []).append(part.footprint(item))
    return True


def _size(obj: SceneObject) -> tuple[float, float, float]:
    """The object's box size (extents times scale) as a plain triple."""
    sx, sy, sz = (float(v) for v in obj.size)
    return sx, sy, sz


def _pack_region(
    scene: Scene, children: list[str], frame: UnitFrame, region: Polygon, shapes: Mapping[str, ObjectShape]
) -> PackResult:
    """``pack_surface`` of ``children`` over ``region``, then those wider than it placed by their base."""
    items = [_child_item(scene, cid, frame) for cid in children]
    first = pack_surface(region, items)
    if not first.unplaced:
        return first
    placed_by_base: dict[str, FloatArray] = {}
    for cid in first.unplaced:
        obj = scene.get(cid)
        m = obj.pose.matrix(with_scale=False)
        base = shapes[cid].base_vertices() @ m[:3, :3].T + m[:3, 3]
        base_uv = convex_hull_2d(frame.uv(base))
        shift = minimal_containing_shift(base_uv, region)
        if shift is None and frame.region is not None:  # not even its foot fits the level: the anchor's box top
            shift = minimal_containing_shift(base_uv, frame.region)
        if shift is not None:
            placed_by_base[cid] = shift
    if not placed_by_base:
        return first
    items = [
        PackItem(i.id, i.corners + placed_by_base[i.id], movable=False) if i.id in placed_by_base else i for i in items
    ]
    second = pack_surface(region, items)
    for cid, shift in placed_by_base.items():
        second.shifts[cid] = shift
    return second


def _quarter_turn(matrix: FloatArray, frame: UnitFrame) -> FloatArray:
    """``matrix`` turned 90 degrees about the support's up axis through the object's origin."""
    axis = frame.up / np.linalg.norm(frame.up)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    turn = np.eye(3) + k + k @ k  # Rodrigues' formula at 90 degrees
    out = matrix.copy()
    out[:3, :3] = turn @ matrix[:3, :3]
    return out


def _pair_push(a: _Body, b: _Body, gap: float) -> tuple[float, FloatArray] | None:
    """Largest in-plane push needed to part two bodies' vertically overlapping pieces."""
    best: tuple[float, FloatArray] | None = None
    reach = max(gap, 0.0) + 1e-6
    for pa in a.pieces:
        alo, ahi = pa.uv_lo + a.shift, pa.uv_hi + a.shift
        for pb in b.pieces:
            if min(pa.hi, pb.hi) - max(pa.lo, pb.lo) <= _VERTICAL_EPS:
                continue
            blo, bhi = pb.uv_lo + b.shift, pb.uv_hi + b.shift
            if (
                alo[0] > bhi[0] + reach
                or blo[0] > ahi[0] + reach
                or alo[1] > bhi[1] + reach
                or blo[1] > ahi[1] + reach
            ):
                continue
            axes = np.concatenate([pa.axes, pb.axes])
            depth, axis = sat_overlap(pa.uv + a.shift, pb.uv + b.shift, axes)
            need = depth + gap
            if need > 1e-5 and (best is None or need > best[0]):
                best = (need, axis)
    return best


def _contain_shift(body: _Body, region: Polygon | None) -> FloatArray | None:
    if region is None:
        return np.zeros(2)
    return minimal_containing_shift(body.box_uv + body.shift, region)


def _separate(
    movers: list[_Body], obstacles: list[_Body], region: Polygon | None, rng: np.random.Generator
) -> list[tuple[str, str]]:
    """Push overlapping bodies apart in the plane; returns pairs still overlapping beyond tolerance."""
    everyone = movers + obstacles
    for _ in range(_MAX_SWEEPS):
        worst = 0.0
        bounds = [b.bounds() for b in everyone]
        for i, a in enumerate(movers):
            for j in range(i + 1, len(everyone)):
                b = everyone[j]
                (alo, ahi), (blo, bhi) = bounds[i], bounds[j]
                if np.any(alo > bhi + SEPARATION_GAP_M) or np.any(blo > ahi + SEPARATION_GAP_M):
                    continue
                push = _pair_push(a, b, SEPARATION_GAP_M)
                if push is None:
                    continue
                need, axis = push
                ca, cb = (alo + ahi) / 2, (blo + bhi) / 2
                if float(np.linalg.norm(cb - ca)) < 1e-9:  # coincident: the push direction is a coin flip
                    axis = axis * (1.0 if rng.random() < 0.5 else -1.0)
                step = need + 1e-4
                if b.movable:
                    wa = b.area / (a.area + b.area)
                    a.shift = a.shift - axis * step * wa
                    b.shift = b.shift + axis * step * (1.0 - wa)
                else:
                    a.shift = a.shift - axis * step
                worst = max(worst, need)
        for body in movers:
            fix = _contain_shift(body, region)
            if fix is not None:
                body.shift = body.shift + fix
        if worst <= 1e-4:
            break
    left: list[tuple[str, str]] = []
    for i, a in enumerate(movers):
        for j in range(i + 1, len(everyone)):
            push = _pair_push(a, everyone[j], -COLLISION_TOLERANCE_M)
            if push is not None:
                left.append((a.obj.id, everyone[j].obj.id))
    return left


def _posed(b: _Body) -> SceneObject:
    return b.obj.model_copy(update={"pose": _pose_from_matrix(b.matrix, b.obj.pose)})


def _tilt_deg(quat: FloatArray) -> float:
    """Angle between a rotation's image of +Z and +Z, degrees."""
    _, x, y, _ = (float(v) for v in quat)
    cos_tilt = 1.0 - 2.0 * (x * x + y * y)
    return math.degrees(math.acos(max(-1.0, min(1.0, cos_tilt))))


def _simulate(
    scene: Scene,
    frame: UnitFrame,
    anchor: tuple[SceneObject, ObjectShape] | None,
    movers: list[_Body],
    statics: list[tuple[SceneObject, ObjectShape]],
    sim: SimSettings,
    settle: SettleSettings,
    mode: JointMode,
) -> tuple[BuiltWorld, SimOutcome]:
    builder = WorldBuilder(sim, gravity_dir=-frame.up)
    builder.add_room(scene.room)
    if anchor is not None:
        builder.add_static(*anchor)
    for obj, shape in statics:
        builder.add_static(obj, shape)
    for body in movers:
        builder.add_dynamic(_posed(body), body.shape, mode=mode, tilt_axes=(frame.e1, frame.e2))
    world = builder.compile()
    return world, run_until_settled(world, settle)


def _pose_from_matrix(matrix: FloatArray, like: Pose) -> Pose:
    """The pose of a body's matrix: its position, and its rotation when it differs from ``like``'s
    (a child turned a quarter to fit its surface); ``like``'s own quaternion otherwise, bit for bit."""
    position = (float(matrix[0, 3]), float(matrix[1, 3]), float(matrix[2, 3]))
    quaternion = like.quaternion
    if not np.allclose(matrix[:3, :3], like.matrix(with_scale=False)[:3, :3], atol=1e-9):
        quaternion = quat_from_matrix(matrix[:3, :3])
    return Pose(position=position, quaternion=quaternion, scale=like.scale)


def settle_unit(
    scene: Scene,
    plan: UnitPlan,
    shapes: Mapping[str, ObjectShape],
    neighbours: Sequence[str],
    *,
    sim: SimSettings,
    settle: SettleSettings,
    seed: int,
) -> tuple[dict[str, Pose], UnitReport]:
    """Stabilize one unit of ``scene`` (read-only) and return the children's new poses and a report.

    ``neighbours`` are ids of objects already stabilized elsewhere: they stay where they are and
    act as obstacles for separation and as static bodies in the simulation.
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    report = UnitReport(
        anchor_id=plan.anchor_id, anchor_kind=plan.anchor_kind, depth=plan.depth, children=list(plan.children)
    )
    anchor_obj = scene.get(plan.anchor_id) if plan.anchor_kind == "object" else None
    frame = unit_frame(
        scene, plan.anchor_id, plan.anchor_kind, anchor_obj.footprint() if anchor_obj else None
    )
    anchor_pieces = (
        _world_pieces(shapes[anchor_obj.id], anchor_obj.pose.matrix(with_scale=False), frame)
        if anchor_obj
        else []
    )

    laid_out = _pack_children(scene, plan, frame, shapes, anchor_pieces) if plan.anchor_kind == "object" else None
    packed, boards = laid_out if laid_out is not None else (None, {})
    bodies: list[_Body] = []
    for cid in plan.children:
        obj = scene.get(cid)
        shape = shapes[cid]
        matrix = obj.pose.matrix(with_scale=False)
        # static children (hung lamps, mounted TVs) are still placed inside and onto their anchor;
        # "static" only keeps them fixed while the dynamic siblings settle
        movable = not obj.sim.static
        if packed is not None and cid in packed.turned:
            matrix = _quarter_turn(matrix, frame)
            report.turned.append(cid)
        box_uv = _box_uv(obj, matrix, frame)
        if frame.region is not None:
            if packed is not None and (cid in packed.shifts or cid in packed.unplaced):
                shift: FloatArray | None = packed.shifts.get(cid)
            else:
                shift = minimal_containing_shift(box_uv, frame.region)
            if shift is None:
                report.larger_than_anchor.append(cid)
                centre = np.asarray(frame.region.centroid.coords[0])
                shift = centre - box_uv.mean(axis=0)
            if float(np.linalg.norm(shift)) > 1e-6:
                report.containment_moves[cid] = round(float(np.linalg.norm(shift)), 6)
                matrix = _translate(matrix, frame.lift(shift))
        pieces = _world_pieces(shape, matrix, frame)
        lo = min(p.lo for p in pieces)
        hi = max(p.hi for p in pieces)
        if frame.support_h is not None:
            target = frame.support_h
        elif cid in boards:  # inside: on the board of its compartment
            target = boards[cid]
        else:
            rel = scene.support_of(cid)
            contained = rel is not None and rel.kind == "contain"
            foot = convex_hull_2d(np.concatenate([p.uv for p in pieces]))
            target = _support_height(foot, lo, hi, anchor_pieces, contained)
        matrix = _translate(matrix, frame.up * (target - lo))
        pieces = _world_pieces(shape, matrix, frame)
        area = max(float(Polygon(box_uv).area) if len(box_uv) >= 3 else 0.0, 1e-4)
        bodies.append(
            _Body(obj, shape, matrix, pieces, _box_uv(obj, matrix, frame), np.zeros(2), area, movable)
        )

    movers = [b for b in bodies if b.movable and not is_thin(b.obj)]
    obstacles = [b for b in bodies if not b.movable and not is_thin(b.obj)]
    for nid in neighbours:
        nobj = scene.get(nid)
        if is_thin(nobj):
            continue
        m = nobj.pose.matrix(with_scale=False)
        obstacles.append(
            _Body(
                nobj,
                shapes[nid],
                m,
                _world_pieces(shapes[nid], m, frame),
                _box_uv(nobj, m, frame),
                np.zeros(2),
                1.0,
                False,
            )
        )
    if anchor_obj is not None:
        am = anchor_obj.pose.matrix(with_scale=False)
        obstacles.append(
            _Body(
                anchor_obj,
                shapes[anchor_obj.id],
                am,
                anchor_pieces,
                _box_uv(anchor_obj, am, frame),
                np.zeros(2),
                1.0,
                False,
            )
        )
    report.unresolved_overlaps = _separate(movers, obstacles, frame.region, rng)
    for b in movers:
        dist = float(np.linalg.norm(b.shift))
        if dist > 1e-6:
            report.separation_moves[b.obj.id] = round(dist, 6)
            b.matrix = _translate(b.matrix, frame.lift(b.shift))
            if frame.support_h is None:  # the anchor's top may differ under the new footprint
                pieces = _world_pieces(b.shape, b.matrix, frame)
                lo, hi = min(p.lo for p in pieces), max(p.hi for p in pieces)
                rel = scene.support_of(b.obj.id)
                target = boards.get(b.obj.id) or _support_height(
                    convex_hull_2d(np.concatenate([p.uv for p in pieces])),
                    lo,
                    hi,
                    anchor_pieces,
                    rel is not None and rel.kind == "contain",
                )
                b.matrix = _translate(b.matrix, frame.up * (target - lo))

    # the world: dynamic children, static anchor / neighbours / fixed children nearby
    dyn = [b for b in bodies if b.movable]
    near = _nearby(dyn, [o for o in obstacles if o.obj.id != plan.anchor_id])
    anchor = (anchor_obj, shapes[anchor_obj.id]) if anchor_obj is not None else None
    mode: JointMode = "tilt" if plan.anchor_kind in ("floor", "object") else "slide"
    attempts: list[tuple[str, SimSettings]] = [
        ("default", sim),
        ("half_step", replace(sim, timestep=sim.timestep / 2, iterations=sim.iterations * 2)),
    ]
    rolled: list[str] = []
    outcome = SimOutcome()
    world: BuiltWorld | None = None
    for label, settings in attempts:
        world, outcome = _simulate(scene, frame, anchor, dyn, near, settings, settle, mode)
        report.steps += outcome.steps
        report.simulated_s += outcome.simulated_s
        if not outcome.blown_up:
            break
        report.fallbacks.append(f"{label}: blow-up of {sorted(outcome.blown_up)}")
    if outcome.blown_up:
        rolled = sorted(outcome.blown_up)
        keep = [b for b in dyn if b.obj.id not in rolled]
        frozen = near + [(_posed(b), b.shape) for b in dyn if b.obj.id in rolled]
        world, outcome = _simulate(scene, frame, anchor, keep, frozen, attempts[-1][1], settle, mode)
        report.steps += outcome.steps
        report.simulated_s += outcome.simulated_s
        if outcome.blown_up:
            rolled = sorted(b.obj.id for b in dyn)
            world = None
        report.fallbacks.append("rollback")
    if world is not None and mode == "tilt":
        tilted = [
            wb.object_id
            for wb in world.bodies
            if _tilt_deg(world.data.xquat[wb.body_id]) > _MAX_SETTLE_TILT_DEG
        ]
        if tilted:  # rocking onto an unstable resting pose: settle again upright
            report.fallbacks.append(f"tilt_locked: {sorted(tilted)} tilted over {_MAX_SETTLE_TILT_DEG:g} deg")
            keep = [b for b in dyn if b.obj.id not in rolled]
            frozen = near + [(_posed(b), b.shape) for b in dyn if b.obj.id in rolled]
            world, outcome = _simulate(scene, frame, anchor, keep, frozen, sim, settle, "slide")
            report.steps += outcome.steps
            report.simulated_s += outcome.simulated_s
            if outcome.blown_up:
                rolled = sorted(b.obj.id for b in dyn)
                world = None
    report.rolled_back = rolled
    report.converged = outcome.converged and not rolled

    poses: dict[str, Pose] = {b.obj.id: _pose_from_matrix(b.matrix, b.obj.pose) for b in bodies}
    if world is not None:
        for wb in world.bodies:
            obj = scene.get(wb.object_id)
            xq = world.data.xquat[wb.body_id]
            quat = quat_multiply(xq, poses[wb.object_id].quaternion)  # the pose it was laid out in (turned or not)
            pos = world.data.xpos[wb.body_id]
            poses[wb.object_id] = Pose(
                position=(float(pos[0]), float(pos[1]), float(pos[2])), quaternion=quat, scale=obj.pose.scale
            )
    report.simulated_s = round(report.simulated_s, 6)
    report.wall_s = round(time.perf_counter() - t0, 6)
    log.debug(
        "unit_settled",
        anchor=plan.anchor_id,
        steps=report.steps,
        converged=report.converged,
        wall_s=report.wall_s,
    )
    return poses, report


def _nearby(
    dyn: list[_Body], candidates: list[_Body], margin: float = 0.3
) -> list[tuple[SceneObject, ObjectShape]]:
    """Static bodies whose plane bounds come within ``margin`` of any dynamic child."""
    if not dyn:
        return []
    lo = np.min([b.bounds()[0] for b in dyn], axis=0) - margin
    hi = np.max([b.bounds()[1] for b in dyn], axis=0) + margin
    out: list[tuple[SceneObject, ObjectShape]] = []
    for c in candidates:
        clo, chi = c.bounds()
        if np.all(clo <= hi) and np.all(chi >= lo):
            out.append((_posed(c) if c.movable else c.obj, c.shape))
    return out

"""Furniture whose own drawers, doors or lids cannot open where it stands: moved the least that lets them.

A fridge flush to a side wall on its hinge side opens 88° and stops; a wardrobe whose door meets the
nightstand placed beside it opens 24°. For each floor-standing piece with a part that does not open
as far as a person or a robot needs (``assets.kept_free``: 90° for a door's hinge, or its whole
range; a lid's whole range, the walls only to 90°; 80 % of a drawer's travel), measured with the
free-space model of the delivered open states (``assets.short_parts``: the part's box swept from
closed against the room's walls and every other object's box), the piece slides sideways along
its own width (parallel to the wall it backs to) by the smallest step of :data:`SHIFT_STEP_M` up to
:data:`SHIFT_MOST_M`, either way, that lets every one of its parts open that far without closing
any part it left open, stays within the room and makes no new collision; what rests on it moves
with it. When it has no such place, what stops its part (``assets.part_blockers``) is moved out of
the way instead, one piece after another (at most :data:`MOST_BLOCKERS`), each the least way that
takes it out of every part's path: a floor-standing piece (the nightstand beside a wardrobe) along
its width, keeping its functional relations (beside its bed's head); a small object (beside a
microwave on a counter, on a toilet's lid) anywhere on its support, onto the support's top where it
lands (from the lid to the cistern), only where a piece of its support bears it (``_borne``: never
off the support's pieces to the floor beside a toilet's pedestal, nor half over an edge). The moves are kept only when the parts then open. A part
with no such repair stays blocked and is reported (``PartRepair.stuck``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenemosaic.assets import object_articulation, part_blockers, parts_clear_of, short_parts
from scenemosaic.physics._checks import collision_report_for
from scenemosaic.physics._hulls import ObjectShape
from scenemosaic.physics._settings import OOB_MIN_INSIDE_FRACTION
from scenemosaic.scene import FLOOR, Scene, SceneObject, functional_holds, functional_relations, rigid_moves

__all__ = ["SHIFT_MOST_M", "SHIFT_STEP_M", "PartRepair", "free_part_paths"]

SHIFT_STEP_M = 0.01
"""Step of the sideways shifts tried, m."""
SHIFT_MOST_M = 0.30
"""The farthest a piece is shifted to let its parts open, m."""
CLEAR_MARGIN_M = 0.02
"""How far clear of a part's path a small object moved out of it must stand, sideways, m: settling
moves a small object by a centimetre or so (a floor-standing piece stays where it is put)."""
RESTING_M = 0.02
"""A small object whose base is this near its support's top under it rests there, m."""
SMALL_STEP_M = 0.02
"""Spacing of the grid of places a small object is tried at on its support, m."""
_SLACK = 1e-4


@dataclass
class PartRepair:
    """What :func:`free_part_paths` did: the pieces moved (id -> metres) and those whose parts still
    do not open (id -> the parts)."""

    moved: dict[str, float] = field(default_factory=dict)
    stuck: dict[str, list[str]] = field(default_factory=dict)
    freed: dict[str, str] = field(default_factory=dict)
    """Each piece moved -> the piece whose parts its move lets open (itself, or what it stood before)."""

    def notes(self) -> list[str]:
        """One provenance note per piece moved or left with a part that does not open."""
        out = [
            f"parts: moved {oid} {d:.2f} m aside so " + ("its parts open" if self.freed.get(oid, oid) == oid else f"{self.freed[oid]}'s parts open")
            for oid, d in sorted(self.moved.items())
        ]  # fmt: skip
        return out + [f"parts: {oid}'s {', '.join(parts)} cannot open where it stands" for oid, parts in sorted(self.stuck.items())]


def _short(scene: Scene, oid: str, base_dir: str | Path | None) -> set[str]:
    """The parts of ``oid`` that do not open as far as their use needs."""
    return set(short_parts(scene, base_dir, [oid]).get(oid, []))


def free_part_paths(
    scene: Scene, shapes: Mapping[str, ObjectShape], base_dir: str | Path | None = None
) -> tuple[Scene, PartRepair]:
    """Let every part of ``scene`` that cannot open where its piece stands open, the smallest way:
    the piece slid sideways, else what stops its part moved aside (see the module docstring);
    returns the repaired scene (a copy; the input is kept) and what moved. A scene whose parts all
    open comes back unchanged."""
    repair = PartRepair()
    if scene.room is None:
        return scene, repair
    repaired = scene
    for oid in short_parts(scene, base_dir):
        short = _short(repaired, oid, base_dir)
        if not short:  # an earlier move freed it
            continue
        moved = _shifted(repaired, shapes, oid, oid, base_dir) if _standing(repaired, oid) else None
        if moved is not None:
            repaired, repair.moved[oid] = moved
            repair.freed[oid] = oid
            continue
        # else what stops it (furniture, or small objects beside it or on it), each the least way
        # aside, one after the other (a lid's path may hold several), kept only if all of it opens
        trial, moves = _blockers_moved(repaired, shapes, oid, base_dir)
        if _short(trial, oid, base_dir):
            repair.stuck[oid] = sorted(short)
            continue
        repaired = trial
        for mover, d in moves.items():
            repair.moved[mover] = d
            repair.freed[mover] = oid
    if repair.moved or repair.stuck:  # a moved scene shares its provenance with the input: a new one
        notes = [*repaired.provenance.notes, *repair.notes()]
        repaired = repaired.model_copy(update={"provenance": repaired.provenance.model_copy(update={"notes": notes})})
    return repaired, repair


MOST_BLOCKERS = 4
"""How many pieces in one part's way the repair moves aside at most."""


def _blockers_moved(
    scene: Scene,
    shapes: Mapping[str, ObjectShape],
    holder: str,
    base_dir: str | Path | None,
    moved: frozenset[str] = frozenset(),
    budget: list[int] | None = None,
) -> tuple[Scene, dict[str, float]]:
    """``scene`` with what stops ``holder``'s parts moved aside so that they open, one piece after
    another (each out of every part's way), and the moves; ``scene`` and no moves when no such
    sequence is found. A small search: each piece's :data:`MOVES_TRIED` least moves are tried in
    turn (the least move of a sponge off a lid may take the one place the soap beside it needs),
    :data:`SEARCH_MOST` moves in all (a part boxed in by many things gives up in bounded time)."""
    budget = [SEARCH_MOST] if budget is None else budget
    if not _short(scene, holder, base_dir):
        return scene, {}
    if len(moved) >= MOST_BLOCKERS:
        return scene, {}
    for blocker in _blockers(scene, holder, base_dir):
        if blocker in moved:
            continue
        for k, (trial, d) in enumerate(_shifts(scene, shapes, blocker, holder, base_dir)):
            if k >= MOVES_TRIED or budget[0] <= 0:
                break
            budget[0] -= 1
            done, more = _blockers_moved(trial, shapes, holder, base_dir, moved | {blocker}, budget)
            if not _short(done, holder, base_dir):
                return done, {blocker: d, **more}
        if budget[0] <= 0:
            break
    return scene, {}


MOVES_TRIED = 3
"""How many of a piece's least moves out of a part's way the repair tries before giving up on it."""
SEARCH_MOST = 24
"""How many moves the search for one part's repair tries in all."""


def _standing(scene: Scene, oid: str) -> bool:
    rel = scene.support_of(oid)
    return rel is None or rel.parent == FLOOR


def _stoppers(scene: Scene, oid: str, base_dir: str | Path | None) -> set[str]:
    """Everything that stops a part of ``oid`` (``assets.part_blockers``)."""
    return {b for stoppers in part_blockers(scene, oid, base_dir).values() for b in stoppers}


def _blockers(scene: Scene, oid: str, base_dir: str | Path | None) -> list[str]:
    """What stops a part of ``oid`` (``assets.part_blockers``; not the walls), nearest first: pieces
    standing on the floor, and small objects standing on furniture (beside a microwave on a counter)."""
    found = _stoppers(scene, oid, base_dir) - {"wall"}
    movable = [b for b in found if _standing(scene, b) or scene.anchor_kind(scene.support_of(b).parent) == "object"]  # type: ignore[union-attr]
    here = np.asarray(scene.get(oid).pose.position[:2])
    return sorted(
        movable, key=lambda b: (float(np.linalg.norm(np.asarray(scene.get(b).pose.position[:2]) - here)), b)
    )


def _shifted(
    scene: Scene, shapes: Mapping[str, ObjectShape], mover: str, holder: str, base_dir: str | Path | None
) -> tuple[Scene, float] | None:
    """The least move of :func:`_shifts`, or ``None``."""
    return next(_shifts(scene, shapes, mover, holder, base_dir), None)


def _shifts(
    scene: Scene, shapes: Mapping[str, ObjectShape], mover: str, holder: str, base_dir: str | Path | None
) -> Iterator[tuple[Scene, float]]:
    """``scene`` with ``mover`` shifted along its width (a small object: anywhere on its support)
    every way that lets ``holder`` (itself: every part of it opens) or whose parts it stops (it is
    out of their way) open, least shift first, each with the shift: within the room, with no new
    collision, no part of another piece closed that opened and, for a piece moved out of the way,
    every functional relation of it kept (a nightstand beside its bed's head)."""
    obj = scene.get(mover)
    frame = obj.pose.matrix(with_scale=False)[:3, :3]
    standing = _standing(scene, mover)
    near = _near(scene, mover, holder, base_dir)
    short_before = short_parts(scene, base_dir, near)
    relations = (
        [r for r in functional_relations(scene) if mover == r.subject or mover in r.group]
        if mover != holder
        else []
    )
    if standing:  # a piece on the floor slides along its width (along its wall)
        steps = np.arange(SHIFT_STEP_M, SHIFT_MOST_M + 1e-9, SHIFT_STEP_M)
        offsets = [frame[:2, 0] * float(s * sign) for s in steps for sign in (1, -1)]
    else:  # a small object anywhere on its support: a grid of places about it, nearest first
        ticks = np.arange(-SHIFT_MOST_M, SHIFT_MOST_M + 1e-9, SMALL_STEP_M)
        grid = [
            frame[:2, 0] * a + frame[:2, 1] * b
            for a in ticks
            for b in ticks
            if 1e-9 < math.hypot(a, b) <= SHIFT_MOST_M + 1e-9
        ]
        offsets = sorted(grid, key=lambda o: (round(float(np.linalg.norm(o)), 9), float(o[0]), float(o[1])))
    support = None if standing else scene.support_of(mover)
    for offset in offsets:
        x, y, z = obj.pose.position
        d = float(np.linalg.norm(offset))
        x, y = x + float(offset[0]), y + float(offset[1])
        if (
            support is not None and support.parent in shapes
        ):  # resting: up or down with its support's top (a lid to the cistern)
            base = scene.get(support.parent)
            x0, y0, _ = obj.pose.position
            below = _top_under(base, shapes[support.parent], x0, y0)
            if abs(z - below) <= RESTING_M:
                top = _top_under(base, shapes[support.parent], x, y)
                if not _borne(base, shapes[support.parent], obj, offset, top):
                    continue  # off its support's pieces (down beside a toilet's pedestal), or half over an edge
                z += top - below
        pose = obj.pose.model_copy(update={"position": (x, y, z)})
        candidate = rigid_moves(scene, {mover: pose})
        trial = scene.model_copy(
            update={
                "objects": [
                    o.model_copy(update={"pose": candidate[o.id]}) if o.id in candidate else o
                    for o in scene.objects
                ]
            }
        )
        if mover == holder and _short(trial, holder, base_dir):
            continue
        if mover != holder and not parts_clear_of(
            trial, holder, mover, base_dir, 0.0 if standing else CLEAR_MARGIN_M
        ):
            continue
        if not _inside(trial, mover) or not (standing or _on_support(trial, mover)):
            continue
        moved_ids = set(candidate)
        if any((p.a in moved_ids) != (p.b in moved_ids) for p in collision_report_for(trial, shapes).pairs):
            continue
        short_now = short_parts(trial, base_dir, near)
        if any(set(parts) - set(short_before.get(oid, [])) for oid, parts in short_now.items()):
            continue  # it would close a part that opened
        if not all(functional_holds(trial, r) for r in relations):
            continue
        yield trial, d


def _borne(support: SceneObject, shape: ObjectShape, obj: SceneObject, offset: np.ndarray, top: float) -> bool:
    """Whether a small object moved by ``offset`` would stand on a piece of its support: one lies
    under its centre (top ``top``), and under the points halfway from its centre to each corner of
    its footprint a piece as high (within :data:`RESTING_M`): not off the support's pieces onto
    the floor, nor tipping over an edge."""
    if top <= RESTING_M:
        return False
    centre = np.asarray(obj.pose.position[:2], dtype=np.float64) + offset
    corners = np.asarray(obj.footprint(), dtype=np.float64) + offset
    return all(
        _top_under(support, shape, float(p[0]), float(p[1])) >= top - RESTING_M for p in (centre + corners) / 2.0
    )


def _top_under(support: SceneObject, shape: ObjectShape, x: float, y: float) -> float:
    """The height of ``support``'s highest piece over the point ``(x, y)`` (its pieces' tops, seen
    from above; a piece's top taken flat), 0 where no piece is under it."""
    from shapely.geometry import MultiPoint, Point

    point, tops = Point(x, y), []
    for piece in shape.world_vertices(support.pose.matrix(with_scale=False)):
        hull = MultiPoint(piece[:, :2]).convex_hull
        if hull.area > 1e-8 and hull.covers(point):
            tops.append(float(piece[:, 2].max()))
    return max(tops, default=0.0)


def _inside(scene: Scene, oid: str) -> bool:
    """Whether ``oid``'s footprint stays within the room's floor polygon."""
    from shapely.geometry import Point, Polygon

    assert scene.room is not None
    floor = Polygon(scene.room.floor).buffer(1e-3)
    return all(floor.covers(Point(float(x), float(y))) for x, y in scene.get(oid).footprint())


def _on_support(scene: Scene, oid: str) -> bool:
    """Whether a small object still stands on its support: its footprint over the support's as
    validation asks (``OOB_MIN_INSIDE_FRACTION`` of it, :func:`check_out_of_bounds`)."""
    from shapely.geometry import Polygon

    rel = scene.support_of(oid)
    if rel is None or scene.anchor_kind(rel.parent) != "object":
        return False
    own = Polygon(scene.get(oid).footprint())
    if own.area <= 0.0:
        return False
    inside = own.intersection(Polygon(scene.get(rel.parent).footprint())).area / own.area
    return bool(inside >= OOB_MIN_INSIDE_FRACTION)


def _near(scene: Scene, oid: str, holder: str, base_dir: str | Path | None, reach: float = 1.5) -> list[str]:
    """The articulated objects (but ``holder``) within ``reach`` metres of ``oid``, whose parts a
    shift of it (at most :data:`SHIFT_MOST_M`) may close."""
    here = np.asarray(scene.get(oid).pose.position[:2])
    return [
        o.id for o in scene.objects
        if o.id != holder and np.linalg.norm(np.asarray(o.pose.position[:2]) - here) < reach and object_articulation(o, base_dir)
    ]  # fmt: skip

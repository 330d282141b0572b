"""Furniture whose own drawers, doors or lids cannot open where it stands: moved the least that lets them.

A fridge flush to a side wall on its hinge side opens 88° and stops; a wardrobe whose door meets the
nightstand placed beside it opens 24°. For each floor-standing piece with a part that does not open
as far as a person or a robot needs (``assets.usable_value``: 90° for a hinge, or its whole range;
80 % of a drawer's travel), measured with the free-space model of the delivered open states
(``assets.short_parts``: the part's box swept from closed against the room's walls and every
other object's box), the piece slides sideways along its own width (parallel to the wall it backs
to) by the smallest step of :data:`SHIFT_STEP_M` up to :data:`SHIFT_MOST_M`, either way, that lets
every one of its parts open that far without closing any part it left open, stays within the
room and makes no new collision; what rests on it moves with it. When it has no such place, the
floor-standing piece that stops its part (``assets.part_blockers``: the nightstand beside a
wardrobe) is shifted the same way instead, keeping its functional relations (beside its bed's
head), or a small object that stops it (beside a microwave on a counter) along its support,
staying on it. A part with neither stays blocked and is reported (``PartRepair.stuck``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenemosaic.assets import object_articulation, part_blockers, short_parts
from scenemosaic.physics._checks import collision_report_for
from scenemosaic.physics._hulls import ObjectShape
from scenemosaic.scene import FLOOR, Scene, functional_holds, functional_relations, rigid_moves

__all__ = ["SHIFT_MOST_M", "SHIFT_STEP_M", "PartRepair", "free_part_paths"]

SHIFT_STEP_M = 0.01
"""Step of the sideways shifts tried, m."""
SHIFT_MOST_M = 0.30
"""The farthest a piece is shifted to let its parts open, m."""
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
        mover = oid
        moved = _shifted(repaired, shapes, oid, oid, base_dir) if _standing(repaired, oid) else None
        # else what stops it (furniture, or a small object beside it), each the least way aside
        for blocker in [] if moved is not None else _blockers(repaired, oid, base_dir):
            moved = _shifted(repaired, shapes, blocker, oid, base_dir)
            if moved is not None:
                mover = blocker
                break
        if moved is None:
            repair.stuck[oid] = sorted(short)
            continue
        repaired, repair.moved[mover] = moved
        repair.freed[mover] = oid
    if repair.moved or repair.stuck:  # a moved scene shares its provenance with the input: a new one
        notes = [*repaired.provenance.notes, *repair.notes()]
        repaired = repaired.model_copy(update={"provenance": repaired.provenance.model_copy(update={"notes": notes})})
    return repaired, repair


def _standing(scene: Scene, oid: str) -> bool:
    rel = scene.support_of(oid)
    return rel is None or rel.parent == FLOOR


def _blockers(scene: Scene, oid: str, base_dir: str | Path | None) -> list[str]:
    """What stops a part of ``oid`` (``assets.part_blockers``; not the walls), nearest first: pieces
    standing on the floor, and small objects standing on furniture (beside a microwave on a counter)."""
    found = {b for stoppers in part_blockers(scene, oid, base_dir).values() for b in stoppers if b != "wall"}
    movable = [b for b in found if _standing(scene, b) or scene.anchor_kind(scene.support_of(b).parent) == "object"]  # type: ignore[union-attr]
    here = np.asarray(scene.get(oid).pose.position[:2])
    return sorted(movable, key=lambda b: (float(np.linalg.norm(np.asarray(scene.get(b).pose.position[:2]) - here)), b))


def _shifted(
    scene: Scene, shapes: Mapping[str, ObjectShape], mover: str, holder: str, base_dir: str | Path | None
) -> tuple[Scene, float] | None:
    """``scene`` with ``mover`` (``holder`` itself, or what stops its parts) shifted the least along
    its width that lets every part of ``holder`` open, within the room, with no new collision, no
    part of another piece closed that opened and, for a piece moved out of the way, every functional
    relation of it kept (a nightstand beside its bed's head); ``None`` if no shift does."""
    obj = scene.get(mover)
    frame = obj.pose.matrix(with_scale=False)[:3, :3]
    standing = _standing(scene, mover)
    # a piece on the floor slides along its width (along its wall); a small object anywhere on its support
    ways = [frame[:, 0]] if standing else [frame[:, 0], frame[:, 1]]
    near = _near(scene, mover, holder, base_dir)
    short_before = short_parts(scene, base_dir, near)
    relations = [r for r in functional_relations(scene) if mover == r.subject or mover in r.group] if mover != holder else []
    steps = np.arange(SHIFT_STEP_M, SHIFT_MOST_M + 1e-9, SHIFT_STEP_M)
    shifts = sorted(((float(s * sign), k) for s in steps for sign in (1, -1) for k in range(len(ways))), key=lambda t: (abs(t[0]), t[1], t[0]))
    for d, k in shifts:
        x, y, z = obj.pose.position
        way = ways[k]
        pose = obj.pose.model_copy(update={"position": (x + float(way[0] * d), y + float(way[1] * d), z)})
        candidate = rigid_moves(scene, {mover: pose})
        trial = scene.model_copy(
            update={"objects": [o.model_copy(update={"pose": candidate[o.id]}) if o.id in candidate else o for o in scene.objects]}
        )
        if _short(trial, holder, base_dir) or not _inside(trial, mover) or not (standing or _on_support(trial, mover)):
            continue
        moved_ids = set(candidate)
        if any((p.a in moved_ids) != (p.b in moved_ids) for p in collision_report_for(trial, shapes).pairs):
            continue
        short_now = short_parts(trial, base_dir, near)
        if any(set(parts) - set(short_before.get(oid, [])) for oid, parts in short_now.items()):
            continue  # it would close a part that opened
        if not all(functional_holds(trial, r) for r in relations):
            continue
        return trial, abs(float(d))
    return None


def _inside(scene: Scene, oid: str) -> bool:
    """Whether ``oid``'s footprint stays within the room's floor polygon."""
    from shapely.geometry import Point, Polygon

    assert scene.room is not None
    floor = Polygon(scene.room.floor).buffer(1e-3)
    return all(floor.covers(Point(float(x), float(y))) for x, y in scene.get(oid).footprint())


def _on_support(scene: Scene, oid: str) -> bool:
    """Whether a small object still stands on its support: its centre over the support's footprint."""
    from shapely.geometry import Point, Polygon

    rel = scene.support_of(oid)
    if rel is None or scene.anchor_kind(rel.parent) != "object":
        return False
    x, y, _ = scene.get(oid).pose.position
    return bool(Polygon(scene.get(rel.parent).footprint()).covers(Point(float(x), float(y))))


def _near(scene: Scene, oid: str, holder: str, base_dir: str | Path | None, reach: float = 1.5) -> list[str]:
    """The articulated objects (but ``holder``) within ``reach`` metres of ``oid``, whose parts a
    shift of it (at most :data:`SHIFT_MOST_M`) may close."""
    here = np.asarray(scene.get(oid).pose.position[:2])
    return [
        o.id for o in scene.objects
        if o.id != holder and np.linalg.norm(np.asarray(o.pose.position[:2]) - here) < reach and object_articulation(o, base_dir)
    ]  # fmt: skip

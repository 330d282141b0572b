"""The order in which local units are stabilized: top-down through the support tree."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Literal

from scenemosaic.scene import CEILING, FLOOR, Scene

__all__ = ["UnitPlan", "plan_units"]

AnchorKind = Literal["floor", "wall", "ceiling", "object"]


@dataclass(frozen=True)
class UnitPlan:
    """One local unit to stabilize: an anchor, its immediate children and its depth in the tree.

    Units of equal depth never contain each other's anchors, so they may run in parallel.
    """

    anchor_id: str
    anchor_kind: AnchorKind
    children: tuple[str, ...]
    depth: int


def plan_units(scene: Scene) -> tuple[list[UnitPlan], list[str]]:
    """Units in top-down order (floor, ceiling, walls, then object anchors breadth-first).

    The tree is read from the scene's support relations (the same relations
    ``build_structure`` turns into ``scene.structure``). Objects without a support relation,
    or caught in a support cycle, are treated as standing on the floor; their ids are returned
    second so the caller can report them.
    """
    parent: dict[str, str] = {}
    defaulted: list[str] = []
    for o in scene.objects:
        rel = scene.support_of(o.id)
        parent[o.id] = rel.parent if rel is not None else FLOOR
        if rel is None:
            defaulted.append(o.id)
    kids: dict[str, list[str]] = {}
    for o in scene.objects:  # object order keeps the plan deterministic
        kids.setdefault(parent[o.id], []).append(o.id)

    walls = [w.id for w in scene.room.walls] if scene.room is not None else []
    roots: list[tuple[str, AnchorKind]] = [(FLOOR, "floor"), (CEILING, "ceiling")]
    roots += [(w, "wall") for w in walls]
    units: list[UnitPlan] = []
    reached: set[str] = set()
    queue: deque[tuple[str, AnchorKind, int]] = deque((a, k, 0) for a, k in roots)
    while queue:
        anchor, kind, depth = queue.popleft()
        children = tuple(c for c in kids.get(anchor, []) if c not in reached)
        if not children:
            continue
        reached.update(children)
        units.append(UnitPlan(anchor, kind, children, depth))
        queue.extend((c, "object", depth + 1) for c in children)

    stranded = [o.id for o in scene.objects if o.id not in reached]
    if stranded:  # support cycles: put them on the floor, after everything else at depth 0
        defaulted.extend(stranded)
        floor_units = [u for u in units if u.anchor_id == FLOOR]
        if floor_units:
            fu = floor_units[0]
            units[units.index(fu)] = UnitPlan(FLOOR, "floor", fu.children + tuple(stranded), 0)
        else:
            units.insert(0, UnitPlan(FLOOR, "floor", tuple(stranded), 0))
        reached.update(stranded)
        queue.extend((c, "object", 1) for c in stranded)
        while queue:
            anchor, kind, depth = queue.popleft()
            children = tuple(c for c in kids.get(anchor, []) if c not in reached)
            if children:
                reached.update(children)
                units.append(UnitPlan(anchor, kind, children, depth))
                queue.extend((c, "object", depth + 1) for c in children)
    units.sort(key=lambda u: u.depth)  # stable: keeps floor, ceiling, walls, then BFS order
    return units, defaulted

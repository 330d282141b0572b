"""The pose a scene's drawers, doors and lids are delivered in (``--open-state``).

A scene delivered other than closed records, in its metadata under :data:`OPEN_STATE_KEY`, the
state asked for, the seed it was drawn from and the joint value of every part that stands open::

    "open_state": {"state": "random", "seed": 7, "parts": {"dresser_1": {"drawer_0": 0.31}}}

Every export reads the values from there (:func:`part_openings`), so they agree with each other
and with ``scene.json``; a part not listed is closed, and a value is held within the part's
limits. What stands in a drawer (an object whose base lies in the drawer's box) is moved with
the drawer when the state is applied (:func:`open_scene`), so ``scene.json`` holds it where it
is delivered. A scene in the default pose (furniture closed, the rooms' doors open) carries no
such key, nor does a closed one without doors: its files are those of a scene that never heard of
open states; ``closed`` in a room with doors is recorded, for it shuts the doors too
(``with_room_doors``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, overload

import numpy as np

from scenemosaic.assets._articulation import OPEN_STATES, OpenState, PartSpec, opening
from scenemosaic.assets._objects import object_articulation
from scenemosaic.scene import House, Scene, SceneObject

__all__ = ["OPEN_STATE_KEY", "open_scene", "part_openings"]

OPEN_STATE_KEY = "open_state"
"""The key of a scene's (and a house's) metadata holding the delivered pose of its parts."""

CONTENT_DROP_TOLERANCE_M = 0.02
"""How far below a drawer's box an object's base may lie and still count as standing in it, m."""


def part_openings(scene: Scene | House) -> dict[str, dict[str, float]]:
    """Object id -> part name -> joint value, for every part ``scene``'s metadata lists open
    (``{}`` for a closed scene). The values are as recorded; clamp each with
    :meth:`PartSpec.clamped`."""
    record = scene.metadata.get(OPEN_STATE_KEY)
    if not isinstance(record, Mapping):
        return {}
    parts = record.get("parts")
    if not isinstance(parts, Mapping):
        return {}
    out: dict[str, dict[str, float]] = {}
    for object_id, values in parts.items():
        if isinstance(values, Mapping):
            out[str(object_id)] = {
                str(k): float(v)
                for k, v in values.items()
                if isinstance(v, int | float) and not isinstance(v, bool)
            }
    return out


def _moved_contents(
    objects: list[SceneObject], holder: SceneObject, part: PartSpec, before: float, after: float
) -> dict[str, SceneObject]:
    """The objects standing in drawer ``part`` of ``holder`` (at joint value ``before``), shifted
    with it to ``after``."""
    m = holder.pose.matrix(with_scale=False)
    axis = np.asarray(part.axis, dtype=np.float64)
    x0, x1, y0, y1, z0, z1 = part.box
    lo = np.array([x0, y0, z0 - CONTENT_DROP_TOLERANCE_M])
    hi = np.array([x1, y1, z1])
    shift = m[:3, :3] @ (axis * (after - before))
    out: dict[str, SceneObject] = {}
    for other in objects:
        if other.id == holder.id:
            continue
        local = m[:3, :3].T @ (np.asarray(other.pose.position, dtype=np.float64) - m[:3, 3]) - axis * before
        if bool(np.all(local >= lo - 1e-6)) and bool(np.all(local <= hi + 1e-6)):
            position = tuple(float(v) for v in np.asarray(other.pose.position) + shift)
            out[other.id] = other.model_copy(
                update={"pose": other.pose.model_copy(update={"position": position})}
            )
    return out


def _hangs_doors(scene: Scene) -> bool:
    """Whether a door leaf hangs in one of the room's walls (``docs/articulation.md``)."""
    return scene.room is not None and any(op.leaf_count > 0 for w in scene.room.walls for op in w.openings)


def _recorded(state: OpenState | None, scene: Scene) -> bool:
    """Whether ``state`` is written down: ``open`` and ``random`` always, ``closed`` where the
    room's doors hang in it (they are delivered open unless told), the default (``None``) never."""
    return state is not None and (state != "closed" or _hangs_doors(scene))


@overload
def open_scene(scene: Scene, state: OpenState | None, seed: int = 0, base_dir: str | Path | None = None) -> Scene: ...


@overload
def open_scene(scene: House, state: OpenState | None, seed: int = 0, base_dir: str | Path | None = None) -> House: ...


def open_scene(
    scene: Scene | House, state: OpenState | None, seed: int = 0, base_dir: str | Path | None = None
) -> Scene | House:
    """``scene`` with its parts in ``state`` (``random`` drawn from ``seed``, see
    :func:`~scenemosaic.assets.opening`): the metadata key :data:`OPEN_STATE_KEY` set and what
    stands in each drawer moved with it, from the pose the scene held before. ``None`` is the
    default pose: the furniture closed and the key dropped, so the room's doors are delivered open
    (``with_room_doors``); ``closed`` closes those too, so it records the key in a room with doors
    and drops it elsewhere. ``base_dir`` resolves mesh assets' relative uris (their declared
    parts). A scene that is closed and stays so, its key unchanged, is returned as it is (the same
    object). A :class:`~scenemosaic.scene.House` has every room opened, its own metadata recording
    the state too (its ``parts`` every room's together) when a room records it."""
    if isinstance(scene, House):  # every room, the house recording the state too
        return _open_house(scene, state, seed, base_dir)
    if state is not None and state not in OPEN_STATES:
        raise ValueError(f"open state must be one of {', '.join(OPEN_STATES)}, not {state!r}")
    furniture: OpenState = state if state is not None else "closed"
    before = part_openings(scene)
    objects = list(scene.objects)
    values: dict[str, dict[str, float]] = {}
    for holder in scene.objects:
        for part in object_articulation(holder, base_dir):
            value = part.clamped(opening(part, furniture, seed=seed, key=holder.id))
            old = part.clamped(before.get(holder.id, {}).get(part.name, 0.0))
            if value != 0.0:
                values.setdefault(holder.id, {})[part.name] = value
            if part.joint == "slide" and value != old:
                moved = _moved_contents(objects, holder, part, old, value)
                objects = [moved.get(o.id, o) for o in objects]
    metadata = {k: v for k, v in scene.metadata.items() if k != OPEN_STATE_KEY}
    if _recorded(state, scene):
        metadata[OPEN_STATE_KEY] = {"state": state, "seed": seed, "parts": values}
    if furniture == "closed" and metadata.get(OPEN_STATE_KEY) == scene.metadata.get(OPEN_STATE_KEY):
        return scene
    return scene.model_copy(update={"objects": objects, "metadata": metadata})


def _open_house(house: House, state: OpenState | None, seed: int, base_dir: str | Path | None) -> House:
    """:func:`open_scene` of a whole house."""
    rooms = [open_scene(room, state, seed, base_dir) for room in house.rooms]
    metadata: dict[str, Any] = {k: v for k, v in house.metadata.items() if k != OPEN_STATE_KEY}
    if any(_recorded(state, room) for room in house.rooms):
        parts: dict[str, dict[str, float]] = {}
        for room in rooms:
            parts.update(part_openings(room))
        metadata[OPEN_STATE_KEY] = {"state": state, "seed": seed, "parts": parts}
    if (
        (state is None or state == "closed")
        and metadata.get(OPEN_STATE_KEY) == house.metadata.get(OPEN_STATE_KEY)
        and all(r is o for r, o in zip(rooms, house.rooms, strict=True))
    ):
        return house
    return house.model_copy(update={"rooms": rooms, "metadata": metadata})

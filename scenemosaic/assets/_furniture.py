"""Procedural builders of furniture: room doors, beds, chests, cabinets, wardrobes, fridges, counters,
tables, desks, seats, sofas, bookshelves and TV stands (``_procedural.py`` names them; the
module docstring there says what every builder promises)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from scenemosaic.assets._articulation import (
    ROOM_DOOR_OPEN_DEG,
    Box6,
    HingeSide,
    PartSpec,
    front_door,
)
from scenemosaic.assets._shapes import (
    Articulated,
    Interval,
    Parts,
    _blob,
    _box,
    _box6,
    _cap,
    _centered,
    _cyl,
    _drawers,
    _hinge_sides,
    _legs,
    _split,
)

__all__ = ["ROOM_DOOR_CATEGORIES", "ROOM_DOOR_HANDLE_PROUD_M", "ROOM_DOOR_JAMB_M", "ROOM_DOOR_LEAF_M", "SHELF_PITCH"]

# --------------------------------------------------------------------------------------------
# builders: (w, d, h) -> convex parts filling [-w/2, w/2] x [-d/2, d/2] x [0, h], front -Y
# --------------------------------------------------------------------------------------------
ROOM_DOOR_LEAF_M = 0.04
"""Thickness of a room door's leaf, metres (a hollow-core interior door)."""
ROOM_DOOR_JAMB_M = 0.02
"""Width of each jamb of a room door's frame, metres: the jambs line the hole's sides (never in the
wall itself), the leaf hangs between them."""
ROOM_DOOR_HANDLE_PROUD_M = 0.06
"""How far a room door's lever handle stands proud of each face of the leaf, metres."""
ROOM_DOOR_CATEGORIES: dict[tuple[HingeSide, ...], str] = {
    ("-x",): "room_door",
    ("+x",): "room_door_right",
    ("-x", "+x"): "room_double_door",
}
"""The procedural model of a room's door by the jambs its leaves hang on, seen from the side they
swing to: one leaf on its left (-X) jamb, one on its right (+X), a pair meeting in the middle."""
_ROOM_DOOR_GAP_M = 0.005  # between a leaf's free edge and its jamb (or the other leaf)
_ROOM_DOOR_FLOOR_GAP_M = 0.015  # under the leaf: it clears a rug


def _room_door(w: float, d: float, h: float, *, hinges: tuple[HingeSide, ...]) -> Articulated:
    """A room's door: the two jambs of its frame (what does not move) and one leaf per hinge side
    between them, closed in the plane of the frame; a lever handle on each face of a leaf near its
    free edge, the one on the front (-Y, the side it swings to) the handle a gripper takes. Each
    leaf turns about the front edge on its jamb (:func:`front_door`, up to
    :data:`ROOM_DOOR_OPEN_DEG`). ``w`` is the hole's width, ``d`` the leaf's thickness plus both
    handles."""
    hx = w / 2
    jamb = min(ROOM_DOOR_JAMB_M, 0.05 * w)
    proud = d * ROOM_DOOR_HANDLE_PROUD_M / (ROOM_DOOR_LEAF_M + 2 * ROOM_DOOR_HANDLE_PROUD_M)
    t = d - 2 * proud
    x0, x1 = -hx + jamb, hx - jamb
    parts: Parts = [_box((-hx, x0), (-t / 2, t / 2), (0.0, h)), _box((x1, hx), (-t / 2, t / 2), (0.0, h))]
    gap = min(_ROOM_DOOR_GAP_M, 0.01 * (x1 - x0))
    if len(hinges) == 1:
        spans = [(x0, x1 - gap) if hinges[0] == "-x" else (x0 + gap, x1)]
    else:
        mid = 0.5 * (x0 + x1)
        spans = [(x0, mid - gap / 2), (mid + gap / 2, x1)]
    z = (min(_ROOM_DOOR_FLOOR_GAP_M, 0.01 * h), h - min(_ROOM_DOOR_GAP_M, 0.005 * h))
    zc, zh = min(1.0, 0.5 * h), min(0.015, 0.01 * h)
    specs: list[PartSpec] = []
    for i, (xr, side) in enumerate(zip(spans, hinges, strict=True)):
        free = xr[1] if side == "-x" else xr[0]
        inward = -1.0 if side == "-x" else 1.0  # from the free edge toward the hinge
        length = min(0.12, 0.3 * (xr[1] - xr[0]))
        a = free + inward * min(0.05, 0.1 * (xr[1] - xr[0]))
        hxr = (min(a, a + inward * length), max(a, a + inward * length))
        pieces = [
            _box(xr, (-t / 2, t / 2), z),
            _box(hxr, (-d / 2, -t / 2), (zc - zh, zc + zh)),
            _box(hxr, (t / 2, d / 2), (zc - zh, zc + zh)),
        ]
        start = len(parts)
        parts.extend(pieces)
        boxes = [_box6(p) for p in pieces]
        name = "leaf" if len(hinges) == 1 else f"leaf_{i}"
        specs.append(
            front_door(name, range(start, start + 3), start + 1, boxes, hinge=side, open_deg=ROOM_DOOR_OPEN_DEG)
        )
    return parts, [], specs


def _room_door_left(w: float, d: float, h: float) -> Articulated:
    """A room's door hung on its left (-X) jamb, seen from the side it swings to."""
    return _room_door(w, d, h, hinges=("-x",))


def _room_door_right(w: float, d: float, h: float) -> Articulated:
    """A room's door hung on its right (+X) jamb, seen from the side it swings to."""
    return _room_door(w, d, h, hinges=("+x",))


def _room_double_door(w: float, d: float, h: float) -> Articulated:
    """A room's double door: two leaves, one on each jamb, meeting in the middle."""
    return _room_door(w, d, h, hinges=("-x", "+x"))


def _bed(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    head_t = _cap(d, 0.06, 0.08)
    leg_h, frame_top, mattress_top = 0.15 * h, 0.32 * h, 0.5 * h
    foot_y = (-hy, hy - head_t)
    parts = _legs((-hx, hx), foot_y, (0.0, leg_h), _cap(w, 0.08, 0.08), _cap(d, 0.06, 0.08))
    parts.append(_box((-hx, hx), foot_y, (leg_h, frame_top)))
    parts.append(
        _box((-hx + 0.02 * w, hx - 0.02 * w), (-hy + 0.02 * d, hy - head_t), (frame_top, mattress_top))
    )
    parts.append(_box((-hx, hx), (hy - head_t, hy), (0.0, h)))  # headboard at the back (+Y)
    pillow_y = (hy - head_t - 0.18 * d, hy - head_t - 0.03 * d)
    pillow_z = (mattress_top, mattress_top + 0.08 * h)
    n_pillows = 2 if w > 1.1 else 1
    for xr in _split(-hx + 0.08 * w, hx - 0.08 * w, n_pillows, 0.06 * w):
        parts.append(_blob(xr, pillow_y, pillow_z))
    return parts


def _nightstand_layout(w: float, d: float, h: float) -> Articulated:
    """Hollow bedside chest: two drawers at the front (-Y), each a box that slides out."""
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.02), _cap(d, 0.04, 0.02)
    parts, _, body_z = _hollow_case(
        w, d, h, plinth=0.08 * h, top=_cap(h, 0.06, 0.03), front=handle + front, boards=[]
    )
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    insides, specs = _drawers(
        parts,
        (-hx + 0.05 * w, hx - 0.05 * w),
        (body_z[0] + 0.04 * h, body_z[1] - 0.04 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        2,
        1,
        handle=handle,
        thickness=front,
    )
    return parts, insides, specs


SHELF_PITCH = 0.4
"""Target height (m) of one compartment of a hollow container: a board every 0.35-0.45 m or so."""


def _shelf_centres(z0: float, z1: float, board: float, most: int = 5) -> list[float]:
    """Centres of evenly spaced boards between the free heights ``z0`` and ``z1`` (one per ~0.4 m)."""
    free = z1 - z0
    n = int(np.clip(round(free / SHELF_PITCH) - 1, 0, most))
    if n == 0 or free <= n * board:
        return []
    gap = (free - n * board) / (n + 1)
    return [z0 + i * gap + (i - 0.5) * board for i in range(1, n + 1)]


def _hollow_case(
    w: float,
    d: float,
    h: float,
    *,
    plinth: float,
    top: float,
    front: float,
    boards: Sequence[float] | None = None,
) -> tuple[Parts, list[Box6], Interval]:
    """A hollow carcass open to -Y behind a front band of depth ``front`` (left for doors/drawer fronts).

    Side walls and back from the floor up, an inset plinth, a bottom board on it, a full-size top
    board, and interior boards at ``boards`` (their centre heights; default: one per ~0.4 m of
    inner height). Returns the parts, the free compartments (inside the walls, from the carcass
    front plane to the back, from one board's top to the next one's underside) and the body's z
    (plinth top to top board), where the fronts go.
    """
    hx, hy = w / 2, d / 2
    wall = _cap(w, 0.04, 0.018)
    back = _cap(d, 0.04, 0.012)
    board = _cap(h, 0.03, 0.018)
    y0 = -hy + front
    ceiling = h - top
    ix, iy = (-hx + wall, hx - wall), (y0, hy - back)
    floor = plinth + board
    parts = [
        _box((-hx, -hx + wall), (y0, hy), (0.0, ceiling)),
        _box((hx - wall, hx), (y0, hy), (0.0, ceiling)),
        _box(ix, (hy - back, hy), (0.0, ceiling)),
        _box(ix, (y0 + 0.05 * (iy[1] - y0), iy[1]), (0.0, plinth)),
        _box(ix, iy, (plinth, floor)),
        _box((-hx, hx), (-hy, hy), (ceiling, h)),
    ]
    centres = _shelf_centres(floor, ceiling, board) if boards is None else list(boards)
    levels = [floor]
    for zc in centres:
        lo_z, hi_z = max(zc - board / 2, levels[-1]), min(zc + board / 2, ceiling)
        if hi_z - lo_z <= 0.2 * board or hi_z >= ceiling:
            continue
        parts.append(_box(ix, iy, (lo_z, hi_z)))
        levels += [lo_z, hi_z]
    levels.append(ceiling)
    compartments = [
        (ix[0], ix[1], iy[0], iy[1], levels[i], levels[i + 1])
        for i in range(0, len(levels), 2)
        if levels[i + 1] > levels[i]
    ]
    return parts, compartments, (plinth, ceiling)


def _dresser_layout(w: float, d: float, h: float) -> Articulated:
    """Hollow chest of three rows of drawers (two columns when wider than 0.9 m), each drawer a
    box that slides out; what is in the chest is in its drawers."""
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.02), _cap(d, 0.04, 0.02)
    plinth, top = 0.07 * h, _cap(h, 0.05, 0.03)
    rows, cols = 3, (2 if w > 0.9 else 1)
    parts, _, _ = _hollow_case(w, d, h, plinth=plinth, top=top, front=handle + front, boards=[])
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    insides, specs = _drawers(
        parts,
        (-hx + 0.04 * w, hx - 0.04 * w),
        (plinth + 0.03 * h, h - top - 0.03 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        rows,
        cols,
        handle=handle,
        thickness=front,
    )
    return parts, insides, specs


def _door_count(w: float) -> int:
    """One door up to 0.6 m of width, else pairs of doors about 0.55 m wide each (at most six)."""
    if w <= 0.6:
        return 1
    return int(min(6, 2 * max(1, round(w / 1.1))))


def _doored_layout(w: float, d: float, h: float, *, cornice: float) -> Articulated:
    """Wardrobe/cabinet: hollow carcass with shelves, doors at the front (-Y) hung by the
    hinge-side rule (``_hinge_sides``), a vertical handle near each door's free edge."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.04, 0.025), _cap(d, 0.04, 0.025)
    parts, compartments, body_z = _hollow_case(
        w, d, h, plinth=_cap(h, 0.05, 0.1), top=cornice, front=handle + door
    )
    n_doors = _door_count(w)
    door_z = (body_z[0] + 0.01 * h, body_z[1] - 0.01 * h)
    specs: list[PartSpec] = []
    xrs = _split(-hx + 0.02 * w, hx - 0.02 * w, n_doors, 0.01)
    for i, (xr, side) in enumerate(zip(xrs, _hinge_sides(n_doors), strict=True)):
        # the handle near the door's free edge: the right one for a door hung on its left edge
        edge = xr[1] - 0.1 * (xr[1] - xr[0]) if side == "-x" else xr[0] + 0.1 * (xr[1] - xr[0])
        hw = 0.02 * (xr[1] - xr[0])
        zc, zh = 0.5 * (door_z[0] + door_z[1]), 0.12 * (door_z[1] - door_z[0])
        pieces = [
            _box(xr, (-hy + handle, -hy + handle + door), door_z),
            _box((edge - hw, edge + hw), (-hy, -hy + handle), (zc - zh, zc + zh)),
        ]
        start = len(parts)
        parts.extend(pieces)
        boxes = [_box6(p) for p in pieces]
        specs.append(front_door(f"door_{i}", (start, start + 1), start + 1, boxes, hinge=side))
    return parts, compartments, specs


def _counter_layout(w: float, d: float, h: float) -> Articulated:
    """Kitchen counter: a row of drawers under the top (one over each pair of doors), a board
    under them, and a cupboard below behind doors hung by the hinge-side rule; what is in the
    counter is in its drawers or on the cupboard's floor."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.04, 0.025), _cap(d, 0.04, 0.025)
    top, plinth, board = _cap(h, 0.05, 0.04), _cap(h, 0.05, 0.1), _cap(h, 0.03, 0.018)
    split = h - top - min(0.2 * h, 0.18)
    parts, compartments, body_z = _hollow_case(
        w, d, h, plinth=plinth, top=top, front=handle + door, boards=[split - board / 2]
    )
    n_doors = _door_count(w)
    specs: list[PartSpec] = []
    door_z = (body_z[0] + 0.01 * h, split - 0.01 * h)
    xrs = _split(-hx + 0.02 * w, hx - 0.02 * w, n_doors, 0.01)
    for i, (xr, side) in enumerate(zip(xrs, _hinge_sides(n_doors), strict=True)):
        edge = xr[1] - 0.1 * (xr[1] - xr[0]) if side == "-x" else xr[0] + 0.1 * (xr[1] - xr[0])
        hw = 0.02 * (xr[1] - xr[0])
        zc, zh = door_z[1] - 0.15 * (door_z[1] - door_z[0]), 0.08 * (door_z[1] - door_z[0])
        pieces = [
            _box(xr, (-hy + handle, -hy + handle + door), door_z),
            _box((edge - hw, edge + hw), (-hy, -hy + handle), (zc - zh, zc + zh)),
        ]
        start = len(parts)
        parts.extend(pieces)
        specs.append(
            front_door(f"door_{i}", (start, start + 1), start + 1, [_box6(p) for p in pieces], hinge=side)
        )
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    insides, drawers = _drawers(
        parts,
        (-hx + 0.02 * w, hx - 0.02 * w),
        (split + 0.01 * h, body_z[1] - 0.01 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        1,
        (n_doors + 1) // 2,
        handle=handle,
        thickness=door,
    )
    return parts, [*compartments[:-1], *insides], [*specs, *drawers]


def _wardrobe_layout(w: float, d: float, h: float) -> Articulated:
    return _doored_layout(w, d, h, cornice=_cap(h, 0.04, 0.06))


def _cabinet_layout(w: float, d: float, h: float) -> Articulated:
    return _doored_layout(w, d, h, cornice=_cap(h, 0.05, 0.03))


def _fridge_layout(w: float, d: float, h: float) -> Articulated:
    """Hollow fridge: a freezer door above a larger fridge door, a board behind the split, shelves.
    Both doors hang on their left (-X) edge, their handles at the right."""
    hx, hy = w / 2, d / 2
    handle, door = _cap(d, 0.05, 0.035), _cap(d, 0.05, 0.04)
    plinth, top = _cap(h, 0.03, 0.04), _cap(h, 0.03, 0.03)
    board = _cap(h, 0.03, 0.018)
    floor, ceiling = plinth + board, h - top
    split = floor + 0.68 * (ceiling - floor)
    boards = [
        *_shelf_centres(floor, split - board / 2, board),
        split,
        *_shelf_centres(split + board / 2, ceiling, board, most=3),
    ]
    parts, compartments, body_z = _hollow_case(
        w, d, h, plinth=plinth, top=top, front=handle + door, boards=boards
    )
    gap = 0.005 * h
    door_x = (-hx + 0.01 * w, hx - 0.01 * w)
    specs: list[PartSpec] = []
    for name, zr in (("door_fridge", (body_z[0], split - gap)), ("door_freezer", (split + gap, body_z[1]))):
        span = zr[1] - zr[0]
        pieces = [
            _box(door_x, (-hy + handle, -hy + handle + door), zr),
            _box((hx - 0.14 * w, hx - 0.1 * w), (-hy, -hy + handle), (zr[0] + 0.2 * span, zr[1] - 0.2 * span)),
        ]
        start = len(parts)
        parts.extend(pieces)
        specs.append(front_door(name, (start, start + 1), start + 1, [_box6(p) for p in pieces], hinge="-x"))
    return parts, compartments, specs


def _table(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.05, 0.04)
    inset_x, inset_y = 0.04 * w, 0.04 * d
    legs = _legs(
        (-hx + inset_x, hx - inset_x),
        (-hy + inset_y, hy - inset_y),
        (0.0, h - top),
        _cap(w, 0.06, 0.06),
        _cap(d, 0.06, 0.06),
    )
    apron_z = (h - top - 0.1 * h, h - top)
    aprons = [
        _box((-hx + inset_x, hx - inset_x), (-hy + inset_y, -hy + inset_y + _cap(d, 0.02, 0.02)), apron_z),
        _box((-hx + inset_x, hx - inset_x), (hy - inset_y - _cap(d, 0.02, 0.02), hy - inset_y), apron_z),
    ]
    return [_box((-hx, hx), (-hy, hy), (h - top, h)), *legs, *aprons]


def _low_table(w: float, d: float, h: float, *, drawer: bool) -> Parts:
    """Coffee/side table: top, four legs, a lower shelf, optionally a drawer at the front."""
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.08, 0.04)
    inset_x, inset_y = 0.03 * w, 0.03 * d
    leg_x, leg_y = _cap(w, 0.08, 0.05), _cap(d, 0.08, 0.05)
    parts = [_box((-hx, hx), (-hy, hy), (h - top, h))]
    parts += _legs((-hx + inset_x, hx - inset_x), (-hy + inset_y, hy - inset_y), (0.0, h - top), leg_x, leg_y)
    shelf_z = (0.15 * h, 0.15 * h + _cap(h, 0.05, 0.025))
    parts.append(_box((-hx + inset_x, hx - inset_x), (-hy + inset_y, hy - inset_y), shelf_z))
    if drawer:
        dz = (h - top - 0.2 * h, h - top)
        parts.append(_box((-hx + inset_x + leg_x, hx - inset_x - leg_x), (-hy + inset_y, hy - inset_y), dz))
    return parts


def _coffee_table(w: float, d: float, h: float) -> Parts:
    return _low_table(w, d, h, drawer=False)


def _side_table(w: float, d: float, h: float) -> Articulated:
    """Side table: a coffee table's top, legs and lower shelf, and a drawer under the top that
    slides out of the front (-Y) between the front legs."""
    parts = _low_table(w, d, h, drawer=False)
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.08, 0.04)
    inset_x, inset_y = 0.03 * w, 0.03 * d
    leg_x = _cap(w, 0.08, 0.05)
    inner = (-hx + inset_x + leg_x, hx - inset_x - leg_x)
    _, specs = _drawers(
        parts,
        inner,
        (h - top - 0.2 * h, h - top - 0.01 * h),
        -hy,
        hy - inset_y,
        inner,
        1,
        1,
        handle=inset_y,
        thickness=_cap(d, 0.04, 0.02),
    )
    return parts, [], specs


def _desk(w: float, d: float, h: float) -> Articulated:
    """Desk: top, a side panel at -X, a hollow pedestal of three drawers at +X, a modesty panel at
    the back (+Y); knee space open to -Y."""
    hx, hy = w / 2, d / 2
    top = _cap(h, 0.05, 0.035)
    panel = _cap(w, 0.04, 0.03)
    under = (0.0, h - top)
    ped_w = min(0.3 * w, 0.45)
    handle, front = _cap(d, 0.03, 0.015), _cap(d, 0.03, 0.02)
    px = (hx - 0.01 * w - ped_w, hx - 0.01 * w)
    py = (-hy + 0.03 * d + handle + front, hy - 0.03 * d)
    wall, back = _cap(ped_w, 0.06, 0.018), _cap(d, 0.04, 0.012)
    inner = (px[0] + wall, px[1] - wall)
    parts = [
        _box((-hx, hx), (-hy, hy), (h - top, h)),
        _box((-hx + 0.01 * w, -hx + 0.01 * w + panel), (-hy + 0.03 * d, hy - 0.03 * d), under),
        _box(
            (-hx + 0.01 * w + panel, px[0]),
            (hy - 0.03 * d - panel, hy - 0.03 * d),
            (0.35 * h, h - top),
        ),
        _box((px[0], inner[0]), py, under),
        _box((inner[1], px[1]), py, under),
        _box(inner, (py[1] - back, py[1]), under),
        _box(inner, (py[0], py[1] - back), (0.0, 0.02 * h)),
    ]
    _, specs = _drawers(
        parts,
        (px[0] + 0.01 * w, hx - 0.02 * w),
        (0.03 * h, h - top - 0.02 * h),
        -hy + 0.03 * d,
        py[1] - back - 0.005,
        inner,
        3,
        1,
        handle=handle,
        thickness=front,
    )
    return parts, [], specs


def _dressing_table(w: float, d: float, h: float) -> Articulated:
    """A small table with a drawer under its top that slides out of the front (-Y), and a mirror
    standing on it at the back (+Y)."""
    hx, hy = w / 2, d / 2
    table_h = 0.55 * h
    top = _cap(h, 0.03, 0.03)
    parts = [_box((-hx, hx), (-hy, hy), (table_h - top, table_h))]
    parts += _legs(
        (-hx + 0.03 * w, hx - 0.03 * w),
        (-hy + 0.03 * d, hy - 0.03 * d),
        (0.0, table_h - top),
        _cap(w, 0.06, 0.04),
        _cap(d, 0.08, 0.04),
    )
    mirror_t = _cap(d, 0.08, 0.03)
    parts.append(_box((-hx + 0.1 * w, hx - 0.1 * w), (hy - mirror_t, hy), (table_h, h)))
    inner = (-hx + 0.15 * w, hx - 0.15 * w)
    _, specs = _drawers(
        parts,
        inner,
        (table_h - top - 0.12 * h, table_h - top - 0.01 * h),
        -hy,
        hy - 0.1 * d,
        inner,
        1,
        1,
        handle=0.03 * d,
        thickness=_cap(d, 0.04, 0.02),
    )
    return parts, [], specs


def _chair(w: float, d: float, h: float) -> Parts:
    """Dining chair: four legs, seat, two back posts and a back panel at +Y; open front at -Y."""
    hx, hy = w / 2, d / 2
    seat_top = 0.5 * h
    seat_t = _cap(h, 0.06, 0.05)
    leg_x, leg_y = _cap(w, 0.1, 0.045), _cap(d, 0.1, 0.045)
    back_t = _cap(d, 0.08, 0.05)
    parts = _legs((-hx, hx), (-hy, hy - back_t), (0.0, seat_top - seat_t), leg_x, leg_y)
    parts.append(_box((-hx, hx), (-hy, hy - back_t), (seat_top - seat_t, seat_top)))
    for xr in ((-hx, -hx + leg_x), (hx - leg_x, hx)):
        parts.append(_box(xr, (hy - back_t, hy), (0.0, h)))  # back legs run up as posts
    parts.append(_box((-hx + leg_x, hx - leg_x), (hy - back_t, hy), (seat_top + 0.3 * (h - seat_top), h)))
    return parts


def _office_chair(w: float, d: float, h: float) -> Parts:
    """Swivel chair: cross base, column, seat, back at +Y on a support, armrests."""
    hx, hy = w / 2, d / 2
    base_h = _cap(h, 0.06, 0.06)
    bar_w, bar_d = _cap(w, 0.1, 0.06), _cap(d, 0.1, 0.06)
    seat_lo, seat_hi = 0.4 * h, 0.48 * h
    back_t = _cap(d, 0.1, 0.06)
    arm_w = _cap(w, 0.1, 0.06)
    parts = [
        _box((-hx, hx), (-bar_d / 2, bar_d / 2), (0.0, base_h)),
        _box((-bar_w / 2, bar_w / 2), (-hy, hy), (0.0, base_h)),
        _cyl(_centered(hx, 0.12), _centered(hy, 0.12), (base_h, seat_lo)),
        _box((-hx + arm_w, hx - arm_w), (-hy + 0.05 * d, hy - back_t - 0.05 * d), (seat_lo, seat_hi)),
        _box(_centered(hx, 0.15), (hy - back_t - 0.05 * d, hy - back_t), (seat_lo, 0.6 * h)),
        _box((-hx + arm_w, hx - arm_w), (hy - back_t, hy), (0.55 * h, h)),
    ]
    arm_y = (-hy + 0.2 * d, hy - back_t - 0.1 * d)
    for xr in ((-hx, -hx + arm_w), (hx - arm_w, hx)):
        mid = 0.5 * (arm_y[0] + arm_y[1])
        parts.append(_box(xr, (mid - 0.05 * d, mid + 0.05 * d), (seat_lo, 0.62 * h)))
        parts.append(_box(xr, arm_y, (0.62 * h, 0.66 * h)))
    return parts


def _upholstered(w: float, d: float, h: float, *, seats: int) -> Parts:
    """Armchair/sofa: short legs, base, seat and back cushions, arms at +-X, back at +Y."""
    hx, hy = w / 2, d / 2
    leg_h, base_top, seat_top = 0.1 * h, 0.38 * h, 0.48 * h
    back_t = _cap(d, 0.18, 0.2)
    arm_w = _cap(w, 0.12, 0.18)
    parts = _legs(
        (-hx + 0.02 * w, hx - 0.02 * w),
        (-hy + 0.02 * d, hy - 0.02 * d),
        (0.0, leg_h),
        _cap(w, 0.05, 0.05),
        _cap(d, 0.05, 0.05),
    )
    parts.append(_box((-hx, hx), (-hy, hy - back_t), (leg_h, base_top)))
    parts.append(_box((-hx, hx), (hy - back_t, hy), (leg_h, 0.8 * h)))
    for xr in ((-hx, -hx + arm_w), (hx - arm_w, hx)):
        parts.append(_box(xr, (-hy, hy - back_t), (base_top, 0.65 * h)))
    cushion_back = _cap(d, 0.15, 0.15)
    for xr in _split(-hx + arm_w, hx - arm_w, seats, 0.01):
        parts.append(_box(xr, (-hy + 0.02 * d, hy - back_t), (base_top, seat_top)))
        parts.append(_box(xr, (hy - back_t - cushion_back, hy - back_t), (seat_top, h)))
    return parts


def _armchair(w: float, d: float, h: float) -> Parts:
    return _upholstered(w, d, h, seats=1)


def _sofa(w: float, d: float, h: float) -> Parts:
    seats = int(np.clip(round((w * 0.76) / 0.6), 1, 4))
    return _upholstered(w, d, h, seats=seats)


def _l_shaped_sofa(w: float, d: float, h: float) -> Parts:
    """Sofa along X with its back at +Y and a chaise on the -X end that reaches forward to -Y."""
    hx, hy = w / 2, d / 2
    leg_h, base_top, seat_top = 0.1 * h, 0.38 * h, 0.48 * h
    back_t = _cap(d, 0.12, 0.2)
    arm_w = _cap(w, 0.06, 0.18)
    main_d = 0.5 * d
    chaise_w = 0.35 * w
    main_y = (hy - main_d, hy - back_t)
    lx, ly = _cap(w, 0.03, 0.05), _cap(d, 0.03, 0.05)
    parts = [
        _box((-hx, -hx + lx), (-hy, -hy + ly), (0.0, leg_h)),
        _box((-hx + chaise_w - lx, -hx + chaise_w), (-hy, -hy + ly), (0.0, leg_h)),
        _box((hx - lx, hx), (hy - main_d, hy - main_d + ly), (0.0, leg_h)),
        _box((hx - lx, hx), (hy - ly, hy), (0.0, leg_h)),
        _box((-hx, -hx + lx), (hy - ly, hy), (0.0, leg_h)),
        _box((-hx, hx), (hy - main_d, hy - back_t), (leg_h, base_top)),
        _box((-hx, -hx + chaise_w), (-hy, hy - main_d), (leg_h, base_top)),
        _box((-hx, hx), (hy - back_t, hy), (leg_h, 0.8 * h)),
        _box((hx - arm_w, hx), main_y, (base_top, 0.65 * h)),
        _box((-hx, -hx + arm_w), (-hy, hy - back_t), (base_top, 0.65 * h)),
        _box((-hx + arm_w, -hx + chaise_w), (-hy + 0.02 * d, hy - main_d), (base_top, seat_top)),
    ]
    seats = int(np.clip(round((w - chaise_w) / 0.7), 1, 3))
    cushion_back = _cap(d, 0.1, 0.15)
    for xr in _split(-hx + arm_w, hx - arm_w, seats + 1, 0.01):
        parts.append(_box(xr, (hy - back_t - cushion_back, hy - back_t), (seat_top, h)))
        parts.append(_box(xr, (main_y[0], main_y[1] - cushion_back), (base_top, seat_top)))
    return parts


def _stool(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    seat_t = _cap(h, 0.08, 0.05)
    parts = [_cyl((-hx, hx), (-hy, hy), (h - seat_t, h))]
    leg_x, leg_y = _cap(w, 0.12, 0.04), _cap(d, 0.12, 0.04)
    legs_x, legs_y = (-0.65 * hx, 0.65 * hx), (-0.65 * hy, 0.65 * hy)
    parts += _legs(legs_x, legs_y, (0.0, h - seat_t), leg_x, leg_y, round_legs=True)
    rung_z = (0.3 * h, 0.3 * h + _cap(h, 0.04, 0.025))
    parts.append(_box(legs_x, (-leg_y / 2, leg_y / 2), rung_z))
    parts.append(_box((-leg_x / 2, leg_x / 2), legs_y, (rung_z[0] + 0.05 * h, rung_z[1] + 0.05 * h)))
    return parts


def _bookshelf_layout(w: float, d: float, h: float) -> tuple[Parts, list[Box6]]:
    """Open shelving: side boards, top and bottom, back panel at +Y, shelves open to -Y."""
    hx, hy = w / 2, d / 2
    board = _cap(min(w, h), 0.05, 0.025)
    back = _cap(d, 0.05, 0.01)
    inner_x, inner_y = (-hx + board, hx - board), (-hy, hy - back)
    parts = [
        _box((-hx, -hx + board), (-hy, hy), (0.0, h)),
        _box((hx - board, hx), (-hy, hy), (0.0, h)),
        _box(inner_x, inner_y, (0.0, board)),
        _box(inner_x, inner_y, (h - board, h)),
        _box(inner_x, (hy - back, hy), (0.0, h)),
    ]
    n_shelves = int(np.clip(round(h / 0.35) - 1, 0, 6))
    step = (h - board) / (n_shelves + 1)
    levels = [board]
    for i in range(1, n_shelves + 1):
        z0 = i * step
        parts.append(_box(inner_x, inner_y, (z0, z0 + board)))
        levels += [z0, z0 + board]
    levels.append(h - board)
    compartments = [(*inner_x, *inner_y, levels[i], levels[i + 1]) for i in range(0, len(levels), 2)]
    return parts, compartments


def _tv_stand_layout(w: float, d: float, h: float) -> Articulated:
    """Low hollow cabinet with a row of drawers at -Y that slide out (one per ~0.6 m of width, at
    most four); what is in the stand is in its drawers."""
    hx, hy = w / 2, d / 2
    handle, front = _cap(d, 0.04, 0.015), _cap(d, 0.04, 0.02)
    parts, _, body_z = _hollow_case(
        w, d, h, plinth=0.12 * h, top=_cap(h, 0.08, 0.03), front=handle + front, boards=[]
    )
    wall, back = _cap(w, 0.04, 0.018), _cap(d, 0.04, 0.012)
    cols = int(np.clip(round(w / 0.6), 1, 4))
    insides, specs = _drawers(
        parts,
        (-hx + 0.03 * w, hx - 0.03 * w),
        (body_z[0] + 0.05 * h, body_z[1] - 0.05 * h),
        -hy,
        hy - back - 0.005,
        (-hx + wall, hx - wall),
        1,
        cols,
        handle=handle,
        thickness=front,
    )
    return parts, insides, specs



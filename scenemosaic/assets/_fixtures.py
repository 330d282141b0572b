"""Procedural builders of bathroom and kitchen fixtures and appliances (toilet, sink, faucet,
microwave, washing machine, oven, dishwasher...), bins, boxes and a few large odds and ends
(``_procedural.py`` names them)."""

from __future__ import annotations

from scenemosaic.assets._articulation import (
    TOILET_LID_OPEN_DEG,
    Box6,
    drop_door,
    front_door,
    lid,
)
from scenemosaic.assets._shapes import (
    Articulated,
    Parts,
    _box,
    _box6,
    _cap,
    _centered,
    _cyl,
    _frac,
    _frame,
    _frustum,
    _hull,
    _lump,
    _profile,
    _rod,
    _split,
    _tub,
)

__all__: list[str] = []

def _toilet(w: float, d: float, h: float) -> Articulated:
    """Bowl toward -Y on a pedestal, cistern at the back (+Y), a lid over the bowl hinged at its
    back edge just before the cistern."""
    hx, hy = w / 2, d / 2
    tank_d = _cap(d, 0.25, 0.22)
    seat = 0.42 * h
    bowl_y = (-hy, hy - tank_d + 0.02 * d)
    lid_piece = _cyl(
        (-hx + 0.03 * w, hx - 0.03 * w), (-hy, hy - tank_d - 0.01 * d), (seat, seat + _cap(h, 0.04, 0.035))
    )
    parts = [
        _frustum(_centered(hx, 0.7), (-hy + 0.2 * d, hy - tank_d), (0.0, 0.25 * h), bottom=1.0, top=0.8),
        _profile((-hx + 0.04 * w, hx - 0.04 * w), bowl_y, (0.2 * h, seat), (0.55, 0.9, 1.0)),
        lid_piece,
        _box((-hx, hx), (hy - tank_d, hy), (0.4 * h, h)),
        _box(_centered(hx, 0.6), (hy - tank_d - 0.03 * d, hy), (0.2 * h, 0.42 * h)),
    ]
    box = _box6(lid_piece)
    grip = (*_frac((box[0], box[1]), 0.35, 0.65), box[2], box[2] + 0.04, box[4], box[5])
    return parts, [], [lid("lid", (2,), 2, [box], handle_box=grip, open_deg=TOILET_LID_OPEN_DEG)]


def _toilet_paper(w: float, d: float, h: float) -> Parts:
    """A roll standing on its end, with its cardboard core showing at the top."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.97 * h)),
        _cyl(_centered(hx, 0.4), _centered(hy, 0.4), (0.5 * h, h)),
    ]


def _paper_towel_roll(w: float, d: float, h: float) -> Parts:
    """A roll on a holder: base disc, the roll, a pole knob on top."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.05 * h)),
        _cyl(_centered(hx, 0.92), _centered(hy, 0.92), (0.04 * h, 0.94 * h)),
        _cyl(_centered(hx, 0.25), _centered(hy, 0.25), (0.9 * h, h)),
    ]


def _plunger(w: float, d: float, h: float) -> Parts:
    """Plunger, broom, mop, toilet brush: a wide foot on the floor and a handle."""
    hx, hy = w / 2, d / 2
    return [
        _frustum((-hx, hx), (-hy, hy), (0.0, 0.2 * h), bottom=1.0, top=0.55),
        _cyl(_centered(hx, 0.18), _centered(hy, 0.18), (0.15 * h, h)),
    ]


def _garbage_can_layout(w: float, d: float, h: float) -> tuple[Parts, list[Box6]]:
    """Open-top bin (garbage can, basket): a floor and four walls, hollow."""
    parts, inside = _tub(
        _frame(w, d, h)[0],
        _frame(w, d, h)[1],
        (0.0, h),
        floor=_cap(h, 0.05, 0.02),
        wall=_cap(min(w, d), 0.05, 0.015),
    )
    return parts, [inside]


def _box_layout(w: float, d: float, h: float) -> Articulated:
    """A closed box: floor, four walls and a lid hinged at its back edge, hollow inside."""
    wall = _cap(min(w, d), 0.05, 0.01)
    parts, inside = _tub(
        (-w / 2, w / 2),
        (-d / 2, d / 2),
        (0.0, h),
        floor=_cap(h, 0.05, 0.01),
        wall=wall,
        lid=_cap(h, 0.05, 0.01),
    )
    box = _box6(parts[-1])
    grip = (*_frac((box[0], box[1]), 0.3, 0.7), box[2], box[2] + min(0.03, 0.2 * d), box[4], box[5])
    k = len(parts) - 1
    return parts, [inside], [lid("lid", (k,), k, [box], handle_box=grip)]


def _sink(w: float, d: float, h: float) -> Parts:
    """Pedestal sink: a column and an open basin on top (a low box is the basin alone)."""
    hx, hy = w / 2, d / 2
    basin_z = (0.75 * h, h) if h > 0.5 else (0.0, h)
    parts, _ = _tub(
        (-hx, hx), (-hy, hy), basin_z, floor=_cap(h, 0.04, 0.03), wall=_cap(min(w, d), 0.08, 0.04)
    )
    if h > 0.5:
        parts.append(
            _frustum(
                _centered(hx, 0.35),
                (-hy + 0.3 * d, hy - 0.05 * d),
                (0.0, basin_z[0] + 0.01 * h),
                bottom=1.2,
                top=0.8,
            )
        )
    return parts


def _faucet(w: float, d: float, h: float) -> Parts:
    """A base at the back (+Y), a riser, a spout reaching to -Y, two handles at +-X."""
    hx, hy = w / 2, d / 2
    riser = min(0.2 * w, 0.8 * d)
    return [
        _box((-hx, hx), (0.0, hy), (0.0, 0.1 * h)),
        _cyl((-riser / 2, riser / 2), (hy - 0.5 * d, hy - 0.1 * d), (0.0, h)),
        _box(_centered(hx, 0.1), (-hy, hy - 0.3 * d), (0.8 * h, 0.95 * h)),
        _cyl((-hx, -hx + 0.12 * w), (0.1 * d, 0.4 * d), (0.0, 0.45 * h)),
        _cyl((hx - 0.12 * w, hx), (0.1 * d, 0.4 * d), (0.0, 0.45 * h)),
    ]


def _microwave(w: float, d: float, h: float) -> Articulated:
    """Microwave, oven: a body, a door on the left of the front (-Y) hung on its left edge with a
    handle bar at its right, a control panel on the right."""
    hx, hy = w / 2, d / 2
    door = _cap(d, 0.06, 0.03)
    grip = 0.4 * door
    door_x, door_z = (-hx + 0.03 * w, hx - 0.3 * w), (0.06 * h, 0.94 * h)
    parts = [
        _box((-hx, hx), (-hy + door, hy), (0.0, h)),
        _box((hx - 0.27 * w, hx - 0.03 * w), (-hy + 0.4 * door, -hy + door), (0.06 * h, 0.94 * h)),
    ]
    pieces = [
        _box(door_x, (-hy + grip, -hy + door), door_z),
        _box((door_x[1] - 0.06 * w, door_x[1] - 0.03 * w), (-hy, -hy + grip), (0.2 * h, 0.8 * h)),
    ]
    parts.extend(pieces)
    return parts, [], [front_door("door", (2, 3), 3, [_box6(p) for p in pieces], hinge="-x")]


def _washing_machine(w: float, d: float, h: float) -> Articulated:
    """Washing machine, dryer: a body, a round door at the front (-Y) hung on its left edge with a
    grip at its right, a control strip on top."""
    hx, hy = w / 2, d / 2
    door = _cap(d, 0.06, 0.05)
    grip = 0.4 * door
    side = min(0.7 * w, 0.55 * h)
    door_z = (0.3 * h, 0.3 * h + side)
    parts = [
        _box((-hx, hx), (-hy + door, hy), (0.0, h)),
        _box((-hx + 0.05 * w, hx - 0.05 * w), (-hy + 0.5 * door, -hy + door), (0.85 * h, 0.97 * h)),
    ]
    pieces = [
        _rod((-side / 2, side / 2), (-hy + grip, -hy + door), door_z, (1.0, 1.0), axis=1),
        _box(
            (side / 2 - 0.12 * side, side / 2 - 0.04 * side),
            (-hy, -hy + grip),
            (door_z[0] + 0.35 * side, door_z[0] + 0.65 * side),
        ),
    ]
    parts.extend(pieces)
    return parts, [], [front_door("door", (2, 3), 3, [_box6(p) for p in pieces], hinge="-x")]


def _drop_door_appliance(w: float, d: float, h: float, *, door_top: float) -> Articulated:
    """A body, a door over the front (-Y) up to ``door_top`` (a fraction of the height) hinged
    along its bottom edge with a handle bar across its top, a control panel above it."""
    hx, hy = w / 2, d / 2
    door = _cap(d, 0.06, 0.04)
    grip = 0.4 * door
    door_x, door_z = (-hx + 0.02 * w, hx - 0.02 * w), (0.04 * h, door_top * h)
    tall = door_z[1] - door_z[0]
    parts = [
        _box((-hx, hx), (-hy + door, hy), (0.0, h)),
        _box(door_x, (-hy + 0.4 * door, -hy + door), (door_z[1] + 0.01 * h, 0.98 * h)),
    ]
    bar = (door_z[1] - 0.12 * tall, door_z[1] - 0.06 * tall)
    pieces = [
        _box(door_x, (-hy + grip, -hy + door), door_z),
        _box((door_x[0] + 0.15 * w, door_x[1] - 0.15 * w), (-hy, -hy + grip), bar),
    ]
    parts.extend(pieces)
    return parts, [], [drop_door("door", (2, 3), 3, [_box6(p) for p in pieces])]


def _oven(w: float, d: float, h: float) -> Articulated:
    """Oven, stove: a drop-down door over the lower three quarters of the front, controls above."""
    return _drop_door_appliance(w, d, h, door_top=0.78)


def _dishwasher(w: float, d: float, h: float) -> Articulated:
    """Dishwasher: a drop-down door over nearly all of the front, a control strip above it."""
    return _drop_door_appliance(w, d, h, door_top=0.9)


def _toaster(w: float, d: float, h: float) -> Parts:
    """A rounded body and a lever on the +X side."""
    hx, hy = w / 2, d / 2
    lever = 0.12 * w
    return [
        _rod((-hx, hx - lever), (-hy, hy), (0.0, h), (1.0, 1.0), axis=0),
        _box((hx - lever - 0.02 * w, hx), _centered(hy, 0.2), (0.45 * h, 0.6 * h)),
    ]


def _coffee_machine(w: float, d: float, h: float) -> Parts:
    """A base, a column at the back (+Y), a head over the front, a carafe standing on the base."""
    hx, hy = w / 2, d / 2
    base = 0.12 * h
    column = (hy - 0.45 * d, hy)
    return [
        _box((-hx, hx), (-hy, hy), (0.0, base)),
        _box((-hx, hx), column, (base, h)),
        _box(_centered(hx, 0.8), (-hy + 0.1 * d, column[0] + 0.01 * d), (0.78 * h, h)),
        _cyl(_centered(hx, 0.5), (-hy + 0.12 * d, column[0]), (base, 0.62 * h)),
    ]


def _kettle(w: float, d: float, h: float) -> Parts:
    """Kettle, watering can: a body, a lid knob, a spout to -X and a handle over the +X side."""
    hx, hy = w / 2, d / 2
    spout, grip = 0.2 * w, 0.14 * w
    body_x = (-hx + spout, hx - grip)
    cx = 0.5 * (body_x[0] + body_x[1])
    knob = 0.1 * (body_x[1] - body_x[0])
    tip = _cap(d, 0.06, 0.015)
    return [
        _frustum(body_x, (-hy, hy), (0.0, 0.85 * h), bottom=1.0, top=0.7),
        _cyl((cx - knob, cx + knob), _centered(hy, 0.1), (0.8 * h, 0.92 * h)),
        _hull(
            [(body_x[0] + 0.1 * w, s * 0.12 * d, z) for s in (-1, 1) for z in (0.15 * h, 0.45 * h)]
            + [(-hx, s * tip, z) for s in (-1, 1) for z in (0.66 * h, 0.76 * h)]
        ),
        _box((hx - 0.06 * w, hx), _centered(hy, 0.12), (0.25 * h, h)),
        _box((cx, hx), _centered(hy, 0.12), (0.92 * h, h)),
    ]


def _teddy_bear(w: float, d: float, h: float) -> Parts:
    """A sitting bear facing -Y: body, head, ears, arms, legs reaching forward; it sits on its body and legs."""
    hx, hy = w / 2, d / 2
    return [
        _lump(_centered(hx, 0.6), (-hy + 0.25 * d, hy), (0.0, 0.62 * h)),
        _lump(_centered(hx, 0.46), (-hy + 0.2 * d, hy - 0.1 * d), (0.55 * h, 0.95 * h)),
        _lump((-hx * 0.46, -hx * 0.2), (-hy + 0.4 * d, hy - 0.3 * d), (0.85 * h, h)),
        _lump((hx * 0.2, hx * 0.46), (-hy + 0.4 * d, hy - 0.3 * d), (0.85 * h, h)),
        _lump((-hx, -hx + 0.3 * w), (-hy + 0.2 * d, hy - 0.2 * d), (0.2 * h, 0.5 * h)),
        _lump((hx - 0.3 * w, hx), (-hy + 0.2 * d, hy - 0.2 * d), (0.2 * h, 0.5 * h)),
        _lump((-hx + 0.15 * w, -0.02 * w), (-hy, hy - 0.35 * d), (0.0, 0.25 * h)),
        _lump((0.02 * w, hx - 0.15 * w), (-hy, hy - 0.35 * d), (0.0, 0.25 * h)),
    ]


def _statue(w: float, d: float, h: float) -> Parts:
    """Statue, figurine, decor piece: a plinth, a rounded body and a head."""
    hx, hy = w / 2, d / 2
    return [
        _box(_centered(hx, 0.85), _centered(hy, 0.85), (0.0, 0.1 * h)),
        _profile((-hx, hx), (-hy, hy), (0.08 * h, 0.75 * h), (0.7, 1.0, 0.55)),
        _lump(_centered(hx, 0.5), _centered(hy, 0.5), (0.7 * h, h)),
    ]


def _towel_holder(w: float, d: float, h: float) -> Parts:
    """Wall bar (towel holder, paper hanger): two brackets at the wall (+Y) and a bar toward -Y."""
    hx, hy = w / 2, d / 2
    post = _cap(w, 0.08, 0.03)
    return [
        _box((-hx, -hx + post), (-hy, hy), (0.0, h)),
        _box((hx - post, hx), (-hy, hy), (0.0, h)),
        _box((-hx, hx), (-hy, -hy + 0.4 * d), (0.3 * h, 0.7 * h)),
    ]


def _vacuum_cleaner(w: float, d: float, h: float) -> Parts:
    """Upright vacuum: a floor head at the front (-Y), a body behind it, a handle up to the top."""
    hx, hy = w / 2, d / 2
    return [
        _box((-hx, hx), (-hy, hy - 0.2 * d), (0.0, 0.12 * h)),
        _box(_centered(hx, 0.6), (-hy + 0.3 * d, hy), (0.05 * h, 0.6 * h)),
        _cyl(_centered(hx, 0.15), (hy - 0.35 * d, hy - 0.15 * d), (0.55 * h, 0.95 * h)),
        _box(_centered(hx, 0.35), (hy - 0.35 * d, hy - 0.1 * d), (0.93 * h, h)),
    ]


def _boots(w: float, d: float, h: float) -> Parts:
    """A pair of boots side by side: a foot toward -Y and a shaft at the back, each."""
    hx, hy = w / 2, d / 2
    parts: Parts = []
    for xr in _split(-hx, hx, 2, 0.05 * w):
        parts.append(_box(xr, (-hy, hy), (0.0, 0.25 * h)))
        parts.append(_box(xr, (0.0, hy), (0.2 * h, h)))
    return parts



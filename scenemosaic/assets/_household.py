"""Procedural builders of household things: screens, lamps, plants, rugs, books, laptops, pictures and
the small objects that sit on surfaces and in containers (``_procedural.py`` names them)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import trimesh

from scenemosaic.assets._articulation import (
    lid,
)
from scenemosaic.assets._shapes import (
    Articulated,
    Interval,
    Parts,
    _along,
    _axes,
    _blob,
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
    _narrow,
    _profile,
    _rod,
    _rod_in,
    _vessel,
    _with,
)

__all__: list[str] = []

def _tv(w: float, d: float, h: float) -> Parts:
    """Flat screen facing -Y: on a foot and neck when the box is deep, a wall panel when it is thin."""
    hx, hy = w / 2, d / 2
    if d <= 0.12:
        bezel = _cap(d, 0.3, 0.01)
        return [
            _box((-hx + 0.02 * w, hx - 0.02 * w), (-hy + bezel, hy), (0.02 * h, 0.98 * h)),
            _box((-hx, hx), (-hy, -hy + bezel), (0.0, h)),
            _box(_centered(hx, 0.5), (-hy, hy), (0.0, 0.02 * h)),  # a low foot under the full depth
        ]
    screen_t = _cap(d, 0.25, 0.06)
    screen_z = (0.12 * h, h)
    return [
        _box((-hx, hx), (-screen_t / 2, screen_t / 2), screen_z),
        _box(_centered(hx, 0.35), (-hy, hy), (0.0, _cap(h, 0.04, 0.03))),
        _box(
            _centered(hx, 0.08), (-screen_t / 2 + 0.3 * screen_t, screen_t / 2), (0.0, screen_z[0] + 0.2 * h)
        ),
    ]


def _floor_lamp(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _cyl(_centered(hx, 0.6), _centered(hy, 0.6), (0.0, _cap(h, 0.03, 0.03))),
        _cyl(_centered(hx, 0.08), _centered(hy, 0.08), (0.0, 0.78 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.75 * h, h), bottom=1.0, top=0.7),
    ]


def _table_lamp(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _frustum(_centered(hx, 0.6), _centered(hy, 0.6), (0.0, 0.1 * h), bottom=1.0, top=0.7),
        _profile(_centered(hx, 0.35), _centered(hy, 0.35), (0.1 * h, 0.45 * h), (0.7, 1.0, 0.5)),
        _cyl(_centered(hx, 0.08), _centered(hy, 0.08), (0.45 * h, 0.6 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.5 * h, h), bottom=1.0, top=0.65),
    ]


def _ceiling_lamp(w: float, d: float, h: float) -> Parts:
    """Hangs from the top of its box: canopy at z = h, a cord, a shade opening downward to z = 0."""
    hx, hy = w / 2, d / 2
    canopy_t = _cap(h, 0.08, 0.04)
    shade_top = min(0.5 * h, max(0.3 * w, 0.3 * h))
    return [
        _cyl(_centered(hx, 0.3), _centered(hy, 0.3), (h - canopy_t, h)),
        _cyl(_centered(hx, 0.03), _centered(hy, 0.03), (shade_top * 0.9, h - canopy_t)),
        _frustum((-hx, hx), (-hy, hy), (0.0, shade_top), bottom=1.0, top=0.35),
        _blob(_centered(hx, 0.25), _centered(hy, 0.25), (0.05 * shade_top, 0.55 * shade_top)),
    ]


def _plant(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    pot_h = 0.3 * h
    return [
        _frustum(_centered(hx, 0.55), _centered(hy, 0.55), (0.0, pot_h), bottom=0.75, top=1.0),
        _cyl(_centered(hx, 0.06), _centered(hy, 0.06), (pot_h * 0.8, 0.5 * h)),
        _blob((-hx, hx), (-hy, hy), (0.4 * h, h)),
        _blob(_centered(hx, 0.7), _centered(hy, 0.7), (0.3 * h, 0.75 * h)),
    ]


def _rug(w: float, d: float, h: float) -> Parts:
    return [_box((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


def _plain_box(w: float, d: float, h: float) -> Parts:
    return [_box((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


def _mug(w: float, d: float, h: float) -> Parts:
    """Cylindrical body with a three-piece handle on the +X side."""
    hx, hy = w / 2, d / 2
    handle_w = 0.25 * w
    bar = _cap(w, 0.06, 0.008)
    body_x = (-hx, hx - handle_w)
    hy_bar = _centered(hy, 0.15)
    return [
        _cyl(body_x, (-hy, hy), (0.0, h)),
        _box((body_x[1] - 0.1 * w, hx), hy_bar, (0.72 * h, 0.72 * h + _cap(h, 0.1, 0.01))),
        _box((body_x[1] - 0.1 * w, hx), hy_bar, (0.22 * h, 0.22 * h + _cap(h, 0.1, 0.01))),
        _box((hx - bar, hx), hy_bar, (0.22 * h, 0.72 * h + _cap(h, 0.1, 0.01))),
    ]


def _book(w: float, d: float, h: float) -> Parts:
    """Two covers across the thinnest axis, a page block inset on the open sides, a spine."""
    size = (w, d, h)
    lo = [-w / 2, -d / 2, 0.0]
    thin = int(np.argmin(size))
    spine, other = (axis for axis in range(3) if axis != thin)
    cover = 0.12 * size[thin]

    def make(spans: dict[int, Interval]) -> trimesh.Trimesh:
        return _box(spans[0], spans[1], spans[2])

    full = {i: (lo[i], lo[i] + size[i]) for i in range(3)}
    parts = []
    for side in ((lo[thin], lo[thin] + cover), (lo[thin] + size[thin] - cover, lo[thin] + size[thin])):
        parts.append(make({**full, thin: side}))
    pages = {
        thin: (lo[thin] + cover, lo[thin] + size[thin] - cover),
        spine: (lo[spine] + cover, lo[spine] + size[spine] - 0.03 * size[spine]),
        other: (lo[other] + 0.03 * size[other], lo[other] + size[other] - 0.03 * size[other]),
    }
    parts.append(make(pages))
    parts.append(make({thin: pages[thin], spine: (lo[spine], lo[spine] + cover), other: full[other]}))
    return parts


def _vase(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _cyl(_centered(hx, 0.5), _centered(hy, 0.5), (0.0, 0.06 * h)),
        _profile((-hx, hx), (-hy, hy), (0.05 * h, 0.75 * h), (0.55, 1.0, 0.45)),
        _cyl(_centered(hx, 0.4), _centered(hy, 0.4), (0.74 * h, 0.92 * h)),
        _cyl(_centered(hx, 0.55), _centered(hy, 0.55), (0.92 * h, h)),
    ]


def _laptop(w: float, d: float, h: float) -> Articulated:
    """Open laptop: keyboard base toward -Y, screen lid hinged at the back, leaning back to +Y.

    Its box is the open laptop, so it is built open, as far as it opens: the lid's joint (about -X
    through the back edge of the base, a positive angle leaning it back) runs from shut (a negative
    angle, the lid on the keyboard) to 0 (as built), where the lid's weight holds it."""
    hx, hy = w / 2, d / 2
    base_t = _cap(h, 0.1, 0.02)
    lid_t = _cap(d, 0.05, 0.01)
    lean = 0.25 * d
    hinge = hy - lean
    parts = [_box((-hx, hx), (-hy, hinge), (0.0, base_t))]
    parts.append(
        _hull(
            [
                (sx, y, z)
                for sx in (-hx, hx)
                for (y, z) in ((hinge - lid_t, 0.0), (hinge, 0.0), (hy - lid_t, h), (hy, h))
            ]
        )
    )
    parts.append(
        _box(_centered(hx, 0.85), (-hy + 0.45 * d, hinge - 0.05 * d), (base_t, base_t + _cap(h, 0.02, 0.003)))
    )
    # the lid turns about the back edge of the base; shut, it lies on the base (turned by the
    # right angle plus its lean, less a little)
    lean_deg = math.degrees(math.atan2(lean, h))
    screen = _box6(parts[1])
    grip = (*_frac((screen[0], screen[1]), 0.3, 0.7), screen[3] - lid_t, screen[3], 0.9 * h, h)
    spec = lid("lid", (1,), 1, [screen], handle_box=grip)
    shut = math.radians(90.0 + lean_deg - 2.0)
    spec = replace(spec, anchor=(0.0, hinge - lid_t / 2, base_t / 2), limits=(-shut, 0.0))
    return parts, [], [spec]


def _printer(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    out_tray = 0.15 * d
    in_tray = 0.12 * d
    return [
        _box((-hx, hx), (-hy + out_tray, hy - in_tray), (0.0, 0.72 * h)),
        _box((-hx, hx), (-hy + out_tray, hy - in_tray), (0.72 * h, 0.82 * h)),
        _box(_centered(hx, 0.7), (-hy, -hy + out_tray), (0.2 * h, 0.25 * h)),
        _box(_centered(hx, 0.7), (hy - in_tray, hy), (0.5 * h, h)),
        _box(
            (hx - 0.3 * w, hx - 0.05 * w), (-hy + out_tray, -hy + out_tray + 0.15 * d), (0.82 * h, 0.86 * h)
        ),
    ]


def _painting(w: float, d: float, h: float) -> Parts:
    """Framed picture or mirror, thin along Y, picture face toward -Y: four frame bars and a canvas."""
    hx, hy = w / 2, d / 2
    frame = _cap(min(w, h), 0.06, 0.05)
    return [
        _box((-hx, hx), (-hy, hy), (0.0, frame)),
        _box((-hx, hx), (-hy, hy), (h - frame, h)),
        _box((-hx, -hx + frame), (-hy, hy), (frame, h - frame)),
        _box((hx - frame, hx), (-hy, hy), (frame, h - frame)),
        _box((-hx + frame, hx - frame), (-hy + 0.3 * d, hy), (frame, h - frame)),
    ]


def _pillow(w: float, d: float, h: float) -> Parts:
    """One low-poly lump with a flat underside (it rests on a face, not on a vertex)."""
    return [_lump((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h), cut=0.6)]


def _fruit(w: float, d: float, h: float) -> Parts:
    """Apple, tomato, orange...: a rounded lump with a flat underside and a short stem."""
    hx, hy = w / 2, d / 2
    return [
        _lump((-hx, hx), (-hy, hy), (0.0, 0.9 * h)),
        _rod(_centered(hx, 0.1), _centered(hy, 0.1), (0.8 * h, h), (1.0, 0.7)),
    ]


def _potato(w: float, d: float, h: float) -> Parts:
    """Potato, lettuce, bread, egg, soap bar: one rounded lump resting on a flat underside."""
    return [_lump((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h))]


def _ball(w: float, d: float, h: float) -> Parts:
    """Sports ball: a low-poly sphere with a small flat patch underneath (it rests, barely rolls)."""
    return [_lump((-w / 2, w / 2), (-d / 2, d / 2), (0.0, h), cut=0.9)]


def _garbage_bag(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _lump((-hx, hx), (-hy, hy), (0.0, 0.85 * h), cut=0.6),
        _rod(_centered(hx, 0.2), _centered(hy, 0.2), (0.8 * h, h), (0.6, 1.0)),
    ]


def _baseball_bat(w: float, d: float, h: float) -> Parts:
    """A bat along its longest axis: barrel, tapering handle, knob. Upright it stands on the barrel;
    lying down its underside is flat, so it does not roll."""
    spans = _frame(w, d, h)
    long, _, _ = _axes(w, d, h)
    if long == 2:
        return [
            _rod(spans[0], spans[1], (0.0, 0.96 * h), (1.0, 0.85, 0.4, 0.3)),
            _rod(_centered(w / 2, 0.45), _centered(d / 2, 0.45), (0.95 * h, h), (1.0, 1.0)),
        ]
    across = 1 - long  # the other horizontal axis
    knob = _along(
        spans, long, (0.0, 0.05), **{f"a{across}": _narrow(spans, across, 0.45), "a2": (0.0, 0.45 * h)}
    )
    body = _along(spans, long, (0.04, 1.0))
    return [
        _rod_in(body, (0.3, 0.35, 0.85, 1.0), axis=long),
        _rod_in(knob, (1.0, 1.0), axis=long),
    ]


def _bottle(w: float, d: float, h: float) -> Parts:
    """Body, shoulder, neck and cap."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.62 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.6 * h, 0.8 * h), bottom=1.0, top=0.4),
        _cyl(_centered(hx, 0.36), _centered(hy, 0.36), (0.78 * h, 0.94 * h)),
        _cyl(_centered(hx, 0.42), _centered(hy, 0.42), (0.92 * h, h)),
    ]


def _jar(w: float, d: float, h: float) -> Parts:
    """Salt/pepper shaker, jar, canister: a round body and a slightly narrower domed lid."""
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.8 * h)),
        _frustum(_centered(hx, 0.92), _centered(hy, 0.92), (0.78 * h, h), bottom=1.0, top=0.6),
    ]


def _candle(w: float, d: float, h: float) -> Parts:
    hx, hy = w / 2, d / 2
    return [
        _cyl((-hx, hx), (-hy, hy), (0.0, 0.93 * h)),
        _cyl(_centered(hx, 0.08), _centered(hy, 0.08), (0.9 * h, h)),
    ]


def _plate(w: float, d: float, h: float) -> Parts:
    """A low dish: a foot ring under a flat, flaring plate."""
    hx, hy = w / 2, d / 2
    return [
        _cyl(_centered(hx, 0.6), _centered(hy, 0.6), (0.0, 0.3 * h)),
        _frustum((-hx, hx), (-hy, hy), (0.25 * h, h), bottom=0.6, top=1.0),
    ]


def _bowl(w: float, d: float, h: float) -> Parts:
    """Open, hollow bowl: a floor disc and flaring wall segments."""
    return _vessel(
        (-w / 2, w / 2),
        (-d / 2, d / 2),
        (0.0, h),
        floor=_cap(h, 0.15, 0.01),
        wall=_cap(min(w, d), 0.06, 0.008),
        bottom=0.6,
    )


def _pot(w: float, d: float, h: float) -> Parts:
    """Cooking pot: a hollow straight-walled vessel with two handles at +-X."""
    hx, hy = w / 2, d / 2
    lug = 0.1 * w
    parts = _vessel(
        (-hx + lug, hx - lug),
        (-hy, hy),
        (0.0, h),
        floor=_cap(h, 0.1, 0.01),
        wall=_cap(min(w, d), 0.05, 0.008),
        bottom=0.95,
    )
    for xr in ((-hx, -hx + lug + 0.02 * w), (hx - lug - 0.02 * w, hx)):
        parts.append(_box(xr, _centered(hy, 0.3), (0.72 * h, 0.86 * h)))
    return parts


def _pan(w: float, d: float, h: float) -> Parts:
    """Frying pan: a shallow hollow vessel and a long handle toward +X."""
    hx, hy = w / 2, d / 2
    handle = float(np.clip(w - d, 0.15 * w, 0.55 * w))
    parts = _vessel(
        (-hx, hx - handle),
        (-hy, hy),
        (0.0, h),
        floor=_cap(h, 0.2, 0.006),
        wall=_cap(min(w, d), 0.04, 0.006),
        bottom=0.85,
    )
    parts.append(_box((hx - handle - 0.03 * w, hx), _centered(hy, 0.12), (0.45 * h, 0.75 * h)))
    return parts


def _knife(w: float, d: float, h: float) -> Parts:
    """Knife, fork: a handle and a thinner blade along the longest axis."""
    spans = _frame(w, d, h)
    long, _, thin = _axes(w, d, h)
    return [
        _box(*_along(spans, long, (0.0, 0.4))),
        _box(*_along(spans, long, (0.38, 1.0), **{f"a{thin}": _narrow(spans, thin, 0.45)})),
    ]


def _spoon(w: float, d: float, h: float) -> Parts:
    """Spoon, ladle: a narrow handle and a rounded bowl at the far end of the longest axis."""
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    handle = _along(
        spans,
        long,
        (0.0, 0.7),
        **{f"a{wide}": _narrow(spans, wide, 0.3), f"a{thin}": _narrow(spans, thin, 0.5)},
    )
    return [_box(*handle), _lump(*_along(spans, long, (0.62, 1.0)))]


def _paddle(w: float, d: float, h: float) -> Parts:
    """Spatula, tennis racket: a handle and a flat head across the thinnest axis."""
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    handle = _along(spans, long, (0.0, 0.45), **{f"a{wide}": _narrow(spans, wide, 0.2)})
    head = _along(spans, long, (0.4, 1.0))
    return [_box(*handle), _rod_in(head, (1.0, 1.0), axis=thin)]


def _pencil(w: float, d: float, h: float) -> Parts:
    """Pencil, pen: an eight-sided body along the longest axis (resting on a face) and a pointed tip."""
    spans = _frame(w, d, h)
    long, _, _ = _axes(w, d, h)
    return [
        _rod_in(_along(spans, long, (0.0, 0.84)), (1.0, 1.0), axis=long),
        _rod_in(_along(spans, long, (0.82, 1.0)), (1.0, 0.25), axis=long),
    ]


def _cell_phone(w: float, d: float, h: float) -> Parts:
    """Phone, remote control, card, sponge: a slab across its thinnest axis with an inset face on top."""
    spans = _frame(w, d, h)
    _, wide, thin = _axes(w, d, h)
    long = 3 - wide - thin
    body = _with(spans, **{f"a{thin}": _frac(spans[thin], 0.0, 0.85)})
    face = _with(
        spans,
        **{
            f"a{thin}": _frac(spans[thin], 0.8, 1.0),
            f"a{wide}": _frac(spans[wide], 0.08, 0.92),
            f"a{long}": _frac(spans[long], 0.06, 0.94),
        },
    )
    return [body, face]


def _disc(w: float, d: float, h: float) -> Parts:
    """CD, coaster, burner: a flat eight-sided disc across the thinnest axis."""
    spans = _frame(w, d, h)
    _, _, thin = _axes(w, d, h)
    return [_rod_in(spans, (1.0, 1.0), axis=thin)]


def _watch(w: float, d: float, h: float) -> Parts:
    """A wrist watch lying down: a strap slab along the longest horizontal axis and a round face."""
    hx, hy = w / 2, d / 2
    strap_x, strap_y = ((-hx, hx), _centered(hy, 0.55)) if w >= d else (_centered(hx, 0.55), (-hy, hy))
    side = min(w, d)
    return [
        _box(strap_x, strap_y, (0.0, 0.35 * h)),
        _cyl((-side / 2, side / 2), (-side / 2, side / 2), (0.0, h)),
    ]


def _key_chain(w: float, d: float, h: float) -> Parts:
    """A ring at one end of the longest axis and a key slab beside it."""
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    ring = _along(spans, long, (0.0, 0.35))
    key = _along(
        spans,
        long,
        (0.3, 1.0),
        **{f"a{wide}": _narrow(spans, wide, 0.6), f"a{thin}": _narrow(spans, thin, 0.7)},
    )
    return [_rod_in(ring, (1.0, 1.0), axis=thin), _box(*key)]


def _alarm_clock(w: float, d: float, h: float) -> Parts:
    """A body with its face toward -Y on two feet, a bell button on top."""
    hx, hy = w / 2, d / 2
    foot = 0.08 * h
    return [
        _rod((-hx, hx), (-hy, hy), (foot, 0.9 * h), (1.0, 1.0), axis=1),
        _box((-hx + 0.1 * w, -hx + 0.3 * w), _centered(hy, 0.6), (0.0, foot + 0.05 * h)),
        _box((hx - 0.3 * w, hx - 0.1 * w), _centered(hy, 0.6), (0.0, foot + 0.05 * h)),
        _cyl(_centered(hx, 0.15), _centered(hy, 0.3), (0.85 * h, h)),
    ]


def _dumbbell(w: float, d: float, h: float) -> Parts:
    spans = _frame(w, d, h)
    long, wide, thin = _axes(w, d, h)
    if long == 2:
        long, wide, thin = (0, 1, 2) if w >= d else (1, 0, 2)
    bar = _along(
        spans,
        long,
        (0.2, 0.8),
        **{f"a{wide}": _narrow(spans, wide, 0.3), f"a{thin}": _narrow(spans, thin, 0.3)},
    )
    bar[2] = _frac(spans[2], 0.35, 0.65)
    return [
        _rod_in(_along(spans, long, (0.0, 0.25)), (1.0, 1.0), axis=long),
        _box(*bar),
        _rod_in(_along(spans, long, (0.75, 1.0)), (1.0, 1.0), axis=long),
    ]



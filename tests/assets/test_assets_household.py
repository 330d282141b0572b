"""Stand-ins for the household objects of the shipped ProcTHOR houses, and hollow containers.

Every category of every house in ``data/houses/procthor`` (whatever is added there) has a builder of
its own (no box fallback), and its stand-in rests on a base that holds its centre of mass. Containers
(cabinet, wardrobe, dresser, tv stand, fridge, shelving, bins, boxes) are hollow: an item put in a
compartment that ``interior_boards`` names rests on a board and touches no part.
"""

from __future__ import annotations

import itertools
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import trimesh
from shapely.geometry import MultiPoint, Point
from structlog.testing import capture_logs

from scenemosaic.assets import (
    MAX_PARTS,
    interior_boards,
    known_categories,
    procedural_key,
    procedural_parts,
)
from scenemosaic.exceptions import ImportFormatError
from scenemosaic.exchange import load_scenes
from scenemosaic.scene import traits

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"

ODD_LABELS: set[str] = set()
"""Labels of the shipped houses that are allowed to stay a plain box (none today)."""


@cache
def _house_sizes() -> dict[str, list[tuple[float, float, float]]]:
    """Category -> the distinct sizes it has in the shipped houses (every ``*.json`` that is a house)."""
    sizes: dict[str, set[tuple[float, float, float]]] = {}
    for path in sorted(HOUSES.glob("*.json")):
        if not isinstance(json.loads(path.read_text()), dict):
            continue  # SOURCES.json and other side files
        try:
            scenes = load_scenes(path)
        except ImportFormatError:
            continue
        for scene in scenes:
            for obj in scene.objects:
                size = tuple(round(float(v), 4) for v in obj.size)
                sizes.setdefault(obj.category, set()).add(size)  # type: ignore[arg-type]
    return {k: sorted(v) for k, v in sizes.items()}


def test_the_houses_are_found() -> None:
    sizes = _house_sizes()
    assert len(sizes) >= 40, sorted(sizes)
    assert {"toilet", "bowl", "plate", "candle", "statue", "watch", "baseball_bat"} <= set(sizes)


def test_every_category_of_the_shipped_houses_has_its_own_builder() -> None:
    from scenemosaic.assets import _procedural

    unknown = {c for c in _house_sizes() if procedural_key(c) not in known_categories()} - ODD_LABELS
    assert not unknown, f"these fall back to a plain box: {sorted(unknown)}"
    _procedural._warned_unknown.clear()
    with capture_logs() as logs:
        for category, sizes in _house_sizes().items():
            for size in sizes:
                parts = procedural_parts(category, size)
                assert 1 <= len(parts) <= MAX_PARTS
    fallbacks = {e["category"] for e in logs if e["event"] == "unknown_procedural_category"}
    assert fallbacks <= ODD_LABELS, fallbacks


def _base_holds_the_centre(parts: list[trimesh.Trimesh]) -> tuple[bool, float]:
    """Whether the centre of mass lies over the convex hull of the points touching the floor, and by how
    much (its distance to the base's edge over the narrow side of the footprint)."""
    contact = np.vstack([p.vertices[p.vertices[:, 2] < 1e-7][:, :2] for p in parts])
    volumes = np.array([p.volume for p in parts])
    centre = (
        np.sum([p.center_mass[:2] * v for p, v in zip(parts, volumes, strict=True)], axis=0) / volumes.sum()
    )
    base = MultiPoint([tuple(q) for q in contact]).convex_hull
    footprint = min(np.ptp(np.vstack([p.vertices for p in parts])[:, :2], axis=0))  # the narrow side
    margin = base.exterior.distance(Point(centre)) if base.geom_type == "Polygon" else 0.0
    return bool(base.geom_type == "Polygon" and base.contains(Point(centre))), margin / footprint


def test_every_shipped_stand_in_rests_on_a_base_under_its_centre() -> None:
    failures = []
    for category, sizes in _house_sizes().items():
        if traits(category).placement in ("wall", "ceiling"):
            continue  # hung, not standing
        for size in sizes:
            ok, _ = _base_holds_the_centre(procedural_parts(category, size))
            if not ok:
                failures.append((category, size))
    assert not failures


@pytest.mark.parametrize(
    ("label", "size"),
    [
        ("Apple", (0.09, 0.09, 0.094)),
        ("Tomato", (0.13, 0.133, 0.106)),
        ("BasketBall", (0.24, 0.24, 0.24)),
        ("Plate", (0.25, 0.25, 0.019)),
        ("Bowl", (0.21, 0.21, 0.07)),
        ("Candle", (0.05, 0.05, 0.1)),
        ("Bottle", (0.1, 0.1, 0.25)),
        ("Pencil", (0.009, 0.14, 0.009)),
        ("CellPhone", (0.07, 0.14, 0.01)),
        ("RemoteControl", (0.068, 0.219, 0.022)),
        ("CreditCard", (0.086, 0.054, 0.004)),
        ("CD", (0.105, 0.105, 0.004)),
        ("BaseballBat", (0.96, 0.09, 0.08)),
        ("BaseballBat", (0.08, 0.09, 0.96)),
        ("Statue", (0.15, 0.15, 0.34)),
        ("TeddyBear", (0.47, 0.33, 0.47)),
        ("Toilet", (0.54, 0.86, 0.95)),
        ("Kettle", (0.2, 0.21, 0.19)),
    ],
)
def test_household_stand_ins_have_a_broad_base(label: str, size: tuple[float, float, float]) -> None:
    """Not just balanced: the centre sits well inside the base (a nudge does not tip it)."""
    key = procedural_key(label)
    assert key in known_categories(), label
    ok, margin = _base_holds_the_centre(procedural_parts(label, size))
    assert ok and margin > 0.05, (label, margin)


def test_flat_things_lie_flat_and_dishes_are_low() -> None:
    for label, size in [("Pencil", (0.009, 0.14, 0.009)), ("CellPhone", (0.07, 0.14, 0.01))]:
        parts = procedural_parts(label, size)
        assert all(p.bounds[1][2] <= size[2] + 1e-9 for p in parts)
    # a bowl is open: a small item in its middle, above the floor, touches no wall
    w, d, h = 0.2, 0.2, 0.08
    parts = procedural_parts("bowl", (w, d, h))
    inner_floor = max(p.bounds[1][2] for p in parts if p.bounds[1][2] < 0.5 * h)
    item_lo, item_hi = np.array([-0.015, -0.015, inner_floor + 1e-4]), np.array([0.015, 0.015, h])
    assert not [p for p in parts if np.all(item_hi > p.bounds[0]) and np.all(item_lo < p.bounds[1])]


CONTAINERS = [
    ("cabinet", (0.9, 0.5, 0.9)),
    ("kitchen_cabinet", (1.2, 0.6, 0.9)),
    ("counter_top", (3.05, 0.92, 0.94)),
    ("wardrobe", (1.2, 0.6, 2.0)),
    ("dresser", (1.67, 0.53, 0.97)),
    ("dresser", (0.75, 0.7, 0.67)),
    ("tv_stand", (1.2, 0.6, 0.75)),
    ("tv_stand", (1.24, 0.37, 0.45)),
    ("fridge", (1.0, 0.72, 1.97)),
    ("fridge", (0.85, 0.7, 1.69)),
    ("shelving_unit", (0.92, 0.35, 1.41)),
    ("bookshelf", (0.9, 0.35, 1.8)),
    ("garbage_can", (0.46, 0.53, 0.66)),
    ("laundry_hamper", (0.66, 0.51, 0.88)),
    ("box", (0.43, 0.45, 0.47)),
    ("safe", (0.3, 0.34, 0.3)),
]


def _overlaps(lo: np.ndarray, hi: np.ndarray, part: trimesh.Trimesh) -> bool:
    return bool(np.all(hi > part.bounds[0]) and np.all(lo < part.bounds[1]))


@pytest.mark.parametrize(("category", "size"), CONTAINERS)
def test_containers_are_hollow_with_boards_to_put_things_on(
    category: str, size: tuple[float, float, float]
) -> None:
    w, d, h = size
    parts = procedural_parts(category, size)
    compartments = interior_boards(category, size)
    assert compartments, category
    assert sum(p.volume for p in parts) < 0.6 * w * d * h, "a solid carcass"
    for x0, x1, y0, y1, z0, z1 in compartments:
        assert -w / 2 < x0 < x1 < w / 2 and -d / 2 <= y0 < y1 <= d / 2 and 0 < z0 < z1 <= h
        # an item filling the compartment (less a millimetre) touches no part
        lo = np.array([x0 + 1e-3, y0 + 1e-3, z0 + 1e-4])
        hi = np.array([x1 - 1e-3, y1 - 1e-3, z1 - 1e-3])
        assert not [p for p in parts if _overlaps(lo, hi, p)], (category, (z0, z1))
        # and rests on a board under the whole of it
        boards = [
            p
            for p in parts
            if abs(p.bounds[1][2] - z0) < 1e-9
            and p.bounds[0][0] <= x0 + 1e-9
            and p.bounds[1][0] >= x1 - 1e-9
            and p.bounds[0][1] <= y0 + 1e-9
            and p.bounds[1][1] >= y1 - 1e-9
        ]
        assert boards, (category, z0)
    # listed bottom to top (left to right within a row of drawers), none sharing space with another
    for lower, upper in itertools.pairwise(compartments):
        assert lower[4] <= upper[4]
    for a, b in itertools.combinations(compartments, 2):
        assert a[5] <= b[4] or b[5] <= a[4] or a[1] <= b[0] or b[1] <= a[0], (a, b)


@pytest.mark.parametrize(
    ("category", "size"),
    [c for c in CONTAINERS if traits(c[0]).opening == "front" and procedural_key(c[0]) != "bookshelf"],
)
def test_front_containers_are_closed_by_separate_thin_doors(
    category: str, size: tuple[float, float, float]
) -> None:
    parts = procedural_parts(category, size)
    compartments = interior_boards(category, size)
    front_plane = compartments[0][2]
    fronts = [p for p in parts if p.bounds[1][1] <= front_plane + 1e-9]
    assert fronts, "doors and drawer fronts stand before the carcass"
    assert all(p.extents[1] < 0.1 for p in fronts)
    covered = sum(p.extents[0] * p.extents[2] for p in fronts)
    opening = (compartments[0][1] - compartments[0][0]) * (compartments[-1][5] - compartments[0][4])
    assert covered > 0.8 * opening


@pytest.mark.parametrize("category", ["cabinet", "wardrobe", "fridge", "bookshelf", "kitchen_cabinet"])
def test_tall_containers_have_a_board_every_forty_centimetres_or_so(category: str) -> None:
    size = (1.0, 0.6, 2.0)
    heights = [c[5] - c[4] for c in interior_boards(category, size)]
    assert len(heights) >= 3
    assert max(heights) < 0.6 and min(heights) > 0.2, heights


def test_interior_boards_of_a_thing_that_is_no_container_is_empty() -> None:
    assert interior_boards("chair", (0.5, 0.5, 0.9)) == []
    assert interior_boards("apple", (0.1, 0.1, 0.1)) == []


def test_a_mug_in_a_fridge_compartment_stays_put_in_mujoco() -> None:
    """Physics check: the container's parts as static geoms, a box item dropped on a board inside."""
    mujoco = pytest.importorskip("mujoco")
    size = (0.85, 0.7, 1.7)
    parts = procedural_parts("fridge", size)
    x0, x1, y0, y1, z0, _ = interior_boards("fridge", size)[1]
    assets, geoms = [], []
    for i, p in enumerate(parts):
        verts = " ".join(f"{v:.6f}" for v in np.asarray(p.vertices).ravel())
        assets.append(f'<mesh name="m{i}" vertex="{verts}"/>')
        geoms.append(f'<geom type="mesh" mesh="m{i}"/>')
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    item = 0.04
    xml = f"""<mujoco><option timestep="0.002"/><asset>{"".join(assets)}</asset><worldbody>
      <geom type="plane" size="5 5 0.1"/>{"".join(geoms)}
      <body name="mug" pos="{cx} {cy} {z0 + item + 0.002}"><freejoint/>
        <geom type="box" size="{item} {item} {item}" mass="0.3"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    for _ in range(1000):
        mujoco.mj_step(model, data)
    pos = data.body("mug").xpos
    assert abs(pos[2] - (z0 + item)) < 0.005, pos
    assert x0 < pos[0] < x1 and y0 < pos[1] < y1
    assert np.linalg.norm(data.body("mug").cvel) < 1e-2
    deepest = max((-data.contact[i].dist for i in range(data.ncon)), default=0.0)
    assert deepest < 0.002

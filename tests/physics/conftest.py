"""Fixtures for the physics tests: real PhyScene rooms and a perturbed SAM3D office, stabilized once.

Everything goes through the library: ``load_scene`` imports, ``structure_scene`` (the offline
rules model) gives supports and units, ``object_hulls`` gives the SAM3D meshes' convex pieces
through a :class:`HullCache` in the repository's (gitignored) ``.scenemosaic-cache/hulls``,
decomposed with ``CoacdParams.fast()`` (the tests/assets hull tests share those files).
"""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from scenemosaic.assets import CoacdParams, HullCache, object_hulls, shutdown_workers
from scenemosaic.exchange import load_scene, write_sam3d_example
from scenemosaic.physics import (
    COLLISION_TOLERANCE_M,
    StabilizationReport,
    check_collisions,
    stabilize_scene_sync,
)
from scenemosaic.scene import Scene
from scenemosaic.structure import structure_scene

REPO_ROOT = Path(__file__).resolve().parents[2]
DATA = REPO_ROOT / "data"
PHYSCENE_DIR = DATA / "layouts" / "physcene"
SAM3D_DIR = DATA / "sam3d_objects"
HULL_CACHE_DIR = REPO_ROOT / ".scenemosaic-cache" / "hulls"
COACD = CoacdParams.fast()
ROOMS = sorted(p.stem for p in PHYSCENE_DIR.glob("*.json"))

Hulls = dict[str, list[np.ndarray]]


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """``room``: one test per PhyScene layout of the shared data."""
    if "room" in metafunc.fixturenames:
        metafunc.parametrize("room", ROOMS)


@pytest.fixture(scope="session")
def hull_cache() -> Iterator[HullCache]:
    """The repository's on-disk hull cache (cold in CI, warm on a developer's machine)."""
    yield HullCache(HULL_CACHE_DIR)
    shutdown_workers()


@pytest.fixture(scope="session")
def physcene_raw() -> dict[str, Scene]:
    """Every PhyScene room as imported, with the supports the rules model assigns (errors kept)."""
    assert ROOMS, f"no layouts in {PHYSCENE_DIR}"

    async def structure_all() -> list[Scene]:
        return [await structure_scene(load_scene(PHYSCENE_DIR / f"{r}.json")) for r in ROOMS]

    return dict(zip(ROOMS, asyncio.run(structure_all()), strict=True))


@pytest.fixture(scope="session")
def physcene_stabilized(physcene_raw: dict[str, Scene]) -> dict[str, tuple[Scene, StabilizationReport]]:
    """Each room after ``stabilize_scene`` (seed 0)."""
    return {name: stabilize_scene_sync(scene, seed=0) for name, scene in physcene_raw.items()}


def _move(scene: Scene, oid: str, offset: tuple[float, float, float]) -> None:
    obj = scene.get(oid)
    obj.pose = obj.pose.model_copy(
        update={"position": tuple(float(p + d) for p, d in zip(obj.pose.position, offset, strict=True))}
    )


def _depth(scene: Scene, hulls: Hulls, a: str, b: str) -> float:
    """Hull penetration depth of ``a`` and ``b`` (0 when apart), measured as the tests measure it."""
    pair = Scene(room=scene.room, objects=[scene.get(a), scene.get(b)])
    report = check_collisions(pair, hulls=hulls)
    return max((p.depth_m for p in [*report.pairs, *report.shallow]), default=0.0)


def drive_into(scene: Scene, hulls: Hulls, mover: str, target: str, overlap: float) -> None:
    """Slide ``mover`` horizontally straight toward ``target``: to first contact, then ``overlap`` further.

    First contact (hull penetration past the 5 mm collision tolerance) is found in 2 cm steps and
    refined by bisection to 1 mm.
    """
    start = np.array(scene.get(mover).pose.position)
    heading = np.array(scene.get(target).pose.position) - start
    heading[2] = 0.0
    heading /= np.linalg.norm(heading)

    def place(s: float) -> None:
        _move(scene, mover, tuple(start + s * heading - np.array(scene.get(mover).pose.position)))

    def touching(s: float) -> bool:
        place(s)
        return _depth(scene, hulls, mover, target) > COLLISION_TOLERANCE_M

    lo, hi = 0.0, 0.02
    while not touching(hi):
        lo, hi = hi, hi + 0.02
        assert hi < 3.0, f"{mover} never reaches {target}"
    while hi - lo > 0.001:
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if not touching(mid) else (lo, mid)
    place(hi + overlap)


def perturbed_office(scene: Scene, hulls: Hulls, seed: int = 0) -> Scene:
    """A copy of the structured SAM3D office with seeded errors of the kind image-to-3D poses have.

    Every object floats 2–10 cm above its support (the desk's children above its lifted top);
    then the office chair is driven 5–15 cm into the desk and the mug 5–15 cm into the printer
    (straight toward the other's centre, counted from first contact).
    """
    rng = np.random.default_rng(seed)
    out = scene.model_copy(deep=True)
    desk_lift = float(rng.uniform(0.02, 0.10))
    _move(out, "work_desk", (0.0, 0.0, desk_lift))
    for oid in ("bed", "office_chair"):
        _move(out, oid, (0.0, 0.0, float(rng.uniform(0.02, 0.10))))
    for oid in ("printer", "coffee_mug"):
        _move(out, oid, (0.0, 0.0, desk_lift + float(rng.uniform(0.02, 0.10))))
    drive_into(out, hulls, "office_chair", "work_desk", float(rng.uniform(0.05, 0.15)))
    drive_into(out, hulls, "coffee_mug", "printer", float(rng.uniform(0.05, 0.15)))
    return out


@pytest.fixture(scope="session")
def sam3d_structured(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    """The shared SAM3D meshes as ``write_sam3d_example`` lays them out, imported and structured."""
    folder = tmp_path_factory.mktemp("sam3d") / "sam3d_office"
    scene = load_scene(write_sam3d_example(folder, SAM3D_DIR))
    return asyncio.run(structure_scene(scene))


@pytest.fixture(scope="session")
def sam3d_hulls(sam3d_structured: Scene, hull_cache: HullCache) -> Hulls:
    """Convex pieces of the five meshes (local frame, scaled), from the library's hull cache."""
    return {
        o.id: [np.asarray(p.vertices) for p in object_hulls(o, cache=hull_cache, params=COACD)]
        for o in sam3d_structured.objects
    }


@pytest.fixture(scope="session")
def sam3d_raw(sam3d_structured: Scene, sam3d_hulls: Hulls) -> tuple[Scene, Hulls]:
    """The perturbed SAM3D office and its convex pieces."""
    return perturbed_office(sam3d_structured, sam3d_hulls, seed=0), sam3d_hulls


@pytest.fixture(scope="session")
def sam3d_stabilized(sam3d_raw: tuple[Scene, Hulls]) -> tuple[Scene, StabilizationReport]:
    scene, hulls = sam3d_raw
    return stabilize_scene_sync(scene, seed=0, hulls=hulls)

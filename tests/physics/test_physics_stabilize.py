"""Acceptance of stabilization on the real PhyScene rooms and a perturbed SAM3D office."""

from __future__ import annotations

import asyncio
from typing import Any

import numpy as np
import pytest

from scenemosaic.physics import (
    COLLISION_TOLERANCE_M,
    StabilizationReport,
    check_collisions,
    check_out_of_bounds,
    plan_units,
    stabilize_scene,
    support_gaps,
    validate_scene,
)
from scenemosaic.physics._hulls import object_shape
from scenemosaic.scene import Relation, Scene

RESTING_M = 0.01
MAX_YAW_DEG = 5.0


def _assert_physically_valid(
    scene: Scene, report: StabilizationReport, hulls: dict[str, list[np.ndarray]] | None = None
) -> None:
    val = validate_scene(scene, hulls=hulls)
    assert val.collisions.count == 0, val.collisions.pairs
    assert val.out_of_bounds.count == 0, val.out_of_bounds.objects
    assert val.tipped == [] and val.fell == []
    for oid, gap in val.support_gaps_m.items():
        assert abs(gap) < RESTING_M, (oid, gap)
    for m in report.motions:
        assert m.yaw_change_deg < MAX_YAW_DEG, m
        assert m.tilt_deg < 10.0, m
    assert val.max_displacement_m < 0.01


def test_raw_rooms_need_fixing(physcene_raw: dict[str, Scene]) -> None:
    """The raw layouts do have the errors stabilization must fix (so the next test can fail)."""
    # structuring gave every object a support, so the gaps below are measured to the right anchor
    assert all(s.support_of(o.id) is not None for s in physcene_raw.values() for o in s.objects)
    collisions = sum(check_collisions(s).count for s in physcene_raw.values())
    gaps = [
        abs(g)
        for s in physcene_raw.values()
        for g in support_gaps(s, {o.id: object_shape(o) for o in s.objects}).values()
    ]
    assert collisions >= 2  # structuring already parted two dining chairs standing inside each other
    assert sum(g > RESTING_M for g in gaps) >= 10
    assert max(gaps) > 0.3


def test_physcene_room_is_valid_after_stabilization(
    room: str, physcene_stabilized: dict[str, tuple[Scene, StabilizationReport]]
) -> None:
    """One test per PhyScene layout (``room`` is parametrized by conftest)."""
    scene, report = physcene_stabilized[room]
    _assert_physically_valid(scene, report)
    assert all(u.rolled_back == [] for u in report.units)


def test_pendant_lamp_on_the_floor_goes_up(
    physcene_raw: dict[str, Scene], physcene_stabilized: dict[str, tuple[Scene, StabilizationReport]]
) -> None:
    name = next(n for n in physcene_raw if n.startswith("LivingDiningRoom-124277"))
    raw = physcene_raw[name]
    fixed, _ = physcene_stabilized[name]
    lamps = [o for o in raw.objects if o.category == "pendant_lamp"]
    low = min(lamps, key=lambda o: o.pose.position[2])
    assert low.pose.position[2] < 0.5
    after = fixed.get(low.id)
    assert after.aabb()[1][2] == pytest.approx(fixed.room.ceiling_height, abs=RESTING_M)  # type: ignore[union-attr]


def test_sam3d_office_perturbation_is_real(sam3d_raw: tuple[Scene, dict[str, list[np.ndarray]]]) -> None:
    scene, hulls = sam3d_raw
    deep = [p for p in check_collisions(scene, hulls=hulls).pairs if p.depth_m > 0.05]
    assert len(deep) >= 2
    gaps = support_gaps(scene, {o.id: object_shape(o, hulls=hulls) for o in scene.objects})
    assert sum(g > 0.015 for g in gaps.values()) >= 3


def test_sam3d_office_is_valid_after_stabilization(
    sam3d_raw: tuple[Scene, dict[str, list[np.ndarray]]], sam3d_stabilized: tuple[Scene, StabilizationReport]
) -> None:
    _, hulls = sam3d_raw
    scene, report = sam3d_stabilized
    _assert_physically_valid(scene, report, hulls)
    desk_unit = next(u for u in report.units if u.anchor_id == "work_desk")
    floor_unit = next(u for u in report.units if u.anchor_id == "floor")
    assert report.units.index(floor_unit) < report.units.index(desk_unit)
    assert set(desk_unit.children) == {"printer", "coffee_mug"}
    # the mug and printer rest on the desk, inside its top
    assert check_out_of_bounds(scene).count == 0


async def test_stabilize_is_deterministic_and_leaves_the_loop_free(
    physcene_raw: dict[str, Scene], monkeypatch: pytest.MonkeyPatch
) -> None:
    import threading

    import scenemosaic.physics._settle as settle_mod
    import scenemosaic.physics._stabilize as stabilize_mod

    scene = physcene_raw[sorted(physcene_raw)[2]]
    loop_thread = threading.get_ident()
    threads: dict[str, set[int]] = {"settle_unit": set(), "run_until_settled": set(), "object_shape": set()}

    def recording(name: str, fn: Any) -> Any:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            threads[name].add(threading.get_ident())
            return fn(*args, **kwargs)

        return wrapper

    # the CPU work (hull loading / CoACD, MuJoCo stepping, the whole unit) must never run on the loop
    monkeypatch.setattr(stabilize_mod, "settle_unit", recording("settle_unit", stabilize_mod.settle_unit))
    monkeypatch.setattr(stabilize_mod, "object_shape", recording("object_shape", stabilize_mod.object_shape))
    monkeypatch.setattr(
        settle_mod, "run_until_settled", recording("run_until_settled", settle_mod.run_until_settled)
    )
    ticks = 0

    async def ticker() -> None:
        nonlocal ticks
        while True:
            ticks += 1
            await asyncio.sleep(0.001)

    task = asyncio.create_task(ticker())
    (a, _), (b, _) = await asyncio.gather(stabilize_scene(scene, seed=3), stabilize_scene(scene, seed=3))
    task.cancel()
    assert ticks > 3
    assert all(threads.values()), threads  # each was called ...
    assert all(loop_thread not in ids for ids in threads.values()), threads  # ... and never on the loop
    assert a.to_json() == b.to_json()
    assert scene.to_json() != a.to_json()  # the input is copied, not edited
    assert "stabilize" in a.provenance.steps
    again, _ = await stabilize_scene(scene, seed=3)  # alone, not racing another run: still the same
    assert again.to_json() == a.to_json()


def test_units_run_top_down_and_children_follow_their_anchor(
    sam3d_raw: tuple[Scene, dict[str, list[np.ndarray]]], sam3d_stabilized: tuple[Scene, StabilizationReport]
) -> None:
    raw, _ = sam3d_raw
    units, defaulted = plan_units(raw)
    assert [u.anchor_id for u in units] == ["floor", "work_desk"]
    assert defaulted == []
    fixed, _ = sam3d_stabilized
    # the printer moved with the desk: its offset to the desk in the plane changed by < 5 cm
    d0 = np.subtract(raw.get("printer").pose.position, raw.get("work_desk").pose.position)[:2]
    d1 = np.subtract(fixed.get("printer").pose.position, fixed.get("work_desk").pose.position)[:2]
    assert np.linalg.norm(d1 - d0) < 0.05


def test_objects_without_support_default_to_the_floor(physcene_raw: dict[str, Scene]) -> None:
    scene = physcene_raw[sorted(physcene_raw)[0]]
    bare = scene.model_copy(update={"relations": [r for r in scene.relations if r.parent != "ceiling"]})
    units, defaulted = plan_units(bare)
    assert set(defaulted) == {r.child for r in scene.relations if r.parent == "ceiling"}
    assert units[0].anchor_id == "floor" and set(defaulted) <= set(units[0].children)
    assert all(isinstance(r, Relation) for r in bare.relations)
    assert COLLISION_TOLERANCE_M == 0.005

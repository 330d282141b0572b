"""Units can settle in worker processes (for batches); the result equals the threaded default."""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor

from scenemosaic import demo_scene
from scenemosaic.physics import stabilize_scene
from scenemosaic.structure import structure_scene


async def test_process_pool_gives_the_same_scene_as_threads() -> None:
    scene = await structure_scene(demo_scene())
    threaded, thread_report = await stabilize_scene(scene, seed=7)
    with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as pool:
        pooled, pool_report = await stabilize_scene(scene, seed=7, executor=pool)
    assert pooled.to_json() == threaded.to_json()
    assert [u.anchor_id for u in pool_report.units] == [u.anchor_id for u in thread_report.units]
    assert len(pool_report.units) >= 4  # floor, ceiling, a wall and object anchors really went through the pool

"""A house run's deliveries started ahead of its export stage: each house, once final, is written
into :attr:`~scenemosaic.scene.RunFolder.staged` by the run's worker processes while the stages
after it (compose, validate, evaluate) run here; the export stage waits for them and moves them into
place. A room's run, or a house run without worker processes, starts none: its export stage
delivers in place (``pipeline/_stages.py``).
"""

from __future__ import annotations

import asyncio
import functools
import os
import shutil
import time
from collections.abc import AsyncIterator, Collection
from pathlib import Path
from typing import Any

from scenemosaic._processes import JobQueue, WorkerJob
from scenemosaic.assets import open_scene
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.exchange import deliver_scene, delivered_files, delivery_parts
from scenemosaic.pipeline._config import config_record
from scenemosaic.pipeline._house_jobs import ExportJob, ExportReply
from scenemosaic.pipeline._state import PipelineRun, rooms_of
from scenemosaic.pipeline._workers import encode, in_processes, in_workers
from scenemosaic.scene import House, Scene

__all__ = ["HouseDeliveries", "deliver_ahead", "delivered_worlds", "house_deliveries", "put_in_place"]

def delivered_worlds(run: PipelineRun, names: Collection[str] | None = None) -> list[tuple[Path, Scene | House]]:
    """What the export delivers, by folder: the base (``base/``) and each variant
    (``variant_<i>/``), a scene or a whole house as the run is, each as delivered (``--open-state``:
    ``assets.open_scene``); with ``names``, those folders only."""
    variants: list[Scene | House] = list(run.world_variants)
    worlds = [(run.folder.base, run.need_world()), *((run.folder.variant(i), v) for i, v in enumerate(variants, start=1))]
    return [
        (folder, open_scene(w, run.config.open_state, run.config.seed, run.base_dir))
        for folder, w in worlds
        if names is None or folder.name in names
    ]


_FIRST_LANE = ("mjcf", "usd", "glb", "sceneeval")
"""The delivery parts of a house's first half; every other part (``exchange.delivery_parts()``,
a registered plugin format's too) goes in the second (:func:`_lanes`)."""


def _lanes() -> tuple[tuple[str, ...], ...]:
    """A house's delivery in two halves of about equal work once the workers are warm
(``exchange.delivery_parts()``; on the 10-room house the plan with its labels, URDF and the
ProcTHOR file take as long as MJCF, USD, GLB and sceneState together), each written
by one worker process from house to house (the job's slot): every worker builds the in-process
memos of its own formats only (USD layers, MuJoCo hull meshes, GLB buffers; URDF links, plan
labels), once, instead of both building all of them."""
    parts = delivery_parts()
    return (tuple(p for p in _FIRST_LANE if p in parts), tuple(p for p in parts if p not in _FIRST_LANE))


class HouseDeliveries:
    """The houses of a run delivered ahead of its export stage, into :attr:`RunFolder.staged`:
    one call of the run's worker pool that takes each house as it becomes final (:meth:`add`:
    its native files written here, its two halves (:func:`_lanes`) queued for the workers),
    and that the export stage closes (:meth:`landed`) once every house is in it."""

    def __init__(self, run: PipelineRun, workers: int) -> None:
        self.run, self.started = run, time.perf_counter()
        self.queue = JobQueue()
        self.houses: dict[str, asyncio.Future[list[str]]] = {}
        """By delivered folder name (``base``, ``variant_<i>``): the files of the house once
        both its halves are written."""
        self._loop = asyncio.get_running_loop()
        self._left: dict[str, set[int]] = {}
        self._config = config_record(run.config)
        self.call = asyncio.ensure_future(in_workers(run, self.queue, workers, self._replied))
        self.call.add_done_callback(self._call_ended)

    async def add(self, folder: Path, house: House) -> None:
        """Write ``house``'s native files into the staging folder of ``folder`` (what a stopped run
        left there goes first) and queue its halves."""
        staged = self.run.folder.staged / folder.name
        if staged.exists():  # a stopped run's leftovers
            await asyncio.to_thread(shutil.rmtree, staged)
        await asyncio.to_thread(functools.partial(deliver_scene, house, staged, self.run.base_dir, parts=()))
        self.houses[folder.name] = self._loop.create_future()
        self._left[folder.name] = set(range(len(_lanes())))
        place = len(self.houses) - 1
        self.queue.put([
            WorkerJob(f"{folder.name}#{k}", encode(ExportJob(folder=staged, parts=list(parts), config=self._config)),
                      slot=place * len(_lanes()) + k)
            for k, parts in enumerate(_lanes())
        ])  # fmt: skip

    def _replied(self, job: str, reply: dict[str, Any]) -> None:
        self._loop.call_soon_threadsafe(self._settle, job, reply)

    def _settle(self, job: str, reply: dict[str, Any]) -> None:
        name, _, lane = job.rpartition("#")
        future = self.houses.get(name)
        if future is None or future.done():
            return
        answer = ExportReply.model_validate(reply)  # a worker that died: {"error": why}
        if answer.error is not None:
            future.set_exception(SceneMosaicError(f"house export failed: {name}: {answer.error}"))
            return
        left = self._left[name]
        left.discard(int(lane))
        if not left:
            future.set_result(delivered_files(self.run.folder.staged / name))

    def _call_ended(self, call: asyncio.Future[Any]) -> None:
        failure = None if call.cancelled() else call.exception()
        for future in self.houses.values():
            if not future.done():
                future.set_exception(failure or SceneMosaicError("house export stopped before every house was written"))

    async def landed(self) -> AsyncIterator[tuple[str, list[str]]]:
        """No more houses: each one, as ``(folder name, files)``, once written, in the order they
        were added; then the pool call's end (a worker that died fails it)."""
        self.queue.close()
        for name, future in self.houses.items():
            yield name, await future
        await self.call

    async def stop(self) -> None:
        """Stop the workers' deliveries (the run failed or was stopped before its export stage)."""
        self.queue.close()
        self.call.cancel()
        await asyncio.gather(self.call, *self.houses.values(), return_exceptions=True)


async def deliver_ahead(run: PipelineRun, names: set[str], worlds: list[tuple[Path, Scene | House]] | None = None) -> None:
    """Start delivering the houses of the folders ``names`` (``base``, ``variant_<i>``) into
    :attr:`RunFolder.staged` in the run's worker processes, in the background
    (:class:`HouseDeliveries`): the next stages (compose, validate, evaluate, one core) run
    meanwhile, and the export stage waits for them and moves them into place. The houses must be
    final: nothing later changes them. Without worker processes (a room's run, a model that is not
    ``rules``, one worker) nothing is started. ``worlds``: :func:`delivered_worlds`, when the caller
    has them."""
    workers = in_processes(run.config, len(rooms_of(run.need_world())))
    if not workers:
        return
    if run.deliveries is None:
        run.deliveries = HouseDeliveries(run, workers)
    deliveries = house_deliveries(run)
    assert deliveries is not None
    if worlds is None:  # opening a house's parts is CPU work: off the event loop, only those named
        todo = names - set(deliveries.houses)
        worlds = await asyncio.to_thread(delivered_worlds, run, todo) if todo else []
    for folder, house in worlds:
        if folder.name in names and folder.name not in deliveries.houses:
            assert isinstance(house, House)  # worker processes run the rooms of a house only
            await deliveries.add(folder, house)


def house_deliveries(run: PipelineRun) -> HouseDeliveries | None:
    """The run's deliveries ahead, as the house stages started them (``None``: none started)."""
    ahead = run.deliveries
    if ahead is not None and not isinstance(ahead, HouseDeliveries):
        raise TypeError(f"a house run's deliveries ahead are HouseDeliveries, not {type(ahead).__name__}")
    return ahead


def put_in_place(staged: Path, final: Path) -> None:
    """Move a house delivered ahead from the staging folder to its place (what was there goes)."""
    if final.is_symlink() or final.is_file():
        final.unlink()
    elif final.exists():
        shutil.rmtree(final)
    os.replace(staged, final)

"""A house's rooms: the ``rooms`` stage of a whole-house run, and the worker side of its processes.

A multi-room house input (an AI2-THOR / ProcTHOR house file without ``room``) goes through the same
stages as a room (``pipeline/_stages.py``: import, compose, validate, evaluate, export, over the
run's world, here the house) with one stage of its own in place of a room's assets ... evolve,
:data:`ROOMS_STAGE`: each room is a run of its own over the room stages of the run's plan
(``pipeline/_plan.py``: import → assets → structure → stabilize → doors → evolve → compose, then
``clutter`` when ``--clutter`` is not ``keep``) in ``OUT/rooms/<room>/``, started from the room's
scene as the house import gave it (in memory) and with its own checkpoint, so a stopped house
resumes room by room. Rooms are independent until the house-level checks, so they run concurrently:
in ``room_workers`` processes (:mod:`scenemosaic.pipeline._house_worker`, which runs
:func:`room_worker`; ``pipeline/_workers.py`` is the parent's side) when the model is the offline
``rules`` (CPU-bound work), else as tasks of this process sharing the run's one model stack
(waiting on a server). The same workers, warm, deliver the house's base and variants ahead of the
export stage (``pipeline/_deliveries.py``).

``docs/houses.md`` describes the model, the checks and their constants.
"""

from __future__ import annotations

import asyncio
import errno
import functools
import gc
import json
import os
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import structlog
from pydantic import BaseModel

from scenemosaic._memo import forget_memos
from scenemosaic.assets import HullCache
from scenemosaic.dag import FileRunStore
from scenemosaic.exceptions import OutputSpaceError, SceneMosaicError
from scenemosaic.exchange import export_house_folder, is_house_source
from scenemosaic.pipeline._checkpoint import (
    checkpoint_state,
    input_digest,
    load_checkpoint,
    save_checkpoint,
)
from scenemosaic.pipeline._config import GenerateConfig, config_from_record, config_record
from scenemosaic.pipeline._driver import run_stages
from scenemosaic.pipeline._house_jobs import (
    HOUSE_JOB,
    ExportJob,
    ExportReply,
    ForgetJob,
    ForgetReply,
    RoomJob,
)
from scenemosaic.pipeline._state import PipelineRun, RoomOutcome, RunSetup, Stage, StageRecord
from scenemosaic.pipeline._workers import encode, in_processes, in_workers, sent
from scenemosaic.scene import RunFolder, Scene

if TYPE_CHECKING:
    from scenemosaic.models import RunModel

__all__ = ["ROOMS_STAGE", "is_house_input", "room_worker"]

log = structlog.get_logger(__name__)



def is_house_input(input_path: Path, config: GenerateConfig) -> bool:
    """Whether a run's input is a whole multi-room house (``exchange.is_house_source``: a file of a
    format registered as holding houses, with more than one room), and no ``room`` picks one of
    its rooms."""
    if config.room is not None or config.prompt is not None:
        return False
    return is_house_source(input_path, config.format, allow_orphans=config.allow_orphans, index=config.index)


# -- one room ---------------------------------------------------------------------------------------


async def _run_room(
    room: Scene,
    input_path: Path,
    root: Path,
    config: GenerateConfig,
    base_dir: Path,
    model: RunModel | None,
    stages: tuple[Stage, ...],
) -> RoomOutcome:
    """One room of the house through ``stages`` (the plan's room stages: ``pipeline/_plan.py``)
    in ``OUT/rooms/<room>/``, from its scene as given; ``model`` is the house run's model stack
    (``None``: the room opens its own)."""
    t0 = time.perf_counter()
    folder = RunFolder(root).room(room.id)
    config = config.model_copy(update={"room": room.id})
    run = PipelineRun(RunSetup(input_path=input_path, folder=folder, config=config, base_dir=base_dir, source=room))
    run.store = FileRunStore(folder.checkpoint)
    run.model = model
    digest = await asyncio.to_thread(input_digest, input_path, run.config)
    finished = await asyncio.to_thread(load_checkpoint, run, digest) if config.resume else set()
    if not config.resume:
        await asyncio.to_thread(save_checkpoint, run, digest)
    failure: BaseException | None = None
    try:
        failure = await run_stages(run, finished, digest, None, stages)
    finally:
        if model is None and run.model is not None:
            await run.model.aclose()
        if run.hull_cache is not None:  # the room's CoACD processes leave with it
            await asyncio.to_thread(functools.partial(run.hull_cache.close, cancel=failure is not None))
    if isinstance(failure, asyncio.CancelledError):
        raise failure
    error = None if failure is None else f"{type(failure).__name__}: {failure}"
    if failure is not None and not isinstance(failure, SceneMosaicError):
        log.error("room_failed", room=room.id, traceback="".join(traceback.format_exception(failure)))
    state = checkpoint_state(run)
    return RoomOutcome(
        room_id=room.id, state=state, error=error, error_type=type(failure).__name__ if failure else None, seconds=time.perf_counter() - t0
    )  # fmt: skip


RoomStages = Callable[[GenerateConfig], tuple[Stage, ...]]
"""What gives a house's room its stages, from the run's settings (``pipeline._plan.room_plan``)."""


def room_worker(reply_fd: int, room_stages: RoomStages) -> None:
    """A worker process's loop (``python -m scenemosaic.pipeline._house_worker``): one job a line
    on stdin, one reply a line on the pipe ``reply_fd`` when it ends (the package's worker pool,
    ``scenemosaic._processes.WorkerPool``), each a typed message of ``pipeline/_house_jobs.py``:
    a :class:`RoomJob` runs a room and replies with its :class:`RoomOutcome`; an
    :class:`ExportJob` writes some parts of a house whose native files are saved in a folder
    (``exchange.export_house_folder``) and replies with an :class:`ExportReply`; a
    :class:`ForgetJob` drops the memos. ``room_stages`` gives a room its stages (the worker's entry
    point passes the plan's: a lower layer does not import the plan)."""
    with os.fdopen(reply_fd, "wb") as replies:
        for line in sys.stdin.buffer:
            if line.strip():
                replies.write(encode(asyncio.run(_work(HOUSE_JOB.validate_python(json.loads(line)), room_stages))))
                replies.flush()








async def _work(job: RoomJob | ExportJob | ForgetJob, room_stages: RoomStages) -> BaseModel:
    """One job of a worker process (see :func:`room_worker`); its reply."""
    if isinstance(job, ForgetJob):  # the run is over and this worker is kept for the next one
        dropped = forget_memos()
        gc.collect()
        return ForgetReply(forgotten=dropped)
    if isinstance(job, RoomJob):
        config = config_from_record(job.config, resume=job.resume, restart_stale=job.restart_stale)
        try:
            return await _run_room(job.room, job.input, job.root, config, job.base_dir, None, room_stages(config))
        except Exception as exc:  # reported to the parent, which fails the stage
            return RoomOutcome(room_id=job.room.id, error=f"{type(exc).__name__}: {exc}", error_type=type(exc).__name__)
    config = config_from_record(job.config)
    with HullCache(config.hull_cache_dir) as cache:
        export = functools.partial(export_house_folder, job.folder, hull_cache=cache, parts=job.parts)
        try:
            return ExportReply(files=await asyncio.to_thread(export))
        except Exception as exc:  # reported to the parent, which fails the stage
            return ExportReply(error=f"{type(exc).__name__}: {exc}")












# -- the rooms stage ----------------------------------------------------------------------------


async def _stage_rooms(run: PipelineRun, rec: StageRecord) -> None:
    """Every room through the plan's room stages (``RunSetup.room_stages``), concurrently (largest
    rooms first)."""
    house = run.need_house()
    rooms = sorted(house.rooms, key=lambda s: -len(s.objects))
    workers = in_processes(run.config, len(rooms))
    rec.detail["workers"] = workers or 1
    rec.detail["processes"] = bool(workers)
    if workers:
        cfg = run.config
        jobs = [
            (f"room {s.id!r}", RoomJob(room=s, input=run.input_path, root=run.folder.root, base_dir=run.base_dir,
                                       config=config_record(cfg), resume=cfg.resume, restart_stale=cfg.restart_stale))
            for s in rooms
        ]  # fmt: skip
        replies = await in_workers(run, jobs, workers)
        by_id = {s.id: RoomOutcome.model_validate(replies[f"room {s.id!r}"]) for s in rooms}
    else:
        model = await run.asking(rec)  # the run's one model stack, shared by the rooms
        stages = run.setup.room_stages

        async def here(room: Scene) -> RoomOutcome:
            # a room's scene and outcome cross the same boundary as a worker's (a JSON line each
            # way, validated again), so one process and many give the same bytes: validating a
            # pose again divides its quaternion by its norm, which may move its last bit
            outcome = await _run_room(sent(room), run.input_path, run.folder.root, run.config, run.base_dir, model, stages)
            return sent(outcome)

        by_id = {o.room_id: o for o in await asyncio.gather(*(here(s) for s in rooms))}
    run.rooms = {rid: by_id[rid] for rid in house.room_ids}
    done: list[Scene] = []
    failed = []
    for rid, outcome in run.rooms.items():
        state = outcome.state
        if outcome.error or state is None or state.scene is None:
            failed.append(f"{rid}: {outcome.error or 'no scene'}")
            continue
        done.append(state.scene)
        run.warnings += [f"{rid}: {w}" for w in state.warnings]
    rec.detail["seconds_per_room"] = {rid: round(o.seconds, 3) for rid, o in run.rooms.items()}
    rec.detail["critical_path_s"] = round(max((o.seconds for o in run.rooms.values()), default=0.0), 3)
    rec.detail["sum_of_rooms_s"] = round(sum(o.seconds for o in run.rooms.values()), 3)
    if failed:
        full = next((o for o in run.rooms.values() if o.error_type == OutputSpaceError.__name__), None)
        if full is not None:  # the disk, not the room: said as such, like any run's full disk
            raise OutputSpaceError(str(run.folder.room(full.room_id)), errno.ENOSPC)
        raise SceneMosaicError("room(s) failed: " + "; ".join(failed))
    run.house = house.with_rooms(done)


ROOMS_STAGE = Stage("rooms", _stage_rooms)
"""A house run's stage in place of a room's assets ... evolve: every room through the plan's room
stages (``pipeline/_plan.py``), up to its own variants."""

"""The stages of a whole-house run: every room worked on at once, then composed, checked and delivered as one.

A multi-room house input (an AI2-THOR / ProcTHOR house file without ``room``) runs
:data:`HOUSE_STAGES` through the same driver as a room (``pipeline/_driver.py``: records,
usage, checkpoint, interruption) over the same :class:`PipelineRun`, whose ``house`` holds it:

1. **rooms** — each room is a run of its own over the room stages of the run's plan
   (``pipeline/_plan.py``: import → assets → structure → stabilize → doors → evolve → compose,
   then ``clutter`` when ``--clutter`` is not ``keep``) in ``OUT/rooms/<room>/``, started from the
   room's scene as the house import gave it (in memory) and with its own checkpoint, so a stopped
   house resumes room by room. Rooms are independent until the house-level checks, so they run
   concurrently: in ``room_workers`` processes (:mod:`scenemosaic.pipeline._house_worker`, each
   room's result sent back over the pipe) when the model is the offline ``rules`` (CPU-bound
   work), else as tasks of this process sharing the run's one model stack (waiting on a server).
2. **compose** — whole-house variants from one candidate pool over every room's unit variants
   (``compose.compose_house``: a candidate is valid when every room is, its doors clear and its
   floor as connected as the base's); with clutter, a room shown in the same arrangement by two
   houses gets its small objects varied anew (``pipeline._clutter.vary_house_repeats``);
3. **validate** — the delivered whole-house world (``physics.validate_scene``: every room's checks,
   and the house's MuJoCo world settled once) and the house checks (door clearance, reachability
   from room to room, nothing across a wall);
4. **evaluate** — each room's metrics and the house's (``metrics.evaluate``);
5. **export** — ``base/`` and each ``variant_<i>/`` as whole houses (``exchange.deliver_scene``),
   and the contact sheet; with worker processes the houses are delivered ahead, each in two
   halves written at once (:class:`HouseDeliveries`), and this stage moves them into place.

``docs/houses.md`` describes the model, the checks and their constants.
"""

from __future__ import annotations

import asyncio
import errno
import functools
import gc
import json
import os
import shutil
import sys
import threading
import time
import traceback
from collections.abc import AsyncIterator, Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import structlog
from pydantic import BaseModel

from scenemosaic._memo import forget_memos
from scenemosaic._processes import STOP_GRACE_S, JobEnd, JobQueue, WorkerJob, WorkerPool
from scenemosaic.assets import HullCache, open_scene
from scenemosaic.compose import compose_house
from scenemosaic.dag import FileRunStore
from scenemosaic.exceptions import OutputSpaceError, SceneMosaicError
from scenemosaic.exchange import (
    deliver_scene,
    delivered_files,
    delivery_parts,
    export_house_folder,
    formats_left_out,
    is_house_source,
    load_house,
    plugin_formats,
)
from scenemosaic.metrics import evaluate, furniture, house_checks
from scenemosaic.physics import ValidationReport, check_collisions, check_out_of_bounds, validate_scene
from scenemosaic.pipeline._checkpoint import (
    checkpoint_state,
    input_digest,
    load_checkpoint,
    save_checkpoint,
)
from scenemosaic.pipeline._clutter import vary_house_repeats
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
from scenemosaic.pipeline._stages import (
    judge_scenes,
    note_import_warnings,
    note_shortfall,
    validation_warnings,
)
from scenemosaic.pipeline._state import PipelineRun, RoomOutcome, RunSetup, Stage, StageRecord
from scenemosaic.render import ContactSheet
from scenemosaic.scene import House, HouseFloor, RunFolder, Scene

if TYPE_CHECKING:
    from scenemosaic.models import RunModel

__all__ = ["HOUSE_STAGES", "HOUSE_STAGE_NAMES", "is_house_input", "room_worker"]

log = structlog.get_logger(__name__)

WORKER_MODULE = "scenemosaic.pipeline._house_worker"
"""The module a house run's worker processes run (``python -m``)."""


def is_house_input(input_path: Path, config: GenerateConfig) -> bool:
    """Whether a run's input is a whole multi-room house (``exchange.is_house_source``: a file of a
    format registered as holding houses, with more than one room), and no ``room`` picks one of
    its rooms."""
    if config.room is not None or config.prompt is not None:
        return False
    return is_house_source(input_path, config.format, allow_orphans=config.allow_orphans)


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
                replies.write(_encode(asyncio.run(_work(HOUSE_JOB.validate_python(json.loads(line)), room_stages))))
                replies.flush()


_M = TypeVar("_M", bound=BaseModel)


def _sent(message: _M) -> _M:
    """``message`` as the other end of a worker's pipe reads it (:func:`_encode`, then validated)."""
    return type(message).model_validate(json.loads(_encode(message)))


def _encode(message: BaseModel) -> bytes:
    """One line of a message (the standard library's JSON of its JSON-ready dump: a float that is
    not finite, in a stage's figures, travels as ``Infinity`` and comes back a float)."""
    return json.dumps(message.model_dump(mode="json")).encode() + b"\n"


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


async def _in_workers(
    run: PipelineRun,
    jobs: Sequence[tuple[str, RoomJob | ExportJob]] | JobQueue,
    count: int,
    on_reply: Callable[[str, dict[str, Any]], None] | None = None,
) -> dict[str, dict[str, Any]]:
    """Run every job (``(name, job)``, or the :class:`JobQueue` of a call that takes jobs while it
    runs) in ``count`` worker processes of the run's pool (:attr:`PipelineRun.workers`, a
    ``scenemosaic._processes.WorkerPool`` started on first use and kept from stage to stage: the
    rooms' workers, warm, deliver the houses); their replies by name, each also given to
    ``on_reply`` (in the pool's thread) as it comes (a job whose worker died: ``{"error"}``).
    A worker that dies fails the stage; a cancel stops every worker at once."""
    replies: dict[str, dict[str, Any]] = {}
    failures: list[str] = []

    def ended(job: WorkerJob, end: JobEnd) -> None:
        if end.reply is None:
            failures.append(f"{job.name}: {end.failure()}")
            reply = {"error": end.failure()}
        else:
            reply = replies[job.name] = json.loads(end.reply)
        if on_reply is not None:
            on_reply(job.name, reply)

    if run.workers is None:  # in a thread: closing kept workers that do not fit waits for them
        run.workers = await asyncio.to_thread(_take_workers)
    stop = threading.Event()
    queue = jobs if isinstance(jobs, JobQueue) else JobQueue([WorkerJob(name, _encode(job)) for name, job in jobs], closed=True)
    pool = functools.partial(run.workers.run, queue, workers=count, on_end=ended, stop=stop)
    running = asyncio.ensure_future(asyncio.to_thread(pool))
    try:
        await asyncio.shield(running)
    except asyncio.CancelledError:
        stop.set()  # the workers are stopped (they leave at SIGTERM) before the cancel goes on
        await asyncio.wait([running], timeout=STOP_GRACE_S + 1)
        raise
    if failures:
        raise SceneMosaicError("worker process(es) stopped: " + "; ".join(failures))
    return replies


def _take_workers() -> WorkerPool:
    """The room workers a house run before kept (``WorkerPool.take_kept``: started as this run
    would start them, alive and idle), else a new pool."""
    return WorkerPool.take_kept(WORKER_MODULE, orphan="kill")


def release_workers(pool: WorkerPool, *, keep: bool) -> None:
    """The end of a house run's workers: with ``keep`` (the run ended well) and every worker idle
    and alive, each forgets what the run derived (its memos: a pool kept holds the package's
    imports only) and the pool is kept for the next house run in this process
    (``WorkerPool.keep``); else, or when a worker fails to forget, the workers leave."""
    if keep:
        pool.keep(_forget)
    else:
        pool.close()


def _forget(pool: WorkerPool) -> bool:
    """Every worker of ``pool`` drops its memos (:class:`ForgetJob`); whether all did."""
    failed: list[str] = []
    forget = [WorkerJob(f"forget#{k}", _encode(ForgetJob()), limit_s=STOP_GRACE_S, slot=k) for k in range(pool.size)]
    try:
        pool.run(forget, workers=pool.size, on_end=lambda job, end: failed.extend([] if end.reply else [job.name]))
    except Exception:  # a pool that cannot forget is not kept (run() has closed it)
        return False
    return not failed


def _in_processes(config: GenerateConfig, rooms: int) -> int:
    """How many worker processes the rooms get (0: run them in this process)."""
    workers = config.room_workers or min(os.cpu_count() or 1, rooms)
    # what a worker process cannot know: a model stack, plugin agents, rules or formats of the user's process
    portable = config.model == "rules" and config.agents is None and not config.layout_rules and not plugin_formats()
    return min(workers, rooms) if workers > 1 and portable and rooms > 1 else 0


# -- stages -----------------------------------------------------------------------------------------


async def _stage_import(run: PipelineRun, rec: StageRecord) -> None:
    """The house, every room in its world frame."""
    run.house = await asyncio.to_thread(
        functools.partial(load_house, run.input_path, run.config.format, allow_orphans=run.config.allow_orphans)
    )
    rec.detail["source_format"] = run.house.rooms[0].provenance.source_format
    rec.detail["rooms"] = run.house.room_ids
    note_import_warnings(run, run.house.rooms)


async def _stage_rooms(run: PipelineRun, rec: StageRecord) -> None:
    """Every room through the plan's room stages (``RunSetup.room_stages``), concurrently (largest
    rooms first)."""
    house = run.need_house()
    rooms = sorted(house.rooms, key=lambda s: -len(s.objects))
    workers = _in_processes(run.config, len(rooms))
    rec.detail["workers"] = workers or 1
    rec.detail["processes"] = bool(workers)
    if workers:
        cfg = run.config
        jobs = [
            (f"room {s.id!r}", RoomJob(room=s, input=run.input_path, root=run.folder.root, base_dir=run.base_dir,
                                       config=config_record(cfg), resume=cfg.resume, restart_stale=cfg.restart_stale))
            for s in rooms
        ]  # fmt: skip
        replies = await _in_workers(run, jobs, workers)
        by_id = {s.id: RoomOutcome.model_validate(replies[f"room {s.id!r}"]) for s in rooms}
    else:
        model = await run.asking(rec)  # the run's one model stack, shared by the rooms
        stages = run.setup.room_stages

        async def here(room: Scene) -> RoomOutcome:
            # a room's scene and outcome cross the same boundary as a worker's (a JSON line each
            # way, validated again), so one process and many give the same bytes: validating a
            # pose again divides its quaternion by its norm, which may move its last bit
            outcome = await _run_room(_sent(room), run.input_path, run.folder.root, run.config, run.base_dir, model, stages)
            return _sent(outcome)

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


def _room_variants(run: PipelineRun, room_id: str) -> list[Scene]:
    outcome = run.rooms.get(room_id)
    return list(outcome.state.variants) if outcome is not None and outcome.state is not None else []


def _planned(run: PipelineRun, room_id: str) -> bool:
    """Whether the room's floor kept a room plan among its evolved layouts (``evolve/_plans.py``)."""
    outcome = run.rooms.get(room_id)
    layouts = outcome.state.layouts if outcome is not None and outcome.state is not None else None
    floor = (layouts or {}).get("floor")
    return floor is not None and any(lid.startswith("plan_") for lid in floor[0])


def _check_problems(checks: dict[str, Any]) -> list[str]:
    """The house checks that fail, in words."""
    out = []
    if checks["unreachable_rooms"]:
        out.append(f"room(s) not reachable from the rest of the house: {', '.join(checks['unreachable_rooms'])}")
    if checks["door_blockers"]:
        out.append(f"door(s) blocked by {', '.join(checks['door_blockers'][:6])}")
    if checks["wall_crossings"]:
        out.append(f"object(s) across a wall: {', '.join(checks['wall_crossings'][:6])}")
    return out


async def _stage_compose(run: PipelineRun, rec: StageRecord) -> None:
    """Whole-house variants: one pool over every room's own valid variants (``compose_house``);
    a house is valid when every room stays reachable from every other."""
    house, m = run.need_house(), run.config.variants
    if run.config.clutter == "keep":  # nothing here changes the base: it is delivered meanwhile
        await _deliver_ahead(run, {RunFolder.BASE})
    room_variants = [_room_variants(run, s.id) for s in house.rooms]
    if m <= 0 or not any(room_variants):
        rec.status = "skipped"
        rec.detail["reason"] = "no variants asked for" if m <= 0 else "no room has a variant"
        await _deliver_ahead(run, {RunFolder.BASE})
        return
    unplanned = [s.id for s in house.rooms if furniture(s) and not _planned(run, s.id)]
    if unplanned:  # said, not hidden: their variants differ in smaller pieces only
        rec.detail["rooms_without_plan"] = unplanned
        run.notes.append(f"room(s) whose free floor holds no other arrangement of their furniture groups: {', '.join(unplanned)}")
    floor = HouseFloor(house)  # the floors and doorways rasterized once, each room arrangement once
    base_unreachable = set(floor.walkable(house.rooms).unreachable_rooms())

    def reachable(rooms: list[Scene]) -> bool:
        return set(floor.walkable(rooms).unreachable_rooms()) <= base_unreachable

    compose = functools.partial(compose_house, house.rooms, room_variants, m=m, seed=run.config.seed, accept=reachable)
    variants, report = await asyncio.to_thread(compose)
    repeats = await vary_house_repeats(run, house.rooms, variants, report.picked)  # --clutter: no room's clutter shown twice
    varied: dict[str, list[str]] = repeats.get("varied", {})
    rec.detail.update(report.summary())
    if varied:
        rec.detail["clutter_varied_anew"] = varied
    if repeats.get("dropped"):
        rec.detail["clutter_dropped"] = repeats["dropped"]
        run.notes.append(f"clutter: small object(s) dropped at house compose (why: report.json, stage compose): {repeats['dropped']}")
    rec.detail["room_variants"] = {s.id: len(v) for s, v in zip(house.rooms, room_variants, strict=True)}
    checked = []
    run.house_variants, run.variant_checks = [], []
    for i, rooms in enumerate(variants, start=1):
        for s in rooms:
            anew = " (its small objects varied anew)" if s.id in varied.get(f"variant_{i}", ()) else ""
            s.provenance.notes.append(f"house variant {i}: this room as {report.picked[i - 1][s.id]}{anew}")
        variant = house.with_rooms(rooms)
        name = run.folder.variant(i).name
        cols = oob = 0
        for s in rooms:
            shapes = await asyncio.to_thread(run.shapes, s)  # hulls may be computed: off the event loop
            cols += len((await asyncio.to_thread(check_collisions, s, run.base_dir, hull_cache=run.cache())).pairs)
            oob += len((await asyncio.to_thread(functools.partial(check_out_of_bounds, s, shapes=shapes))).objects)
        checks = await asyncio.to_thread(house_checks, variant)
        run.variant_checks.append(checks)
        checked.append({"folder": name, "collision_pairs": cols, "out_of_bounds": oob, **checks})
        problems = _check_problems(checks) + ([f"{cols} colliding pair(s), {oob} object(s) out of bounds"] if cols or oob else [])
        if problems:
            run.warnings.append(f"{name}: " + "; ".join(problems))
        run.house_variants.append(variant)
    rec.detail["variants"] = checked
    note_shortfall(run, rec, len(variants), report.pool_size)
    # every house is final now: delivered while validate and evaluate run here
    await _deliver_ahead(run, {RunFolder.BASE, *(run.folder.variant(i).name for i in range(1, len(variants) + 1))})


async def _stage_validate(run: PipelineRun, rec: StageRecord) -> None:
    """The delivered whole-house world, settled once in MuJoCo, with every room's checks; then
    the house-wide checks."""
    house = run.need_house()
    cache = run.cache()

    def validate() -> dict[str, ValidationReport]:
        return validate_scene(house, run.base_dir, hull_cache=cache)

    reports = await asyncio.to_thread(validate)
    per_room: dict[str, Any] = {}
    for rid, report in reports.items():
        per_room[rid] = report.model_dump(mode="json")
        state = run.rooms[rid].state if rid in run.rooms else None
        if state is not None:  # each room's report shows its own
            state.validation = per_room[rid]
        run.warnings += [f"{rid}: {w}" for w in validation_warnings(report)]
    checks = await asyncio.to_thread(house_checks, house)
    run.warnings += [f"base: {p}" for p in _check_problems(checks)]
    run.validation = {
        "collision_pairs": sum(len(v["collisions"]["pairs"]) for v in per_room.values()),
        "out_of_bounds": sum(len(v["out_of_bounds"]["objects"]) for v in per_room.values()),
        "fell": sum(len(v["fell"]) for v in per_room.values()),
        "tipped": sum(len(v["tipped"]) for v in per_room.values()),
        "max_displacement_m": max((v["max_displacement_m"] for v in per_room.values()), default=0.0),
        **checks,
    }
    rec.detail.update({k: v for k, v in run.validation.items() if not isinstance(v, dict | list) or len(v) <= 20})


async def _stage_evaluate(run: PipelineRun, rec: StageRecord) -> None:
    """Each room's metrics (base and variants) and the house's: NAV, reachability, diversity, RelKeep."""
    house = run.need_house()
    measure = functools.partial(
        evaluate, house, run.house_variants, base_dir=run.base_dir,
        variant_dirs=[run.base_dir] * len(run.house_variants), hull_cache=run.cache(),
        base_checks=run.validation, variant_checks=run.variant_checks,
    )  # fmt: skip
    run.metrics = await asyncio.to_thread(measure)
    frozen = [rid for rid in run.metrics["house"].get("rooms_not_rearranged") or [] if _planned(run, rid)]
    if frozen:  # had room plans, none selected (rooms without any were said at compose)
        run.notes.append(f"room(s) whose furniture no selected variant moves: {', '.join(frozen)}")
    for k, scene in enumerate(house.rooms):  # POS and ROT per room, from the run's model
        judged = await judge_scenes(run, rec, [scene, *(v.rooms[k] for v in run.house_variants)])
        if judged is not None:
            run.metrics["rooms"][scene.id]["semantic_judge"] = {"base": judged[0], "variants": judged[1:]}
    rec.detail["house"] = run.metrics["house"]


def _houses(run: PipelineRun) -> list[tuple[Path, House]]:
    """The houses the export delivers, by folder (``base/``, ``variant_<i>/``), each as delivered
    (``--open-state``: ``assets.open_scene``)."""
    houses = [(run.folder.base, run.need_house()), *((run.folder.variant(i), v) for i, v in enumerate(run.house_variants, start=1))]
    return [(folder, open_scene(h, run.config.open_state, run.config.seed, run.base_dir)) for folder, h in houses]


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
        self.call = asyncio.ensure_future(_in_workers(run, self.queue, workers, self._replied))
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
            WorkerJob(f"{folder.name}#{k}", _encode(ExportJob(folder=staged, parts=list(parts), config=self._config)),
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


async def _deliver_ahead(run: PipelineRun, names: set[str], houses: list[tuple[Path, House]] | None = None) -> None:
    """Start delivering the houses of the folders ``names`` (``base``, ``variant_<i>``) into
    :attr:`RunFolder.staged` in the run's worker processes, in the background
    (:class:`HouseDeliveries`): the next stages (compose, validate, evaluate, one core) run
    meanwhile, and the export stage waits for them and moves them into place. The houses must be
    final: nothing later changes them. Without worker processes (a model that is not ``rules``,
    one worker) nothing is started. ``houses``: :func:`_houses`, when the caller has them."""
    workers = _in_processes(run.config, len(run.need_house().rooms))
    if not workers:
        return
    if run.deliveries is None:
        run.deliveries = HouseDeliveries(run, workers)
    deliveries = _house_deliveries(run)
    assert deliveries is not None
    for folder, house in _houses(run) if houses is None else houses:
        if folder.name in names and folder.name not in deliveries.houses:
            await deliveries.add(folder, house)


def _house_deliveries(run: PipelineRun) -> HouseDeliveries | None:
    """The run's deliveries ahead, as the house stages started them (``None``: none started)."""
    ahead = run.deliveries
    if ahead is not None and not isinstance(ahead, HouseDeliveries):
        raise TypeError(f"a house run's deliveries ahead are HouseDeliveries, not {type(ahead).__name__}")
    return ahead


async def _stage_export(run: PipelineRun, rec: StageRecord) -> None:
    """``base/`` and every ``variant_<i>/`` as whole houses, and the contact sheet of their plans.
    Houses delivered ahead (:func:`_deliver_ahead`) are waited for and moved into place; any not
    started yet join them first."""
    houses = _houses(run)
    await _deliver_ahead(run, {folder.name for folder, _ in houses}, houses)
    files: dict[str, list[str]] = {}
    sheet = ContactSheet(len(houses)) if run.house_variants else None  # each plan placed as its house lands
    ahead = _house_deliveries(run)
    if ahead is not None:
        async for name, written in ahead.landed():
            final = run.folder.root / name
            await asyncio.to_thread(_put_in_place, run.folder.staged / name, final)
            files[str(final)] = written
            if sheet is not None:
                await asyncio.to_thread(sheet.add, name, final / RunFolder.TOPDOWN)
        rec.detail["delivered_ahead"] = sorted(ahead.houses)
        # how long the houses took to deliver, from the first one begun: mostly while other stages ran
        rec.detail["deliveries_s"] = round(time.perf_counter() - ahead.started, 3)
    else:
        cache = run.cache()
        for folder, house in houses:
            files[str(folder)] = await asyncio.to_thread(functools.partial(deliver_scene, house, folder, run.base_dir, hull_cache=cache))
            if sheet is not None:
                await asyncio.to_thread(sheet.add, folder.name, folder / RunFolder.TOPDOWN)
    rec.detail["files"] = files[str(run.folder.base)]
    if sheet is not None:
        await asyncio.to_thread(sheet.save, run.folder.contact_sheet)
    missing = formats_left_out()
    if missing:
        rec.detail["formats_left_out"] = missing
    if run.house_variants:
        rec.detail["contact_sheet"] = RunFolder.CONTACT_SHEET


def _put_in_place(staged: Path, final: Path) -> None:
    """Move a house delivered ahead from the staging folder to its place (what was there goes)."""
    if final.is_symlink() or final.is_file():
        final.unlink()
    elif final.exists():
        shutil.rmtree(final)
    os.replace(staged, final)


HOUSE_STAGES: tuple[Stage, ...] = (
    Stage("import", _stage_import),
    Stage("rooms", _stage_rooms),
    Stage("compose", _stage_compose),
    Stage("validate", _stage_validate),
    Stage("evaluate", _stage_evaluate),
    Stage("export", _stage_export),
)
"""The stages of a house run, in order (``rooms`` runs the plan's room stages in every room)."""

HOUSE_STAGE_NAMES: tuple[str, ...] = tuple(stage.name for stage in HOUSE_STAGES)
"""The names of :data:`HOUSE_STAGES`, in order."""

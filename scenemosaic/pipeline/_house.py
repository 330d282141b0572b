"""A whole house in one run: every room worked on at once, then composed, checked and delivered as one.

A multi-room house input (an AI2-THOR / ProcTHOR house file without ``room``) runs in two steps:

1. **rooms** — each room is a run of its own over :data:`HOUSE_ROOM_STAGES` (import → assets →
   structure → stabilize → evolve → doors) in ``OUT/rooms/<room>/``, with its own checkpoint, so
   a stopped house resumes room by room. Rooms are independent until the house-level checks, so
   they run concurrently: in ``room_workers`` processes when the model is the offline ``rules``
   (CPU-bound work), else as tasks of this process sharing one model stack (waiting on a server).
2. **the house** — ``compose`` draws whole-house variants from one candidate pool over every
   room's unit variants (``compose.compose_house``: a candidate is valid when every room is, its
   doors clear and its floor as connected as the base's); ``validate`` simulates every room and
   checks the house (door clearance, reachability from room to room, nothing across a wall);
   ``evaluate`` measures each room and the house; ``export`` delivers ``base/`` and each
   ``variant_<i>/`` as whole houses (``exchange.deliver_house``) and the contact sheet.

``docs/houses.md`` describes the model, the checks and their constants.
"""

from __future__ import annotations

import asyncio
import functools
import json
import os
import sys
import time
import traceback
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from scenemosaic.compose import compose_house
from scenemosaic.dag import FileRunStore
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.exchange import export_house_folder, formats_left_out, load_house, save_house
from scenemosaic.metrics import evaluate, house_diversity, relkeep
from scenemosaic.physics import check_collisions, check_out_of_bounds, validate_scene
from scenemosaic.pipeline._checkpoint import (
    RunCheckpoint,
    checkpoint_state,
    input_digest,
    load_checkpoint,
    save_checkpoint,
    write_json,
)
from scenemosaic.pipeline._config import GenerateConfig, config_from_record, config_record
from scenemosaic.pipeline._driver import as_interruption, run_stages
from scenemosaic.pipeline._result import GenerateResult
from scenemosaic.pipeline._stages import HOUSE_ROOM_STAGES
from scenemosaic.pipeline._state import PipelineRun, StageCallback, StageRecord, open_model
from scenemosaic.render import contact_sheet
from scenemosaic.scene import House, RunFolder, Scene, door_blockers, house_walkable, wall_crossings

if TYPE_CHECKING:
    from scenemosaic.models import RunModel

__all__ = ["HOUSE_STAGE_NAMES", "RoomOutcome", "agenerate_house", "is_house_input", "room_worker"]

log = structlog.get_logger(__name__)

HOUSE_STAGE_NAMES = ("rooms", "compose", "validate", "evaluate", "export")
"""The stages of a house run, in order (``rooms`` runs :data:`HOUSE_ROOM_STAGES` in every room)."""
WORKER_MODULE = "scenemosaic.pipeline._house_worker"
"""The module a house run's worker processes run (``python -m``)."""


def is_house_input(input_path: Path, config: GenerateConfig) -> bool:
    """Whether a run's input is a whole multi-room house (and no ``room`` picks one of its rooms)."""
    if config.room is not None or config.prompt is not None or config.format not in ("auto", "procthor"):
        return False
    if not (input_path.is_file() and input_path.suffix.lower() == ".json"):
        return False
    try:
        return len(load_house(input_path, config.format).rooms) > 1
    except SceneMosaicError:
        return False  # not a house, or a broken one: the one-scene import says what is wrong


# -- one room ---------------------------------------------------------------------------------------


@dataclass
class RoomOutcome:
    """What one room's run left for the house (picklable: it comes back from a worker process)."""

    room_id: str
    state: RunCheckpoint | None
    error: str | None = None
    error_type: str | None = None
    seconds: float = 0.0


async def _room_part(
    input_path: Path, root: Path, room_id: str, config: GenerateConfig, base_dir: Path, model: RunModel | None
) -> RoomOutcome:
    t0 = time.perf_counter()
    folder = RunFolder(root).room(room_id)
    run = PipelineRun(input_path=input_path, folder=folder, config=config.model_copy(update={"room": room_id}), base_dir=base_dir)
    run.store = FileRunStore(folder.checkpoint)
    run.model = model
    digest = await asyncio.to_thread(input_digest, input_path, run.config)
    finished = await asyncio.to_thread(load_checkpoint, run, digest) if config.resume else set()
    if not config.resume:
        await asyncio.to_thread(save_checkpoint, run, digest)
    try:
        failure = await run_stages(run, finished, digest, None, HOUSE_ROOM_STAGES)
        if failure is None:  # the stages' last word, reused ones included: what the house reads back
            await asyncio.to_thread(save_checkpoint, run, digest)
    finally:
        if model is None and run.model is not None:
            await run.model.aclose()
    if isinstance(failure, asyncio.CancelledError):
        raise failure
    error = None if failure is None else f"{type(failure).__name__}: {failure}"
    if failure is not None and not isinstance(failure, SceneMosaicError):
        log.error("room_failed", room=room_id, traceback="".join(traceback.format_exception(failure)))
    return RoomOutcome(room_id, checkpoint_state(run), error, type(failure).__name__ if failure else None, time.perf_counter() - t0)


async def room_worker(input_path: Path, root: Path, base_dir: Path) -> None:
    """A worker process's loop (``python -m scenemosaic.pipeline._house_worker``): one job a line
    on stdin — ``room <id>`` (that room's run; its state goes to its checkpoint) or ``export
    <folder>`` (every house-wide format of the house saved there) — and one JSON line on stdout
    when it ends."""
    record = json.loads(RunFolder(root).run_record.read_text(encoding="utf-8"))
    config = config_from_record(record["config"], resume=bool(record.get("resume")))
    reader = asyncio.StreamReader()
    loop = asyncio.get_running_loop()
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    while line := (await reader.readline()).decode().strip():
        kind, _, arg = line.partition(" ")
        t0 = time.perf_counter()
        reply: dict[str, Any] = {"job": line, "error": None, "error_type": None}
        if kind == "room":
            outcome = await _room_part(input_path, root, arg, config, base_dir, None)
            reply.update(error=outcome.error, error_type=outcome.error_type)
        else:
            try:
                await asyncio.to_thread(export_house_folder, Path(arg))
            except Exception as exc:  # reported to the parent, which fails the stage
                reply.update(error=f"{type(exc).__name__}: {exc}", error_type=type(exc).__name__)
        reply["seconds"] = time.perf_counter() - t0
        print(json.dumps(reply), flush=True)


class _Workers:
    """The child processes of a house run (``python -m scenemosaic.pipeline._house_worker``),
    started on first use and kept for the run: each takes the next job as it finishes one."""

    def __init__(self, run: HouseRun, count: int) -> None:
        self.run, self.count = run, count
        self.procs: list[asyncio.subprocess.Process] = []

    async def _start(self) -> None:
        run = self.run
        args = [str(run.input_path), str(run.folder.root), str(run.base_dir)]
        pipe = asyncio.subprocess.PIPE
        while len(self.procs) < self.count:
            proc = await asyncio.create_subprocess_exec(sys.executable, "-m", WORKER_MODULE, *args, stdin=pipe, stdout=pipe)
            self.procs.append(proc)

    async def map(self, jobs: Sequence[str]) -> dict[str, dict[str, Any]]:
        """Run every job (``room <id>``, ``export <folder>``); their replies by job."""
        await self._start()
        queue: asyncio.Queue[str] = asyncio.Queue()
        for job in jobs:
            queue.put_nowait(job)
        replies: dict[str, dict[str, Any]] = {}

        async def serve(proc: asyncio.subprocess.Process) -> None:
            assert proc.stdin is not None and proc.stdout is not None
            while not queue.empty():
                job = queue.get_nowait()
                proc.stdin.write(f"{job}\n".encode())
                await proc.stdin.drain()
                line = await proc.stdout.readline()
                if not line:
                    raise SceneMosaicError(f"the worker process running {job!r} stopped (exit code {await proc.wait()})")
                replies[job] = json.loads(line)

        try:
            await asyncio.gather(*(serve(p) for p in self.procs))
        except BaseException:
            self.kill()  # a stop or a failure: no job keeps working behind our back
            raise
        return replies

    def kill(self) -> None:
        for proc in self.procs:
            if proc.returncode is None:
                proc.kill()
        self.procs = []

    async def close(self) -> None:
        for proc in self.procs:
            if proc.stdin is not None:
                proc.stdin.close()
        for proc in self.procs:
            await proc.wait()
        self.procs = []


def _in_processes(config: GenerateConfig, rooms: int) -> int:
    """How many worker processes the rooms get (0: run them in this process)."""
    workers = config.room_workers or min(os.cpu_count() or 1, rooms)
    portable = config.model == "rules" and config.agents is None and not config.layout_rules
    return min(workers, rooms) if workers > 1 and portable and rooms > 1 else 0


# -- the house run --------------------------------------------------------------------------------


@dataclass
class HouseRun:
    """What a house run carries from stage to stage."""

    input_path: Path
    folder: RunFolder
    config: GenerateConfig
    base_dir: Path
    house: House
    rooms: dict[str, RoomOutcome] = field(default_factory=dict)
    variants: list[House] = field(default_factory=list)
    records: list[StageRecord] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    validation: dict[str, Any] | None = None
    metrics: dict[str, Any] | None = None
    room_validation: dict[str, dict[str, Any]] = field(default_factory=dict)
    variant_checks: list[dict[str, Any]] = field(default_factory=list)
    """The house checks of each variant, as compose measured them (evaluate reports them)."""
    context: PipelineRun | None = None
    """The hull cache, shapes and model stack shared by the house-level stages."""
    workers: _Workers | None = None
    """The worker processes, when the rooms run in them (the export uses them too)."""

    def ctx(self) -> PipelineRun:
        if self.context is None:
            self.context = PipelineRun(input_path=self.input_path, folder=self.folder, config=self.config, base_dir=self.base_dir)
        return self.context


async def agenerate_house(
    input_path: Path, folder: RunFolder, config: GenerateConfig, base_dir: Path, on_stage: StageCallback | None
) -> GenerateResult:
    """Run a whole house (see the module docstring); the output layout is ``OUT/base/`` (a whole
    house), ``OUT/variant_<i>/`` (whole houses), ``OUT/rooms/<room>/`` (each room's work),
    ``OUT/report.json`` (per-room and house figures) and ``OUT/contact_sheet.png``."""
    started = time.perf_counter()
    house = await asyncio.to_thread(load_house, input_path, config.format)
    run = HouseRun(input_path=input_path, folder=folder, config=config, base_dir=base_dir, house=house)
    digest = await asyncio.to_thread(input_digest, input_path, config)
    record = {"input": str(input_path), "input_sha256": digest, "config": config_record(config), "house": True, "resume": config.resume}
    await asyncio.to_thread(write_json, folder.run_record, record)
    failure: BaseException | None = None
    try:
        for name, body in _HOUSE_STAGES:
            rec = StageRecord(name=name)
            run.records.append(rec)
            if on_stage:
                on_stage(name, "started")
            t0 = time.perf_counter()
            try:
                await body(run, rec)
            except (Exception, asyncio.CancelledError) as raised:
                exc = as_interruption(raised)
                rec.seconds = time.perf_counter() - t0
                rec.status = "interrupted" if isinstance(exc, asyncio.CancelledError) else "failed"
                rec.detail["error"] = "interrupted" if rec.status == "interrupted" else f"{type(exc).__name__}: {exc}"
                if on_stage:
                    on_stage(name, "failed")
                failure = exc
                break
            rec.seconds = time.perf_counter() - t0
            if rec.status == "pending":
                rec.status = "done"
            log.info("house_stage_finished", stage=name, seconds=round(rec.seconds, 3))
            if on_stage:
                on_stage(name, "done")
    finally:
        ctx = run.context
        if ctx is not None and ctx.model is not None:
            await ctx.model.aclose()
        if run.workers is not None:
            if failure is None:
                await run.workers.close()
            else:
                run.workers.kill()
    report = _report(run, time.perf_counter() - started, failure)
    await asyncio.shield(asyncio.to_thread(write_json, folder.report, report))
    if failure is not None:
        raise failure
    if report["status"] == "degraded":
        log.warning("run_degraded", warnings=run.warnings)
    return GenerateResult(scene=run.house, out_dir=folder.root, report=report)


# -- stages -----------------------------------------------------------------------------------------


async def _stage_rooms(run: HouseRun, rec: StageRecord) -> None:
    """Every room through :data:`HOUSE_ROOM_STAGES`, concurrently (largest rooms first)."""
    ids = sorted(run.house.room_ids, key=lambda rid: -len(run.house.room(rid).objects))
    workers = _in_processes(run.config, len(ids))
    rec.detail["workers"] = workers or 1
    rec.detail["processes"] = bool(workers)
    if workers:
        run.workers = _Workers(run, workers)
        replies = await run.workers.map([f"room {rid}" for rid in ids])
        outcomes = []
        for rid in ids:
            reply = replies[f"room {rid}"]
            state = await asyncio.to_thread(_room_state, run, rid)
            outcomes.append(RoomOutcome(rid, state, reply["error"], reply["error_type"], float(reply["seconds"])))
    else:
        ctx = run.ctx()
        model = await open_model(run.config, ctx.started)
        ctx.model = model
        tasks = [_room_part(run.input_path, run.folder.root, rid, run.config, run.base_dir, model) for rid in ids]
        outcomes = list(await asyncio.gather(*tasks))
    by_id = {o.room_id: o for o in outcomes}
    run.rooms = {rid: by_id[rid] for rid in run.house.room_ids}
    rooms: list[Scene] = []
    failed = []
    for rid, outcome in run.rooms.items():
        state = outcome.state
        if outcome.error or state is None or state.scene is None:
            failed.append(f"{rid}: {outcome.error or 'no scene'}")
            continue
        rooms.append(state.scene)
        run.warnings += [f"{rid}: {w}" for w in state.warnings]
    rec.detail["seconds_per_room"] = {rid: round(o.seconds, 3) for rid, o in run.rooms.items()}
    rec.detail["critical_path_s"] = round(max((o.seconds for o in outcomes), default=0.0), 3)
    rec.detail["sum_of_rooms_s"] = round(sum(o.seconds for o in outcomes), 3)
    if failed:
        raise SceneMosaicError("room(s) failed: " + "; ".join(failed))
    run.house = run.house.with_rooms(rooms)


def _room_state(run: HouseRun, room_id: str) -> RunCheckpoint | None:
    """A room's state as its run's checkpoint left it (a worker process ran it)."""
    part = PipelineRun(
        input_path=run.input_path, folder=run.folder.room(room_id), config=run.config.model_copy(update={"room": room_id, "resume": True}),
        base_dir=run.base_dir,
    )  # fmt: skip
    part.store = FileRunStore(part.folder.checkpoint)
    load_checkpoint(part, input_digest(run.input_path, part.config))
    return checkpoint_state(part)


def _house_checks(house: House) -> dict[str, Any]:
    """Door clearance, reachability and walls: what only the whole house can say."""
    walk = house_walkable(house)
    blockers = door_blockers(house)
    crossings = wall_crossings(house)
    return {
        "house_nav": round(walk.nav, 4),
        "rooms_reached": {k: round(v, 4) for k, v in walk.reached().items()},
        "unreachable_rooms": walk.unreachable_rooms(),
        "door_blockers": [f"{b.object_id} ({b.door})" for b in blockers],
        "wall_crossings": [f"{o} ({r}, {d:.3f} m)" for r, o, d in crossings],
        "doorways": len(house.doorways()),
    }


def _checks_fail(checks: dict[str, Any]) -> list[str]:
    out = []
    if checks["unreachable_rooms"]:
        out.append(f"room(s) not reachable from the rest of the house: {', '.join(checks['unreachable_rooms'])}")
    if checks["door_blockers"]:
        out.append(f"door(s) blocked by {', '.join(checks['door_blockers'][:6])}")
    if checks["wall_crossings"]:
        out.append(f"object(s) across a wall: {', '.join(checks['wall_crossings'][:6])}")
    return out


def _variants_of(outcome: RoomOutcome) -> list[Scene]:
    return list(outcome.state.variants) if outcome.state is not None else []


async def _stage_compose(run: HouseRun, rec: StageRecord) -> None:
    """Whole-house variants: one pool over every room's own valid variants (``compose_house``);
    a house is valid when every room stays reachable from every other."""
    m = run.config.variants
    room_variants = [_variants_of(run.rooms[s.id]) for s in run.house.rooms]
    if m <= 0 or not any(room_variants):
        rec.status = "skipped"
        rec.detail["reason"] = "no variants asked for" if m <= 0 else "no room has a variant"
        return
    ctx = run.ctx()
    base_unreachable = set(house_walkable(run.house).unreachable_rooms())

    def reachable(rooms: list[Scene]) -> bool:
        return set(house_walkable(run.house.with_rooms(rooms)).unreachable_rooms()) <= base_unreachable

    compose = functools.partial(compose_house, run.house.rooms, room_variants, m=m, seed=run.config.seed, accept=reachable)
    variants, report = await asyncio.to_thread(compose)
    rec.detail.update(report.summary())
    rec.detail["room_variants"] = {s.id: len(v) for s, v in zip(run.house.rooms, room_variants, strict=True)}
    checked = []
    for i, rooms in enumerate(variants, start=1):
        for s in rooms:
            s.provenance.notes.append(f"house variant {i}: this room as {report.picked[i - 1][s.id]}")
        house = run.house.with_rooms(rooms)
        name = run.folder.variant(i).name
        cols = oob = 0
        for s in rooms:
            shapes = ctx.shapes(s)
            cols += len((await asyncio.to_thread(check_collisions, s, run.base_dir, hull_cache=ctx.cache())).pairs)
            oob += len((await asyncio.to_thread(functools.partial(check_out_of_bounds, s, shapes=shapes))).objects)
        checks = await asyncio.to_thread(_house_checks, house)
        run.variant_checks.append(checks)
        checked.append({"folder": name, "collision_pairs": cols, "out_of_bounds": oob, **checks})
        problems = _checks_fail(checks) + ([f"{cols} colliding pair(s), {oob} object(s) out of bounds"] if cols or oob else [])
        if problems:
            run.warnings.append(f"{name}: " + "; ".join(problems))
        run.variants.append(house)
    rec.detail["variants"] = checked
    if len(variants) < m:
        rec.detail["shortfall"] = f"{m} variants asked for, {len(variants)} distinct valid ones in a pool of {report.pool_size}"
        log.warning("fewer_variants_than_asked", asked=m, written=len(variants), pool=report.pool_size)


async def _stage_validate(run: HouseRun, rec: StageRecord) -> None:
    """Simulate every room of the base house; then the house-wide checks."""
    ctx = run.ctx()
    per_room: dict[str, Any] = {}
    for scene in run.house.rooms:
        report = await asyncio.to_thread(functools.partial(validate_scene, scene, run.base_dir, hull_cache=ctx.cache()))
        per_room[scene.id] = report.model_dump(mode="json")
        rid = scene.id
        if report.collisions.pairs:
            run.warnings.append(f"{rid}: {len(report.collisions.pairs)} colliding pair(s) left")
        if report.out_of_bounds.objects:
            run.warnings.append(f"{rid}: {len(report.out_of_bounds.objects)} object(s) out of bounds")
        if report.fell:
            run.warnings.append(f"{rid}: object(s) fell in the validation run: " + ", ".join(report.fell[:10]))
        if report.tipped:
            run.warnings.append(f"{rid}: object(s) tipped in the validation run: " + ", ".join(report.tipped[:10]))
    checks = await asyncio.to_thread(_house_checks, run.house)
    run.warnings += [f"base: {p}" for p in _checks_fail(checks)]
    run.room_validation = per_room
    run.validation = {
        "collision_pairs": sum(len(v["collisions"]["pairs"]) for v in per_room.values()),
        "out_of_bounds": sum(len(v["out_of_bounds"]["objects"]) for v in per_room.values()),
        "fell": sum(len(v["fell"]) for v in per_room.values()),
        "tipped": sum(len(v["tipped"]) for v in per_room.values()),
        **checks,
    }
    rec.detail.update({k: v for k, v in run.validation.items() if not isinstance(v, dict | list) or len(v) <= 20})


async def _stage_evaluate(run: HouseRun, rec: StageRecord) -> None:
    """Each room's metrics (base and variants) and the house's: NAV, reachability, diversity, RelKeep."""
    ctx = run.ctx()
    rooms: dict[str, Any] = {}
    for k, scene in enumerate(run.house.rooms):
        variants = [v.rooms[k] for v in run.variants]
        measure = functools.partial(
            evaluate, scene, variants, base_dir=run.base_dir, variant_dirs=[run.base_dir] * len(variants), hull_cache=ctx.cache()
        )
        rooms[scene.id] = await asyncio.to_thread(measure)

    def house_figures() -> dict[str, Any]:
        base = run.validation or _house_checks(run.house)  # validate measured the base
        out: dict[str, Any] = {"base": {k: base[k] for k in ("house_nav", "unreachable_rooms", "door_blockers", "wall_crossings")}}
        out["variants"] = []
        for v, checks in zip(run.variants, run.variant_checks, strict=True):
            keep = [relkeep(b, s) for b, s in zip(run.house.rooms, v.rooms, strict=True)]
            out["variants"].append(
                {
                    "house_nav": checks["house_nav"],
                    "unreachable_rooms": checks["unreachable_rooms"],
                    "door_blockers": len(checks["door_blockers"]),
                    "wall_crossings": len(checks["wall_crossings"]),
                    "RelKeep": round(min(keep), 4) if keep else 1.0,
                }
            )
        if run.variants:
            out["diversity"] = house_diversity(run.variants)
        return out

    house = await asyncio.to_thread(house_figures)
    run.metrics = {"house": house, "rooms": rooms}
    rec.detail["house"] = house


async def _stage_export(run: HouseRun, rec: StageRecord) -> None:
    """``base/`` and every ``variant_<i>/`` as whole houses (the native files here, the house-wide
    formats in the worker processes when there are some), and the contact sheet of their plans."""
    houses = [(run.folder.base, run.house), *((run.folder.variant(i), v) for i, v in enumerate(run.variants, start=1))]
    for folder, house in houses:
        await asyncio.to_thread(save_house, house, folder, base_dir=run.base_dir)
    if run.workers is not None:
        replies = await run.workers.map([f"export {folder}" for folder, _ in houses])
        failed = [f"{job}: {r['error']}" for job, r in replies.items() if r["error"]]
        if failed:
            raise SceneMosaicError("house export failed: " + "; ".join(failed))
    else:
        for folder, _ in houses:
            await asyncio.to_thread(export_house_folder, folder)
    base = run.folder.base
    rec.detail["files"] = sorted(str(p.relative_to(base)) for p in base.iterdir() if p.is_file())
    if run.variants:
        folders = [folder for folder, _ in houses]
        await asyncio.to_thread(contact_sheet, [(f.name, f / RunFolder.TOPDOWN) for f in folders], run.folder.contact_sheet)
        rec.detail["contact_sheet"] = RunFolder.CONTACT_SHEET
    missing = formats_left_out()
    if missing:
        rec.detail["formats_left_out"] = missing


_HOUSE_STAGES = (
    ("rooms", _stage_rooms),
    ("compose", _stage_compose),
    ("validate", _stage_validate),
    ("evaluate", _stage_evaluate),
    ("export", _stage_export),
)


# -- the report -----------------------------------------------------------------------------------


def _report(run: HouseRun, total_s: float, failure: BaseException | None) -> dict[str, Any]:
    if isinstance(failure, asyncio.CancelledError):
        status, error = "interrupted", "interrupted: the run was stopped (signal or cancel); resume it with --resume"
    elif failure is not None:
        status, error = "failed", f"{type(failure).__name__}: {failure}"
    else:
        status, error = ("degraded" if run.warnings else "ok"), None
    trace = None
    if failure is not None and not isinstance(failure, SceneMosaicError | asyncio.CancelledError):
        trace = "".join(traceback.format_exception(failure))
    rooms: dict[str, Any] = {}
    for s in run.house.rooms:
        outcome = run.rooms.get(s.id)
        state = outcome.state if outcome else None
        rooms[s.id] = {
            "room_type": (s.metadata.get("procthor") or {}).get("room_type"),
            "objects": len(s.objects),
            "seconds": round(outcome.seconds, 3) if outcome else None,
            "error": outcome.error if outcome else None,
            "stages": [
                {"name": r["name"], "seconds": round(r["seconds"], 4), "status": r["status"], "detail": r["detail"]}
                for r in (state.records if state else [])
            ],
            "warnings": list(state.warnings) if state else [],
            "validation": run.room_validation.get(s.id),
        }
    delivered = any(r.name == "export" and r.status == "done" for r in run.records)
    return {
        "input": str(run.input_path),
        "config": config_record(run.config) | {"variants_requested": run.config.variants},
        "house": {"id": run.house.id, "rooms": run.house.room_ids, "doorways": len(run.house.doorways())},
        "status": status,
        "error": error,
        "failed_stage": next((r.name for r in run.records if r.status in ("failed", "interrupted")), None),
        "traceback": trace,
        "warnings": list(run.warnings),
        "total_seconds": round(total_s, 4),
        "objects": len(run.house.objects),
        "categories": sorted({o.category for o in run.house.objects}),
        "variants_written": len(run.variants) if delivered else 0,
        "stages": [
            {"name": r.name, "seconds": round(r.seconds, 4), "status": r.status, "objects": None, "detail": r.detail}
            for r in run.records
        ],
        "rooms": rooms,
        "validation": run.validation,
        "metrics": run.metrics,
    }

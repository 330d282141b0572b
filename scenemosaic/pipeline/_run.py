"""The driver of ``generate``: runs :data:`STAGES` over one :class:`PipelineRun` and never loses work.

* The run's model stack is opened once (``models.open_run_model``), by the first stage that asks
  the model, and closed when the stage loop ends; each stage's usage is the difference of two
  readings of it.
* After every stage the run's state goes to its checkpoint (``pipeline/_checkpoint.py``);
  ``resume=True`` continues a stopped run from there (finished stages and finished agents are
  reused, hulls come from the on-disk cache).
* A failing or cancelled run (Ctrl-C, SIGTERM: the CLI cancels the task) writes ``report.json``
  *first* (with the traceback of an unexpected error), then keeps the last good scene or house in
  ``base/`` as native files marked partial (``base/partial.json``: the loaders refuse it unless
  asked for a partial result), so a second signal loses nothing and nothing looks delivered.
* The outcome is ``ok``, ``degraded`` (the files are there, but collisions, fallen objects or
  solver fallbacks remain: each named in ``warnings``), ``failed`` or ``interrupted``.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import fcntl
import functools
import shutil
import sys
import time
from collections.abc import Coroutine, Iterator
from pathlib import Path
from typing import IO, Any, TypeVar

import structlog

from scenemosaic.dag import FileRunStore
from scenemosaic.exceptions import OutputSpaceError, UsageError
from scenemosaic.exchange import is_dataset, save_partial
from scenemosaic.pipeline._checkpoint import (
    input_digest,
    load_checkpoint,
    previous_input,
    save_checkpoint,
    write_json,
)
from scenemosaic.pipeline._config import INPUT_SIZE_LIMITS_MB, GenerateConfig, check_config
from scenemosaic.pipeline._driver import run_stages
from scenemosaic.pipeline._plan import plan
from scenemosaic.pipeline._report import RunReport, run_report
from scenemosaic.pipeline._result import GenerateResult
from scenemosaic.pipeline._stages import STAGES, is_image_input
from scenemosaic.pipeline._state import PipelineRun, RunSetup, StageCallback
from scenemosaic.pipeline._workers import release_workers
from scenemosaic.scene import RunFolder, not_a_regular_file

__all__ = ["REPORT_FILE", "agenerate", "generate", "run_sync", "stage_progress"]

T = TypeVar("T")

log = structlog.get_logger(__name__)

REPORT_FILE = RunFolder.REPORT
"""The run's report in its output folder."""


# -- folders --------------------------------------------------------------------------------------


def _prepare_folders(input_path: Path, folder: RunFolder, config: GenerateConfig) -> Path:
    """Check the input and the output folder; returns the folder relative asset paths start from.

    An output folder holding another input's results is refused unless ``overwrite``; a re-run of
    the same input (not resumed) first removes the previous results, so a failing re-run never
    leaves an old ``base/`` beside its new report.
    """
    out = folder.root  # made, and shown writable, by taking its lock (_hold_lock)
    if any(p.name != RunFolder.LOCK for p in out.iterdir()):
        previous = previous_input(folder)
        same = previous is not None and Path(previous).resolve() == input_path.resolve()
        if not same and not config.overwrite:
            what = f"the results of {previous}" if previous else "files scenemosaic did not write"
            raise UsageError(
                f"output folder {out} already holds {what}; choose an empty folder or pass "
                "overwrite=True (--overwrite) to replace it"
            )
        if not config.resume:
            for target in folder.outputs():
                if target.is_symlink():  # planted (base/ -> elsewhere): the link goes, never what it points at
                    target.unlink()
                elif target.is_dir():
                    shutil.rmtree(target)
                elif target.exists():
                    target.unlink()
    return input_path if input_path.is_dir() else input_path.parent


def _input_of(input_path: str | Path | None, folder: RunFolder, config: GenerateConfig) -> Path:
    """The run's input: the given path, or for a text prompt the image it is drawn into."""
    if config.prompt is None:
        if input_path is None:
            raise UsageError("give an input (a scene file or folder, or a photograph), or a text prompt")
        return Path(input_path)
    if input_path is not None and Path(input_path).resolve() != folder.prompt_image.resolve():
        raise UsageError("give an input or a text prompt, not both")
    if not config.prompt.strip():
        raise UsageError("the text prompt is empty")
    return folder.prompt_image


# -- the driver -----------------------------------------------------------------------------------


async def agenerate(
    input_path: str | Path | None,
    out_dir: str | Path,
    config: GenerateConfig | None = None,
    *,
    on_stage: StageCallback | None = None,
) -> GenerateResult:
    """Run the pipeline on ``input_path`` and write the output layout under ``out_dir``.

    ``input_path`` is a scene file or folder, or a photograph (the image front end); with
    ``config.prompt`` it is ``None`` and the room is drawn from the text first (``OUT/prompt.png``).
    A multi-room house (without ``config.room``) is generated whole (``docs/houses.md``): the
    result's ``scene`` is then a :class:`~scenemosaic.scene.House`.

    Raises the failing stage's error after writing ``report.json`` (and ``base/`` from the
    last good scene when there is one), so partial results are kept. Cancelling the task stops
    the run at once: ``report.json`` (status ``interrupted``) and ``base/scene.json`` are written
    before the cancel propagates. With ``config.resume`` a stopped run continues from its
    checkpoints. A finished run's report says ``ok`` or ``degraded`` (see ``warnings``).
    """
    config = config or GenerateConfig()
    check_config(config)
    folder = RunFolder(out_dir)
    input_path = _input_of(input_path, folder, config)
    await asyncio.to_thread(_check_paths, input_path, folder, config)
    lock = await asyncio.to_thread(_hold_lock, folder)
    try:
        return await _agenerate_locked(input_path, folder, config, on_stage)
    finally:
        lock.close()  # releases the lock


def _check_paths(input_path: Path, folder: RunFolder, config: GenerateConfig) -> None:
    """The input exists, and neither it nor the output folder lies where the other would be harmed:
    an input inside what the run writes would be removed first; an output folder inside an input
    folder would be read back as input."""
    out = folder.root
    if not input_path.exists() and config.prompt is None:
        raise UsageError(f"input not found: {input_path}")
    if config.prompt is None:
        _check_input_file(input_path, config)
    if config.prompt is None:  # a prompt's image lives in OUT by design
        src, dst = input_path.resolve(), out.resolve()
        written = [p.resolve() for p in folder.outputs()]
        if src == dst or any(src == w or w in src.parents for w in written):
            raise UsageError(f"the input {input_path} lies in what the run writes in --out {out} (it would remove it); choose another folder")
        if input_path.is_dir() and src in dst.parents:
            raise UsageError(f"--out {out} lies inside the input folder {input_path}; choose a folder outside it")


def _check_input_file(input_path: Path, config: GenerateConfig) -> None:
    """The input is a folder or a regular file within its kind's size limit, found out without
    opening it: a device or a FIFO as input would never end or wait for ever."""
    special = not_a_regular_file(input_path)
    if special is not None and special != "a directory":
        raise UsageError(f"the input {input_path} is {special}, not a regular file: give a scene file, a folder or a photograph")
    if special is not None:
        return
    if is_dataset(input_path):  # streamed a line at a time (exchange/_dataset.py): no whole-file limit
        return
    kind = "image" if is_image_input(input_path, config.format) else "scene"
    limit_mb = config.max_input_mb or INPUT_SIZE_LIMITS_MB[kind]
    size_mb = input_path.stat().st_size / 1e6
    if size_mb > limit_mb:
        what = "photograph" if kind == "image" else "scene file"
        raise UsageError(
            f"the input {input_path} is {size_mb:,.1f} MB, over the {limit_mb:g} MB limit for a {what}; "
            "raise it with --max-input-mb if the file is meant to be this large"
        )


def _hold_lock(folder: RunFolder) -> IO[str]:
    """Take the output folder's lock (``OUT/.lock``, ``flock``) for the run; refuses a folder
    another run is writing into, or one that cannot be made."""
    out = folder.root
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        handle = folder.lock.open("a", encoding="utf-8")
    except OSError as exc:  # under a file, read-only, no permission: the user's to fix, not a crash
        raise UsageError(f"cannot write the output folder {out}: {exc.strerror or exc}") from exc
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        handle.close()
        raise UsageError(f"another run is writing into {out}; wait for it to end, or choose another folder") from None
    return handle


async def _agenerate_locked(
    input_path: Path, folder: RunFolder, config: GenerateConfig, on_stage: StageCallback | None
) -> GenerateResult:
    base_dir = await asyncio.to_thread(_prepare_folders, input_path, folder, config)
    planned = await asyncio.to_thread(plan, input_path, config)  # a house: every room at once (docs/houses.md)
    if is_image_input(input_path, config.format):  # a photograph's meshes are written beside what perception saw
        base_dir = folder.perception
    setup = RunSetup(input_path=input_path, folder=folder, config=config, base_dir=base_dir, room_stages=planned.room_stages)
    run = PipelineRun(setup)
    if on_stage is not None:  # the progress displays count the plan, announced before the first stage
        for name in planned.names:
            on_stage(name, "planned")
    run.store = FileRunStore(folder.checkpoint)
    digest = await asyncio.to_thread(input_digest, input_path, config)
    finished = await asyncio.to_thread(load_checkpoint, run, digest) if config.resume else set()
    if not config.resume:  # resumable from the first moment, even if stopped during the import
        await asyncio.to_thread(save_checkpoint, run, digest)
    started = time.perf_counter()
    failure: BaseException | None = None
    ended_well = False
    try:  # the run's one model stack, opened by the first stage that asks, closed here
        failure = await run_stages(run, finished, digest, on_stage, planned.stages)
        ended_well = failure is None
    finally:
        if run.model is not None:
            await run.model.aclose()
        if run.hull_cache is not None:  # its CoACD processes leave with the run (cancelled when it failed)
            await asyncio.to_thread(functools.partial(run.hull_cache.close, cancel=not ended_well))
        await _stop_deliveries(run)
        if run.workers is not None:  # gone (or idle, kept) before a partial result is written into their folders
            await asyncio.to_thread(functools.partial(release_workers, run.workers, keep=ended_well))
        if run.folder.staged.exists():  # what was delivered ahead is in place, or not wanted
            await asyncio.to_thread(shutil.rmtree, run.folder.staged, True)
    if failure is not None:
        await _keep_partial_results(run, failure, time.perf_counter() - started)
        raise failure
    report = run_report(run, time.perf_counter() - started, None)
    await asyncio.to_thread(_write_report, folder.report, report)
    if report.status == "degraded":
        log.warning("run_degraded", warnings=run.warnings)
    made = run.result
    assert made is not None
    return GenerateResult(scene=made, out_dir=folder.root, report=report.to_json())


async def _stop_deliveries(run: PipelineRun) -> None:
    """Deliveries started ahead of the export stage that it did not wait for (the run failed or
    was stopped before it) are stopped; a finished run's are done already."""
    if run.deliveries is not None:
        deliveries, run.deliveries = run.deliveries, None
        await deliveries.stop()


async def _keep_partial_results(run: PipelineRun, failure: BaseException, elapsed: float) -> None:
    """Report first, then the last good scene (or house) as a partial result; shielded, so a
    second cancel cannot lose the report.

    The partial result is the native files only (``scene.json`` or ``house_scene.json`` and each
    room's, with their meshes) and ``partial.json`` saying why: nothing a simulator would load as
    a finished scene, and the loaders refuse it unless asked for a partial result."""

    async def keep() -> None:
        report = run_report(run, elapsed, failure)
        await asyncio.to_thread(_write_report, run.folder.report, report)
        if isinstance(failure, OutputSpaceError):  # the disk is full: the report was the one file worth trying
            return
        made = run.result
        base = run.folder.base
        if made is None or RunFolder.is_delivered(base):  # a resumed run's earlier delivery stays
            return
        marker = {"status": report.status, "failed_stage": report.failed_stage, "error": report.error}
        try:
            report.partial_files = await asyncio.to_thread(save_partial, made, base, run.base_dir, marker)
        except Exception as exc:  # the original failure matters more; note this one
            log.warning("partial_export_failed", error=str(exc))
            report.partial_export_error = f"{type(exc).__name__}: {exc}"
        await asyncio.to_thread(_write_report, run.folder.report, report)

    task = asyncio.ensure_future(keep())
    try:
        await asyncio.shield(task)
    except asyncio.CancelledError:
        if not task.done():  # a second cancel: the report is written first thing; let the export finish
            await asyncio.wait([task])


def _write_report(path: Path, report: RunReport) -> None:
    """Write ``report.json``; on a full disk the report stays in memory, on the error (``report``)."""
    payload = report.to_json()
    try:
        write_json(path, payload)
    except OutputSpaceError as full:
        full.report = payload
        raise


def generate(
    input_path: str | Path | None,
    out_dir: str | Path,
    config: GenerateConfig | None = None,
    *,
    on_stage: StageCallback | None = None,
    progress: bool = False,
) -> GenerateResult:
    """Synchronous :func:`agenerate`. Inside a running event loop (a Jupyter cell), the run
    gets its own loop in a worker thread and this call waits for it; ``await agenerate(...)``
    there instead keeps the notebook's loop free. ``progress=True`` shows a bar of the stages
    (rich: a live bar in a terminal, a widget-free one in Jupyter)."""
    if not progress:
        return run_sync(agenerate(input_path, out_dir, config, on_stage=on_stage))
    with stage_progress(on_stage) as callback:
        return run_sync(agenerate(input_path, out_dir, config, on_stage=callback))


@contextlib.contextmanager
def stage_progress(then: StageCallback | None = None) -> Iterator[StageCallback]:
    """A progress display over the pipeline's stages; yields the ``on_stage`` callback that
    advances it (and calls ``then`` too).

    On a terminal, a live rich bar. Anywhere else (a Jupyter cell, a pipe) one plain line per
    finished stage on stderr, ``generate: structure done (3/10, 1.2 s)``: no widget library, no
    warning, nothing redrawn.
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=True, force_jupyter=False)  # rich's Jupyter display needs ipywidgets
    if Console().is_jupyter or not console.is_terminal:  # a kernel's stderr may claim to be a terminal
        yield _stage_lines(then)
        return
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=console,
    ) as bar:
        task = bar.add_task("generate", total=len(STAGES))
        planned: list[str] = []

        def callback(name: str, status: str) -> None:
            if status == "planned":  # the run's plan, announced stage by stage before the first
                planned.append(name)
                bar.update(task, total=len(planned))
            elif status == "started":
                bar.update(task, description=f"generate: {name}")
            elif status in ("done", "reused", "failed"):
                bar.advance(task)
            if then is not None:
                then(name, status)

        yield callback


def _stage_lines(then: StageCallback | None) -> StageCallback:
    """The widget-free progress: a line per finished stage (see :func:`stage_progress`)."""
    started = time.perf_counter()
    state = {"done": 0, "total": 0}

    def callback(name: str, status: str) -> None:
        if status == "planned":  # the run's plan, announced stage by stage before the first
            state["total"] += 1
        if status in ("done", "reused", "failed", "skipped"):
            state["done"] += 1
            elapsed = time.perf_counter() - started
            sys.stderr.write(f"generate: {name} {status} ({state['done']}/{state['total']}, {elapsed:.1f} s)\n")
            sys.stderr.flush()
        if then is not None:
            then(name, status)

    return callback


def run_sync(coro: Coroutine[Any, Any, T]) -> T:
    """Run ``coro`` to completion from synchronous code, with or without a running loop here.

    Inside a running loop (a notebook cell) the coroutine runs on a loop of its own in a worker
    thread. An interrupt of the caller (Ctrl-C, the notebook's stop button: ``KeyboardInterrupt``
    while it waits) cancels the coroutine there, as Ctrl-C cancels ``asyncio.run``, waits for it
    to wind down (a run writes its report, ``interrupted``, and keeps its partial result) and
    then raises the interrupt: nothing goes on running unseen."""
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return asyncio.run(coro)
    started: concurrent.futures.Future[tuple[asyncio.AbstractEventLoop, asyncio.Task[T]]] = concurrent.futures.Future()

    async def hosted() -> T:
        task = asyncio.ensure_future(coro)
        started.set_result((asyncio.get_running_loop(), task))
        return await task

    with concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="scenemosaic-sync") as pool:
        done = pool.submit(asyncio.run, hosted())
        try:
            return done.result()
        except KeyboardInterrupt:
            loop, task = started.result()
            with contextlib.suppress(RuntimeError):  # the run ended meanwhile: its loop is closed
                loop.call_soon_threadsafe(task.cancel)
            concurrent.futures.wait([done])  # the run stops and writes what it must
            raise

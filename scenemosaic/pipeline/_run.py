"""The driver of ``generate``: runs :data:`STAGES` over one :class:`PipelineRun` and never loses work.

* After every stage a checkpoint (the scene and the stage records) goes to ``out/.checkpoint``;
  ``resume=True`` continues a stopped run from there (finished stages and finished agents are
  reused, hulls come from the on-disk cache).
* A failing stage writes ``report.json`` (with the traceback of an unexpected error) and exports
  the last good scene to ``base/``. A cancelled run (Ctrl-C, SIGTERM: the CLI cancels the task)
  writes the report *first*, then only ``base/scene.json``, so a second signal loses nothing.
* The outcome is ``ok``, ``degraded`` (the files are there, but collisions, fallen objects or
  solver fallbacks remain: each named in ``warnings``), ``failed`` or ``interrupted``.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import json
import os
import shutil
import time
import traceback
from collections.abc import Coroutine, Iterator
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any, TypeVar

import structlog

from scenemosaic.exceptions import UsageError
from scenemosaic.pipeline._config import (
    GenerateConfig,
    GenerateResult,
    PipelineRun,
    StageCallback,
    StageRecord,
)
from scenemosaic.pipeline._stages import PROMPT_IMAGE, STAGES, export_base, export_scene_only, is_image_input
from scenemosaic.scene import Scene

__all__ = ["REPORT_FILE", "agenerate", "checkpoint_config", "generate", "run_sync", "stage_progress"]

T = TypeVar("T")

log = structlog.get_logger(__name__)

REPORT_FILE = "report.json"
_RUN_FILE = "run.json"
_OUTPUTS = ("base", "evolve", "perception", "contact_sheet.png", REPORT_FILE, ".checkpoint")
"""What a run writes into its output folder (and what ``overwrite`` may remove)."""
_CONFIG_KEYS = (
    "format", "model", "seed", "room", "stabilize", "solver_fallback", "vision", "request_timeout_s", "deadline_s",
    "variants", "evolve", "evolve_rounds", "save_views", "segmenter", "reconstructor", "hfov_deg",
    "prompt", "image_model", "image_size",
)  # fmt: skip
"""The settings that decide a run's results; a resumed run must agree on them."""


# -- folders, checkpoints ------------------------------------------------------------------------


def _config_record(config: GenerateConfig) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in _CONFIG_KEYS:
        value = getattr(config, key)
        out[key] = value if isinstance(value, str | int | float | bool | type(None)) else getattr(value, "name", str(value))
    for key in ("asset_dir", "cache_dir", "priors_dir", "detections"):
        value = getattr(config, key)
        out[key] = str(value) if value is not None else None
    return out


def checkpoint_config(out_dir: str | Path) -> tuple[Path, GenerateConfig]:
    """The input and settings of the run whose checkpoints are in ``out_dir`` (for ``--resume``).

    Raises :class:`~scenemosaic.exceptions.UsageError` when the folder holds no resumable run.
    """
    path = Path(out_dir) / ".checkpoint" / _RUN_FILE
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise UsageError(f"{out_dir} holds no run to resume ({path} unreadable: {exc})") from exc
    saved = data.get("config", {})
    known = {f.name for f in fields(GenerateConfig)}
    kwargs: dict[str, Any] = {k: v for k, v in saved.items() if k in known and k in _CONFIG_KEYS}
    for key in ("asset_dir", "cache_dir", "priors_dir", "detections"):
        if saved.get(key):
            kwargs[key] = Path(saved[key])
    return Path(data["input"]), GenerateConfig(**kwargs, resume=True)


def _prepare_folders(input_path: Path, out: Path, config: GenerateConfig) -> Path:
    """Check the input and the output folder; returns the folder relative asset paths start from.

    An output folder holding another input's results is refused unless ``overwrite``; a re-run of
    the same input (not resumed) first removes the previous results, so a failing re-run never
    leaves an old ``base/`` beside its new report.
    """
    if not input_path.exists() and config.prompt is None:
        raise UsageError(f"input not found: {input_path}")
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()):
        previous = _previous_input(out)
        same = previous is not None and Path(previous).resolve() == input_path.resolve()
        if not same and not config.overwrite:
            what = f"the results of {previous}" if previous else "files scenemosaic did not write"
            raise UsageError(
                f"output folder {out} already holds {what}; choose an empty folder or pass "
                "overwrite=True (--overwrite) to replace it"
            )
        if not config.resume:
            for name in (*_OUTPUTS, *(p.name for p in out.glob("variant_*"))):
                target = out / name
                if target.is_dir():
                    shutil.rmtree(target)
                elif target.exists():
                    target.unlink()
    out.mkdir(parents=True, exist_ok=True)
    return input_path if input_path.is_dir() else input_path.parent


def _input_of(input_path: str | Path | None, out: Path, config: GenerateConfig) -> Path:
    """The run's input: the given path, or for a text prompt the image it is drawn into."""
    if config.prompt is None:
        if input_path is None:
            raise UsageError("give an input (a scene file or folder, or a photograph), or a text prompt")
        return Path(input_path)
    if input_path is not None and Path(input_path).resolve() != (out / PROMPT_IMAGE).resolve():
        raise UsageError("give an input or a text prompt, not both")
    if not config.prompt.strip():
        raise UsageError("the text prompt is empty")
    return out / PROMPT_IMAGE


def _previous_input(out: Path) -> str | None:
    for candidate in (out / REPORT_FILE, out / ".checkpoint" / _RUN_FILE):
        try:
            value = json.loads(candidate.read_text(encoding="utf-8")).get("input")
        except (OSError, ValueError, AttributeError):
            continue
        if isinstance(value, str):
            return value
    return None


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    """Write atomically (a temporary file renamed over the target), readable by everyone (0644)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(payload, indent=2, sort_keys=True), encoding="utf-8")
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def _save_checkpoint(run: PipelineRun) -> None:
    folder = run.checkpoint_dir
    folder.mkdir(parents=True, exist_ok=True)
    if run.scene is not None:
        tmp = folder / ".scene.json.tmp"
        tmp.write_text(run.scene.to_json(), encoding="utf-8")
        os.replace(tmp, folder / "scene.json")
    _write_json(
        folder / _RUN_FILE,
        {
            "input": str(run.input_path),
            "config": _config_record(run.config),
            "records": [asdict(r) for r in run.records if r.status in ("done", "skipped", "reused")],
            "validation": run.validation,
            "metrics": run.metrics,
            "variants_written": run.variants_written,
            "warnings": run.warnings,
            "fallbacks": [{"agent": f.agent, "reason": f.reason} for f in run.fallbacks],
        },
    )


def _load_checkpoint(run: PipelineRun) -> set[str]:
    """Restore a stopped run's state; returns the names of the stages it finished."""
    from scenemosaic.agents import FallbackRecord

    folder = run.checkpoint_dir
    try:
        data = json.loads((folder / _RUN_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    if Path(data.get("input", "")).resolve() != run.input_path.resolve():
        raise UsageError(f"{run.out_dir} holds a run of {data.get('input')}, not of {run.input_path}; cannot resume")
    changed = [k for k, v in _config_record(run.config).items() if k in _CONFIG_KEYS and data["config"].get(k) != v]
    if changed:
        raise UsageError(f"cannot resume {run.out_dir}: settings differ from the stopped run ({', '.join(changed)})")
    done = [StageRecord(**r) for r in data.get("records", [])]
    if (folder / "scene.json").is_file():
        run.scene = Scene.model_validate_json((folder / "scene.json").read_text(encoding="utf-8"))
    run.validation = data.get("validation")
    run.metrics = data.get("metrics")
    run.variants_written = int(data.get("variants_written", 0))
    run.warnings = list(data.get("warnings", []))
    run.fallbacks = [FallbackRecord(**f) for f in data.get("fallbacks", [])]
    run.records = done
    return {r.name for r in done}


# -- the report -----------------------------------------------------------------------------------


def _status(run: PipelineRun, failure: BaseException | None) -> str:
    if isinstance(failure, asyncio.CancelledError):
        return "interrupted"
    if failure is not None:
        return "failed"
    return "degraded" if run.warnings else "ok"


def _report(run: PipelineRun, total_s: float, failure: BaseException | None) -> dict[str, Any]:
    scene = run.scene
    status = _status(run, failure)
    error: str | None = None
    trace: str | None = None
    if status == "interrupted":
        error = "interrupted: the run was stopped (signal or cancel); resume it with --resume"
    elif failure is not None:
        error = f"{type(failure).__name__}: {failure}"
        from scenemosaic.exceptions import SceneMosaicError

        if not isinstance(failure, SceneMosaicError):  # a bug, not bad input: keep everything for the issue
            trace = "".join(traceback.format_exception(failure))
    failed_stage = next((r.name for r in run.records if r.status in ("failed", "interrupted")), None)
    return {
        "input": str(run.input_path),
        "config": _config_record(run.config) | {"variants_requested": run.config.variants},
        "status": status,
        "error": error,
        "failed_stage": failed_stage,
        "traceback": trace,
        "warnings": list(run.warnings),
        "total_seconds": round(total_s, 4),
        "objects": len(scene.objects) if scene else 0,
        "categories": sorted({o.category for o in scene.objects}) if scene else [],
        "variants_written": run.variants_written,
        "stages": [
            {"name": r.name, "seconds": round(r.seconds, 4), "status": r.status, "objects": r.objects, "detail": r.detail}
            for r in run.records
        ],
        "validation": run.validation,
        "metrics": run.metrics,
    }


# -- the driver -----------------------------------------------------------------------------------


def _check_config(config: GenerateConfig) -> None:
    if config.variants < 0:
        raise UsageError("variants must be >= 0")
    if config.evolve_rounds < 1:
        raise UsageError(f"evolve_rounds must be >= 1, got {config.evolve_rounds}")
    if config.variants > 0 and not config.evolve:
        raise UsageError("variants come from the evolve stage: drop --no-evolve, or ask for --variants 0")
    for name in ("request_timeout_s", "deadline_s"):
        value = getattr(config, name)
        if value is not None and not value > 0:
            raise UsageError(f"{name} must be a positive number of seconds, got {value}")


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

    Raises the failing stage's error after writing ``report.json`` (and ``base/`` from the
    last good scene when there is one), so partial results are kept. Cancelling the task stops
    the run at once: ``report.json`` (status ``interrupted``) and ``base/scene.json`` are written
    before the cancel propagates. With ``config.resume`` a stopped run continues from its
    checkpoints. A finished run's report says ``ok`` or ``degraded`` (see ``warnings``).
    """
    config = config or GenerateConfig()
    _check_config(config)
    out = Path(out_dir)
    input_path = _input_of(input_path, out, config)
    base_dir = await asyncio.to_thread(_prepare_folders, input_path, out, config)
    if is_image_input(input_path, config.format):  # a photograph's meshes are written beside what perception saw
        from scenemosaic.perception import PERCEPTION_FOLDER

        base_dir = out / PERCEPTION_FOLDER
    run = PipelineRun(input_path=input_path, out_dir=out, config=config, base_dir=base_dir)
    finished = await asyncio.to_thread(_load_checkpoint, run) if config.resume else set()
    if not config.resume:  # resumable from the first moment, even if stopped during the import
        await asyncio.to_thread(_save_checkpoint, run)
    failure: BaseException | None = None
    started = time.perf_counter()
    for stage in STAGES:
        name = stage.name
        if name in finished and name != "export":
            for rec in run.records:
                if rec.name == name and rec.status == "done":
                    rec.status = "reused"
            if on_stage:
                on_stage(name, "reused")
            continue
        rec = StageRecord(name=name)
        run.records.append(rec)
        if on_stage:
            on_stage(name, "started")
        t0 = time.perf_counter()
        bound = log.bind(stage=name)
        bound.info("stage_started")
        try:
            await stage.run(run, rec)
        except (Exception, asyncio.CancelledError) as exc:
            rec.seconds = time.perf_counter() - t0
            interrupted = isinstance(exc, asyncio.CancelledError)
            rec.status = "interrupted" if interrupted else "failed"
            rec.detail["error"] = "interrupted" if interrupted else f"{type(exc).__name__}: {exc}"
            bound.error("stage_failed", error=str(exc) or type(exc).__name__, error_type=type(exc).__name__)
            if on_stage:
                on_stage(name, "failed")
            failure = exc
            break
        rec.seconds = time.perf_counter() - t0
        if rec.status == "pending":
            rec.status = "done"
        rec.objects = len(run.scene.objects) if run.scene is not None else None
        bound.info("stage_finished", seconds=round(rec.seconds, 3), objects=rec.objects)
        await asyncio.to_thread(_save_checkpoint, run)
        if on_stage:
            on_stage(name, "done")

    if failure is not None:
        await _keep_partial_results(run, failure, time.perf_counter() - started)
        raise failure
    report = _report(run, time.perf_counter() - started, None)
    await asyncio.to_thread(_write_json, out / REPORT_FILE, report)
    if report["status"] == "degraded":
        log.warning("run_degraded", warnings=run.warnings)
    assert run.scene is not None
    return GenerateResult(scene=run.scene, out_dir=out, report=report)


async def _keep_partial_results(run: PipelineRun, failure: BaseException, elapsed: float) -> None:
    """Report first, then the last good scene; shielded, so a second cancel cannot lose the report."""

    async def keep() -> None:
        report = _report(run, elapsed, failure)
        await asyncio.to_thread(_write_json, run.out_dir / REPORT_FILE, report)
        if run.scene is None or (run.out_dir / "base" / "scene.json").exists():
            return
        quick = isinstance(failure, asyncio.CancelledError)  # stopping: no hull or render work now
        try:
            files = await asyncio.to_thread(
                export_scene_only if quick else export_base, run.scene, run.out_dir / "base", run.base_dir
            )
        except Exception as exc:  # the original failure matters more; note this one
            log.warning("partial_export_failed", error=str(exc))
            report["partial_export_error"] = f"{type(exc).__name__}: {exc}"
        else:
            report["partial_files"] = files
        await asyncio.to_thread(_write_json, run.out_dir / REPORT_FILE, report)

    task = asyncio.ensure_future(keep())
    try:
        await asyncio.shield(task)
    except asyncio.CancelledError:
        if not task.done():  # a second cancel: the report is written first thing; let the export finish
            await asyncio.wait([task])


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
    """A rich progress bar over the pipeline's stages; yields the ``on_stage`` callback that
    advances it (and calls ``then`` too)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn()) as bar:
        task = bar.add_task("generate", total=len(STAGES))

        def callback(name: str, status: str) -> None:
            if status == "started":
                bar.update(task, description=f"generate: {name}")
            elif status in ("done", "reused", "failed"):
                bar.advance(task)
            if then is not None:
                then(name, status)

        yield callback


def run_sync(coro: Coroutine[Any, Any, T]) -> T:
    """Run ``coro`` to completion from synchronous code, with or without a running loop here."""
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return asyncio.run(coro)
    with concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="scenemosaic-sync") as pool:
        return pool.submit(asyncio.run, coro).result()

"""The ``generate`` pipeline: import → assets → structure → stabilize → validate → export.

Later stages (evolve, compose) slot in between *stabilize* and *export*; every stage is a
small function over a :class:`PipelineRun` so a new one is one more entry in ``_STAGES``.
A failing stage never loses earlier work: the last good scene is exported to ``base/`` and
``report.json`` records which stage failed and why.
"""

from __future__ import annotations

import asyncio
import functools
import json
import time
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from scenemosaic.exceptions import UsageError
from scenemosaic.models import Model
from scenemosaic.scene import Scene

if TYPE_CHECKING:
    from scenemosaic.agents import TaskAgent
    from scenemosaic.assets import HullCache
    from scenemosaic.models import UsageTracker

__all__ = [
    "STAGES",
    "STAGE_NAMES",
    "GenerateConfig",
    "GenerateResult",
    "PipelineRun",
    "Stage",
    "StageRecord",
    "agenerate",
    "export_base",
    "generate",
]

log = structlog.get_logger(__name__)

StageCallback = Callable[[str, str], None]
"""Called as ``callback(stage_name, status)`` with status ``"started"``, ``"done"`` or ``"failed"``."""


@dataclass(frozen=True)
class GenerateConfig:
    """Settings of one ``generate`` run."""

    format: str = "auto"
    """Input format (``auto``, ``native``, ``front3d``, ``procthor``, ``sam3d``)."""
    variants: int = 0
    """Number of diverse variants to deliver. Only 0 (the base scene) until the evolution and
    composition stages arrive; any other value is refused before work starts, never ignored."""
    model: str | Model = "rules"
    """Model string (``rules``, ``openai:<model>[@<base_url>]``, ``replay:<cassette.json>``) or a
    :class:`~scenemosaic.models.Model` instance, which the caller keeps ownership of (not closed here)."""
    seed: int = 0
    """Run seed; every random choice derives from it, so equal inputs give identical files."""
    room: str | None = None
    """Room id to take from a multi-room house file."""
    asset_dir: Path | None = None
    """Folder of asset meshes a SceneEval input names by ``assetId`` (default: ``assets/`` beside it)."""
    vision: bool | None = None
    """Force the model's vision setting (``False`` for text-only local servers); ``None`` keeps its default."""
    solver_fallback: bool = True
    """When a real model's answers stay unusable (after retries and repairs), use the agent's rule
    solver and note it in the report, instead of failing the run. Configuration errors still fail."""
    stabilize: bool = True
    """Run the physics stabilization stage."""
    cache_dir: Path | None = None
    """Hull cache folder; default ``$SCENEMOSAIC_CACHE`` or ``~/.cache/scenemosaic``."""
    priors_dir: Path | None = None
    """ProcTHOR priors folder (receptacles, placement annotations, asset groups) replacing the
    priors shipped with the package."""
    agents: Sequence[TaskAgent[Any, Any]] | None = None
    """Structuring agents the manager may schedule; default
    :data:`~scenemosaic.structure.DEFAULT_AGENTS`. Add a plugin with
    ``agents=[*DEFAULT_AGENTS, MyAgent()]``."""


@dataclass
class StageRecord:
    """Timing and outcome of one pipeline stage, as written to ``report.json``."""

    name: str
    seconds: float = 0.0
    status: str = "pending"
    objects: int | None = None
    detail: dict[str, Any] = field(default_factory=dict)


@dataclass
class GenerateResult:
    """What ``generate`` produced: the final base scene, the output folder and the report."""

    scene: Scene
    out_dir: Path
    report: dict[str, Any]

    @property
    def base_dir(self) -> Path:
        return self.out_dir / "base"


@dataclass
class PipelineRun:
    """Mutable state threaded through the stages."""

    input_path: Path
    out_dir: Path
    config: GenerateConfig
    base_dir: Path
    scene: Scene | None = None
    records: list[StageRecord] = field(default_factory=list)
    hull_cache: HullCache | None = None
    """The run's CoACD hull cache, opened by the assets stage and reused by physics."""
    validation: dict[str, Any] | None = None
    """The validate stage's full report (JSON-ready), written to ``report.json``."""


# -- stages --------------------------------------------------------------------------------------


async def _stage_import(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.exchange import load_scene

    scene = await asyncio.to_thread(
        functools.partial(
            load_scene, run.input_path, run.config.format, room=run.config.room, asset_dir=run.config.asset_dir
        )
    )
    run.scene = scene
    rec.detail["source_format"] = scene.provenance.source_format


async def _stage_assets(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.assets import HullCache, object_hulls

    assert run.scene is not None
    cache = HullCache(run.config.cache_dir / "hulls" if run.config.cache_dir else None)
    run.hull_cache = cache
    scene = run.scene

    def prepare() -> dict[str, int]:
        counts: dict[str, int] = {}
        for obj in scene.objects:
            counts[obj.asset.kind] = counts.get(obj.asset.kind, 0) + 1
            if obj.asset.kind == "mesh":  # warm the CoACD cache once, before physics needs it
                object_hulls(obj, run.base_dir, cache=cache)
        return counts

    rec.detail["asset_kinds"] = await asyncio.to_thread(prepare)


async def _stage_structure(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.agents import AgentPolicy, FallbackRecord
    from scenemosaic.models import InstrumentedModel, UsageTracker, parse_model
    from scenemosaic.structure import structure_scene

    assert run.scene is not None
    spec = run.config.model
    model = parse_model(spec, vision=run.config.vision) if isinstance(spec, str) else spec
    rec.detail["model"] = model.name
    tracker = UsageTracker()
    asking: Model = InstrumentedModel(model, on_call=tracker.on_call)
    fallbacks: list[FallbackRecord] = []
    try:
        run.scene = await structure_scene(
            run.scene,
            asking,
            agents=run.config.agents,
            policy=AgentPolicy(solver_fallback=run.config.solver_fallback),
            seed=run.config.seed,
            priors_dir=run.config.priors_dir,
            base_dir=run.base_dir,
            fallbacks=fallbacks,
        )
    finally:
        if not model.uses_rule_solvers:
            rec.detail["solver_fallbacks"] = [{"agent": f.agent, "reason": f.reason} for f in fallbacks]
        rec.detail["usage"] = _usage_summary(tracker)
        if isinstance(spec, str):
            await model.aclose()
    structure = run.scene.structure
    rec.detail["units"] = len(structure.units) if structure else 0
    rec.detail["relations"] = len(run.scene.relations)
    rec.detail["constraints"] = len(run.scene.constraints)


def _usage_summary(tracker: UsageTracker) -> dict[str, Any]:
    """Requests, tokens and latencies of the model calls, per run and per agent."""
    latencies = sorted(c.latency_s for c in tracker.calls)
    return {
        "requests": tracker.total.requests,
        "input_tokens": tracker.total.input_tokens,
        "output_tokens": tracker.total.output_tokens,
        "image_tokens": tracker.total.image_tokens,
        "failed_calls": sum(1 for c in tracker.calls if not c.ok),
        "latency_s": {
            "mean": round(sum(latencies) / len(latencies), 4) if latencies else 0.0,
            "max": round(latencies[-1], 4) if latencies else 0.0,
        },
        "by_agent": {
            agent: {"requests": u.requests, "input_tokens": u.input_tokens, "output_tokens": u.output_tokens}
            for agent, u in sorted(tracker.by_agent.items())
        },
    }


async def _stage_stabilize(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.physics import stabilize_scene

    assert run.scene is not None
    if not run.config.stabilize:
        rec.status = "skipped"
        return
    scene, report = await stabilize_scene(
        run.scene, base_dir=run.base_dir, seed=run.config.seed, hull_cache=run.hull_cache
    )
    run.scene = scene
    rec.detail.update(report.model_dump(mode="json", include=_summary_fields(report)))


async def _stage_validate(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.physics import validate_scene

    assert run.scene is not None
    scene = run.scene
    report = await asyncio.to_thread(validate_scene, scene, run.base_dir)
    rec.detail.update(report.model_dump(mode="json", include=_summary_fields(report)))
    run.validation = report.model_dump(mode="json")


def _summary_fields(report: Any) -> set[str]:
    """The scalar fields of a report model (counts, booleans, timings) for report.json's stage table."""
    return {
        name
        for name, value in report
        if isinstance(value, int | float | bool | str) or (isinstance(value, list) and len(value) <= 20)
    }


async def _stage_export(run: PipelineRun, rec: StageRecord) -> None:
    assert run.scene is not None
    rec.detail["files"] = await asyncio.to_thread(export_base, run.scene, run.out_dir / "base", run.base_dir)


DELIVERED_FORMATS: tuple[tuple[str, str], ...] = (("glb", "scene.glb"), ("sceneeval", "sceneeval"), ("mjcf", ""))
"""Formats written beside ``scene.json`` in every delivered folder, with their destination in it."""


def export_base(scene: Scene, folder: Path, base_dir: Path | None) -> list[str]:
    """Write one scene in the stable output layout; returns the files written (relative to ``folder``)."""
    from scenemosaic.exchange import export_glb, export_mjcf, export_sceneeval, save_scene
    from scenemosaic.render import render_topdown

    folder.mkdir(parents=True, exist_ok=True)
    save_scene(scene, folder, base_dir=base_dir)
    # later exports read mesh assets from the saved folder, whose uris save_scene rewrote
    from scenemosaic.exchange import read_scene

    saved = read_scene(folder)
    export_glb(saved, folder / "scene.glb", base_dir=folder)
    (folder / "topdown.png").write_bytes(render_topdown(saved, base_dir=folder))
    export_sceneeval(saved, folder / "sceneeval", base_dir=folder)
    export_mjcf(saved, folder, base_dir=folder)
    return [*sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file() and p.parent == folder), "sceneeval/", "mjcf/"]


StageFn = Callable[[PipelineRun, StageRecord], Awaitable[None]]
"""A stage's body: reads and updates the run, records its figures in the stage record."""


@dataclass(frozen=True)
class Stage:
    """One named step of the pipeline."""

    name: str
    run: StageFn


STAGES: tuple[Stage, ...] = (
    Stage("import", _stage_import),
    Stage("assets", _stage_assets),
    Stage("structure", _stage_structure),
    Stage("stabilize", _stage_stabilize),
    Stage("validate", _stage_validate),
    Stage("export", _stage_export),
)
"""The stages ``generate`` runs, in order (``evolve`` and ``compose`` slot in before ``export``)."""

STAGE_NAMES: tuple[str, ...] = tuple(stage.name for stage in STAGES)
"""The names of :data:`STAGES`, in order."""


# -- driver --------------------------------------------------------------------------------------


def _prepare_folders(input_path: Path, out: Path) -> Path:
    """Check the input exists, create the output folder; returns the folder relative asset paths start from."""
    if not input_path.exists():
        raise UsageError(f"input not found: {input_path}")
    out.mkdir(parents=True, exist_ok=True)
    return input_path if input_path.is_dir() else input_path.parent


def _export_partial(scene: Scene, folder: Path, base_dir: Path) -> None:
    if not (folder / "scene.json").exists():  # a failed export stage may already have written it
        export_base(scene, folder, base_dir)


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    path.write_text(json.dumps(payload, indent=2, sort_keys=True), encoding="utf-8")


async def agenerate(
    input_path: str | Path,
    out_dir: str | Path,
    config: GenerateConfig | None = None,
    *,
    on_stage: StageCallback | None = None,
) -> GenerateResult:
    """Run the pipeline on ``input_path`` and write the output layout under ``out_dir``.

    Raises the failing stage's error after writing ``report.json`` (and ``base/`` from the
    last good scene when there is one), so partial results are kept.
    """
    config = config or GenerateConfig()
    if config.variants < 0:
        raise UsageError("variants must be >= 0")
    if config.variants > 0:
        raise UsageError(
            f"variants={config.variants} asked for, but variants arrive with the evolution stage, which this "
            "version does not have yet; run with variants=0 (--variants 0) for the base scene"
        )
    input_path, out = Path(input_path), Path(out_dir)
    base_dir = await asyncio.to_thread(_prepare_folders, input_path, out)
    run = PipelineRun(input_path=input_path, out_dir=out, config=config, base_dir=base_dir)
    failure: BaseException | None = None
    started = time.perf_counter()
    for stage in STAGES:
        name = stage.name
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
            rec.status = "failed"
            rec.detail["error"] = f"{type(exc).__name__}: {exc}"
            bound.error("stage_failed", error=str(exc), error_type=type(exc).__name__)
            if on_stage:
                on_stage(name, "failed")
            failure = exc
            break
        rec.seconds = time.perf_counter() - t0
        if rec.status == "pending":
            rec.status = "done"
        rec.objects = len(run.scene.objects) if run.scene is not None else None
        bound.info("stage_finished", seconds=round(rec.seconds, 3), objects=rec.objects)
        if on_stage:
            on_stage(name, "done")

    if failure is not None and run.scene is not None:
        try:  # keep the partial result: the last good scene in the stable layout
            await asyncio.to_thread(_export_partial, run.scene, out / "base", run.base_dir)
        except Exception as exc:  # the original failure matters more; note this one
            log.warning("partial_export_failed", error=str(exc))

    report = _report(run, time.perf_counter() - started, failure)
    await asyncio.to_thread(_write_json, out / "report.json", report)
    if failure is not None:
        raise failure
    assert run.scene is not None
    return GenerateResult(scene=run.scene, out_dir=out, report=report)


def _report(run: PipelineRun, total_s: float, failure: BaseException | None) -> dict[str, Any]:
    scene = run.scene
    return {
        "input": str(run.input_path),
        "config": {
            "format": run.config.format,
            "model": run.config.model if isinstance(run.config.model, str) else run.config.model.name,
            "seed": run.config.seed,
            "variants_requested": run.config.variants,
            "room": run.config.room,
        },
        "status": "failed" if failure else "ok",
        "error": f"{type(failure).__name__}: {failure}" if failure else None,
        "total_seconds": round(total_s, 4),
        "objects": len(scene.objects) if scene else 0,
        "categories": sorted({o.category for o in scene.objects}) if scene else [],
        "variants_written": 0,
        "stages": [
            {
                "name": r.name,
                "seconds": round(r.seconds, 4),
                "status": r.status,
                "objects": r.objects,
                "detail": r.detail,
            }
            for r in run.records
        ],
        "validation": run.validation,
    }


def generate(
    input_path: str | Path,
    out_dir: str | Path,
    config: GenerateConfig | None = None,
    *,
    on_stage: StageCallback | None = None,
) -> GenerateResult:
    """Synchronous :func:`agenerate` for scripts and notebooks without a running loop."""
    return asyncio.run(agenerate(input_path, out_dir, config, on_stage=on_stage))

"""The stages of ``generate``, in order: import → assets → structure → stabilize → evolve → compose → validate → evaluate → export.

Each stage is a small async function over a :class:`~scenemosaic.pipeline.PipelineRun`; CPU work
runs in worker threads so the event loop stays free to notice a cancel.
"""

from __future__ import annotations

import asyncio
import functools
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from scenemosaic.pipeline._config import PipelineRun, Stage, StageRecord
from scenemosaic.scene import WALK_MIN_SHARE, Scene

if TYPE_CHECKING:
    from scenemosaic.agents import AgentOutcome
    from scenemosaic.assets import HullCache
    from scenemosaic.models import Model, ModelSettings, UsageTracker

log = structlog.get_logger(__name__)

__all__ = [
    "DELIVERED_FORMATS",
    "EVOLVE_FOLDER",
    "PROMPT_IMAGE",
    "STAGES",
    "STAGE_NAMES",
    "export_base",
    "export_scene_only",
    "is_image_input",
]

NAV_SLACK = 0.005
"""A variant's NAV must reach ``scene.WALK_MIN_SHARE`` (0.99); where the base scene's own NAV is
lower (a room whose furniture cuts the floor and the critic found no clean move that reopens
it), the base's NAV less this much (one raster cell's worth of noise)."""

PROMPT_IMAGE = "prompt.png"
"""The image a text prompt is drawn into, in the output folder (``prompt.json`` beside it says from what)."""

EVOLVE_FOLDER = "evolve"
"""Where ``generate`` writes each unit's evolved layouts (and, with ``save_views``, their views)."""

DELIVERED_FORMATS: tuple[tuple[str, str], ...] = (
    ("glb", "scene.glb"),
    ("sceneeval", "sceneeval"),
    ("mjcf", ""),
    ("urdf", ""),
    ("usd", ""),
)
"""Formats written beside ``scene.json`` in every delivered folder, with their destination in it;
plus ``procthor`` (``house.json``) for a room taken from an AI2-THOR / ProcTHOR house."""
OPTIONAL_FORMATS: dict[str, str] = {"usd": "pip install 'scenemosaic[usd]'"}
"""Delivered formats that need an extra: without it they are left out, and the export stage's
report says so with the command that installs it."""


def hull_cache(run: PipelineRun) -> HullCache:
    """The run's hull cache, opened on first use (a resumed run skips the assets stage)."""
    from scenemosaic.assets import HullCache

    if run.hull_cache is None:
        run.hull_cache = HullCache(run.config.cache_dir / "hulls" if run.config.cache_dir else None)
    return run.hull_cache


def is_image_input(run_input: Path, format: str) -> bool:
    """Whether a run's input is a photograph for the image front end (``format`` ``image``, or
    ``auto`` and an image suffix)."""
    from scenemosaic.perception import is_image_path

    return format == "image" or (format == "auto" and is_image_path(run_input))


async def _perceive(run: PipelineRun, rec: StageRecord) -> None:
    """The import stage of a photograph: perception (inventory, masks, 3D, world frame)."""
    from scenemosaic.agents import AgentPolicy
    from scenemosaic.models import UsageTracker
    from scenemosaic.perception import perceive

    cfg = run.config
    model, owned = await _open_model(run, rec)
    tracker = UsageTracker()
    asking = _asking_model(run, model, tracker)
    try:
        if cfg.prompt is not None:
            await _draw_prompt(run, rec, asking)
        result = await perceive(
            run.input_path,
            asking,
            detections=cfg.detections,
            segmenter=cfg.segmenter,
            reconstructor=cfg.reconstructor,
            hfov_deg=cfg.hfov_deg,
            out_dir=run.out_dir,
            policy=AgentPolicy(solver_fallback=cfg.solver_fallback),
            settings=_request_settings(run),
            seed=cfg.seed,
        )
    finally:
        rec.detail["usage"] = _usage_summary(tracker)
        if owned:
            await model.aclose()
    run.scene = result.scene
    rec.detail["source_format"] = "image"
    rec.detail["perception"] = result.report
    run.fallbacks.extend(result.fallbacks)
    for f in result.fallbacks:
        run.warnings.append(f"agent {f.agent!r} answered by its rule solver: {f.reason[:160]}")
    if result.report.get("segmenter") == "box" and cfg.segmenter == "auto":
        from scenemosaic.perception import PERCEPTION_INSTALL

        run.warnings.append(f"no segmenter installed: the objects' boxes stood in for their masks ({PERCEPTION_INSTALL})")


async def _draw_prompt(run: PipelineRun, rec: StageRecord, model: Model) -> None:
    """Draw the text prompt into ``OUT/prompt.png`` (kept, with ``prompt.json``, so a re-run or a
    resumed run of the same prompt does not pay for it again)."""
    import json

    from scenemosaic.scene import write_atomic

    cfg = run.config
    assert cfg.prompt is not None
    wanted = {"prompt": cfg.prompt, "size": cfg.image_size, "image_model": cfg.image_model, "model": model.name}
    record = run.input_path.with_suffix(".json")
    try:
        drawn = json.loads(record.read_text(encoding="utf-8")) == wanted and run.input_path.is_file()
    except (OSError, ValueError):
        drawn = False
    rec.detail["prompt"] = {**wanted, "reused": drawn}
    if drawn:
        return
    png, usage = await model.generate_image(cfg.prompt, size=cfg.image_size, model=cfg.image_model)
    await asyncio.to_thread(write_atomic, run.input_path, png)
    await asyncio.to_thread(write_atomic, record, json.dumps(wanted, indent=2) + "\n")
    rec.detail["prompt"]["requests"] = usage.requests


async def _stage_import(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.exchange import load_scene

    if is_image_input(run.input_path, run.config.format):
        await _perceive(run, rec)
        return
    scene = await asyncio.to_thread(
        functools.partial(
            load_scene, run.input_path, run.config.format, room=run.config.room, asset_dir=run.config.asset_dir
        )
    )
    run.scene = scene
    rec.detail["source_format"] = scene.provenance.source_format


async def _stage_assets(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.assets import object_hulls

    assert run.scene is not None
    cache = hull_cache(run)
    scene = run.scene

    def prepare() -> dict[str, int]:
        counts: dict[str, int] = {}
        for obj in scene.objects:
            counts[obj.asset.kind] = counts.get(obj.asset.kind, 0) + 1
            if obj.asset.kind == "mesh":  # warm the CoACD cache once, before physics needs it
                object_hulls(obj, run.base_dir, cache=cache)
        return counts

    rec.detail["asset_kinds"] = await asyncio.to_thread(prepare)


def _asking_model(run: PipelineRun, model: Model, tracker: UsageTracker) -> Model:
    """The model the agents ask: instrumented for usage, bounded by the run's time limits."""
    from scenemosaic.models import InstrumentedModel

    asking: Model = InstrumentedModel(model, on_call=tracker.on_call)
    if model.uses_rule_solvers:
        return asking
    from scenemosaic.models import CircuitBreakerModel, DeadlineModel

    asking = CircuitBreakerModel(asking)
    if run.config.deadline_s is not None:  # the whole run's budget: what the earlier stages used is gone
        left = run.config.deadline_s - (time.monotonic() - run.started)
        asking = DeadlineModel(asking, max(left, 0.001))
    return asking


async def _open_model(run: PipelineRun, rec: StageRecord) -> tuple[Model, bool]:
    """The run's model and whether this stage owns it (a model string: opened here, closed by
    the caller); the slot count of a llama.cpp server bounds the concurrency."""
    from scenemosaic.models import parse_model

    spec = run.config.model
    if not isinstance(spec, str):
        rec.detail["model"] = spec.name
        return _wrap_model(run, spec, rec), False
    limit = run.config.max_concurrency or await _server_slots(spec, run.config.vision)
    model = parse_model(spec, vision=run.config.vision, **({"max_concurrency": limit} if limit else {}))
    if limit:
        rec.detail["max_concurrency"] = limit
    rec.detail["model"] = model.name
    return _wrap_model(run, model, rec), True


def _wrap_model(run: PipelineRun, model: Model, rec: StageRecord) -> Model:
    """``model`` behind the run's rate limits and then its reply cache (a cached answer waits for
    no budget), when the run has them and the model asks anything."""
    from scenemosaic.models import CachedModel, LimitedModel, RateLimiter

    if model.uses_rule_solvers:
        return model
    cfg = run.config
    if cfg.requests_per_minute or cfg.tokens_per_minute:
        limiter = RateLimiter(
            requests_per_minute=cfg.requests_per_minute,
            tokens_per_minute=cfg.tokens_per_minute,
            shared_dir=cfg.rate_limit_dir,
            key=model.name,
        )
        model = LimitedModel(model, limiter)
        rec.detail["rate_limits"] = {
            "requests_per_minute": cfg.requests_per_minute,
            "tokens_per_minute": cfg.tokens_per_minute,
            "shared": str(cfg.rate_limit_dir) if cfg.rate_limit_dir else None,
        }
    if cfg.reply_cache is None:
        return model
    rec.detail["reply_cache"] = str(cfg.reply_cache)
    return CachedModel(model, cfg.reply_cache)


def _request_settings(run: PipelineRun) -> ModelSettings | None:
    from scenemosaic.models import ModelSettings

    return ModelSettings(timeout_s=run.config.request_timeout_s) if run.config.request_timeout_s else None


async def _stage_structure(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.agents import AgentPolicy
    from scenemosaic.dag import FileRunStore
    from scenemosaic.models import UsageTracker
    from scenemosaic.structure import structure_scene

    assert run.scene is not None
    notes_before = len(run.scene.provenance.notes)
    model, owned = await _open_model(run, rec)
    tracker = UsageTracker()
    asking = _asking_model(run, model, tracker)
    settings = _request_settings(run)
    # finished agents are kept on disk, so a stopped run resumed later does not ask them again
    store = FileRunStore(run.checkpoint_dir / "agents")
    fallbacks = run.fallbacks
    outcomes: dict[str, AgentOutcome] = {}
    try:
        run.scene = await structure_scene(
            run.scene,
            asking,
            agents=run.config.agents,
            settings=settings,
            policy=AgentPolicy(solver_fallback=run.config.solver_fallback),
            store=store,
            seed=run.config.seed,
            priors_dir=run.config.priors_dir,
            base_dir=run.base_dir,
            fallbacks=fallbacks,
            outcomes=outcomes,
        )
    finally:
        if not model.uses_rule_solvers:
            rec.detail["solver_fallbacks"] = [{"agent": f.agent, "reason": f.reason} for f in fallbacks]
        rec.detail["usage"] = _usage_summary(tracker)
        rec.detail["agents"] = _agent_breakdown(outcomes, tracker)
        if owned:
            await model.aclose()
    for f in fallbacks:
        run.warnings.append(f"agent {f.agent!r} answered by its rule solver: {f.reason[:160]}")
    # what the agents changed to make the input consistent (objects pulled inside walls...)
    rec.detail["repairs"] = run.scene.provenance.notes[notes_before:]
    structure = run.scene.structure
    rec.detail["units"] = len(structure.units) if structure else 0
    rec.detail["relations"] = len(run.scene.relations)
    rec.detail["constraints"] = len(run.scene.constraints)


async def _server_slots(spec: str, vision: bool | None) -> int | None:
    """The slot count an OpenAI-compatible server behind ``spec`` reports, if it reports one."""
    from scenemosaic.models import OpenAIChatModel, parse_model

    if spec == "rules" or spec.startswith("replay:"):
        return None
    probe = parse_model(spec, vision=vision)
    inner: Any = probe
    while not isinstance(inner, OpenAIChatModel) and getattr(inner, "wrapped", None) is not None:
        inner = inner.wrapped
    try:
        return await inner.server_slots() if isinstance(inner, OpenAIChatModel) else None
    finally:
        await probe.aclose()


def _agent_breakdown(outcomes: dict[str, AgentOutcome], tracker: UsageTracker) -> dict[str, Any]:
    """Per agent: how it was answered, model requests, repairs, tokens (``report.json``)."""
    out: dict[str, Any] = {}
    for name in sorted(set(outcomes) | set(tracker.by_agent)):
        o = outcomes.get(name)
        u = tracker.by_agent.get(name)
        out[name] = {
            "answered_by": o.answered_by if o else "resumed",
            "requests": o.requests if o else 0,
            "repairs": o.repairs if o else 0,
            "valid_first_time": bool(o and o.answered_by == "model" and o.repairs == 0),
            "input_tokens": u.input_tokens if u else 0,
            "output_tokens": u.output_tokens if u else 0,
            **({"fallback_reason": o.reason} if o and o.reason else {}),
        }
    return out


def _usage_summary(tracker: UsageTracker) -> dict[str, Any]:
    """Requests, tokens and latencies of the model calls, per run and per agent."""
    latencies = sorted(c.latency_s for c in tracker.calls)
    return {
        "requests": tracker.total.requests,
        "cached": tracker.total.cached,
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
        run.scene, base_dir=run.base_dir, seed=run.config.seed, hull_cache=hull_cache(run)
    )
    run.scene = scene
    rec.detail.update(report.model_dump(mode="json", include=_summary_fields(report)))


async def _stage_evolve(run: PipelineRun, rec: StageRecord) -> None:
    """Refine every unit through the Critic-Actor loop (and grow unit variants when asked)."""
    from scenemosaic.agents import AgentPolicy
    from scenemosaic.evolve import evolve_scene
    from scenemosaic.models import UsageTracker
    from scenemosaic.physics import object_shape

    assert run.scene is not None
    if not (run.config.evolve and run.config.stabilize):  # it refines a stabilized scene
        rec.status = "skipped"
        rec.detail["reason"] = "evolve off" if not run.config.evolve else "stabilize off: nothing stabilized to refine"
        return
    scene = run.scene
    cache = hull_cache(run)
    shapes = await asyncio.to_thread(lambda: {o.id: object_shape(o, run.base_dir, cache=cache) for o in scene.objects})
    model, owned = await _open_model(run, rec)
    tracker = UsageTracker()
    asking = _asking_model(run, model, tracker)
    folder = run.out_dir / EVOLVE_FOLDER
    try:
        evolved, report = await evolve_scene(
            scene,
            asking,
            shapes,
            variants=run.config.variants,
            settings=_request_settings(run),
            policy=AgentPolicy(solver_fallback=run.config.solver_fallback),
            max_rounds=run.config.evolve_rounds,
            seed=run.config.seed,
            base_dir=run.base_dir,
            views_dir=folder if run.config.save_views else None,
            rules=run.config.layout_rules,
        )
    finally:
        rec.detail["usage"] = _usage_summary(tracker)
        if owned:
            await model.aclose()
    run.scene = evolved
    summary = report.summary()
    rec.detail.update({k: v for k, v in summary.items() if k != "per_layout"})
    rec.detail["layouts"] = summary["per_layout"]
    rec.detail["files"] = await asyncio.to_thread(_write_layouts, report, folder, run.out_dir)
    for unit in report.units:
        for lay in unit.layouts:
            run.fallbacks.extend(lay.fallbacks)
            for f in lay.fallbacks:
                run.warnings.append(f"agent {f.agent!r} ({unit.anchor_id}/{lay.layout_id}) answered by its rule solver: {f.reason[:120]}")
        o = unit.original
        if o.error:
            run.warnings.append(f"unit {unit.anchor_id}: evolution failed, kept the stabilized layout ({o.error[:160]})")
        elif o.violations:
            run.warnings.append(f"unit {unit.anchor_id}: refined layout still breaks rules: {'; '.join(o.violations[:5])}")


def _write_layouts(report: Any, folder: Path, out_dir: Path) -> list[str]:
    """``evolve/<anchor>/<layout_id>.json`` per evolved layout: the 2D state, anchor-frame poses,
    checks and the rounds of its memory. Returns the paths relative to ``out_dir``."""
    import json

    written: list[str] = []
    for unit in report.units:
        for lay in unit.layouts:
            target = folder / unit.anchor_id / f"{lay.layout_id}.json"
            target.parent.mkdir(parents=True, exist_ok=True)
            payload = {
                **lay.summary(),
                "state": lay.state.model_dump(mode="json") if lay.state else None,
                "local_poses": {k: p.model_dump(mode="json") for k, p in lay.local_poses.items()},
                "memory": [r.model_dump(mode="json") for r in lay.rounds],
                "views": [str(Path(v).relative_to(out_dir)) for v in lay.views],
            }
            payload.pop("wall_s", None)  # timings vary between runs; the files must not
            target.write_text(json.dumps(payload, indent=2, sort_keys=True), encoding="utf-8")
            written.append(str(target.relative_to(out_dir)))
    return written


async def _stage_compose(run: PipelineRun, rec: StageRecord) -> None:
    """Select ``variants`` diverse whole scenes from the unit layouts the evolve stage wrote, and
    write each as ``variant_<i>/`` in the same layout as ``base/``."""
    from scenemosaic.compose import UnitLayouts, compose_variants
    from scenemosaic.physics import check_collisions, check_out_of_bounds, object_shape
    from scenemosaic.scene import Pose

    assert run.scene is not None
    folder = run.out_dir / EVOLVE_FOLDER
    if run.config.variants <= 0 or not folder.is_dir():
        rec.status = "skipped"
        rec.detail["reason"] = "no variants asked for" if run.config.variants <= 0 else "no evolved unit layouts"
        return
    scene = run.scene

    def read_layouts() -> tuple[dict[str, UnitLayouts], list[str]]:
        import json

        kept: dict[str, UnitLayouts] = {}
        dropped: list[str] = []
        for unit_dir in sorted(p for p in folder.iterdir() if p.is_dir()):
            records = {p.stem: json.loads(p.read_text(encoding="utf-8")) for p in unit_dir.glob("*.json")}
            if "original" not in records:
                continue
            ids, poses = [], []
            for lid in ["original", *sorted(k for k in records if k != "original")]:
                r = records[lid]
                if lid != "original" and (r.get("error") or not r.get("valid") or r.get("violations")):
                    why = r.get("error") or "; ".join(r.get("violations") or []) or "not valid"
                    dropped.append(f"{unit_dir.name}/{lid}: {why[:120]}")
                    continue
                ids.append(lid)
                poses.append({k: Pose.model_validate(v) for k, v in r["local_poses"].items()})
            kept[unit_dir.name] = UnitLayouts(unit_dir.name, tuple(ids), tuple(poses))
        return kept, dropped

    layouts, dropped = await asyncio.to_thread(read_layouts)
    cache = hull_cache(run)
    shapes = await asyncio.to_thread(lambda: {o.id: object_shape(o, run.base_dir, cache=cache) for o in scene.objects})
    from scenemosaic.metrics import nav

    base_nav = await asyncio.to_thread(nav, scene)
    floor_share = WALK_MIN_SHARE if base_nav >= WALK_MIN_SHARE else base_nav - NAV_SLACK

    def walkable(candidate: Scene) -> bool:  # a variant keeps the walkable floor as connected as the base
        return nav(candidate) >= floor_share

    variants, report = await asyncio.to_thread(
        functools.partial(
            compose_variants, scene, layouts, shapes, m=run.config.variants, seed=run.config.seed, accept=walkable
        )
    )
    report.dropped = dropped + report.dropped
    rec.detail.update(report.summary())
    written = []
    for i, (variant, picked) in enumerate(zip(variants, report.picked, strict=True), start=1):
        variant.provenance.steps.append("compose")
        variant.provenance.notes.append(f"variant {i}: " + ", ".join(f"{k} {v}" for k, v in picked.items()))
        target = run.out_dir / f"variant_{i}"
        await asyncio.to_thread(export_base, variant, target, run.base_dir)
        cols = await asyncio.to_thread(functools.partial(check_collisions, variant, run.base_dir, hull_cache=cache))
        oob = await asyncio.to_thread(check_out_of_bounds, variant)
        written.append({"folder": target.name, "collision_pairs": len(cols.pairs), "out_of_bounds": len(oob.objects)})
        if cols.pairs or oob.objects:
            run.warnings.append(f"{target.name}: {len(cols.pairs)} colliding pair(s), {len(oob.objects)} object(s) out of bounds")
    rec.detail["variants"] = written
    run.variants_written = len(written)
    if len(written) < run.config.variants:  # not a fault of the scenes written: said, not degraded
        rec.detail["shortfall"] = (
            f"{run.config.variants} variants asked for, {len(written)} distinct valid ones in a pool of {report.pool_size}"
        )
        log.warning("fewer_variants_than_asked", asked=run.config.variants, written=len(written), pool=report.pool_size)


async def _stage_validate(run: PipelineRun, rec: StageRecord) -> None:
    from scenemosaic.physics import validate_scene

    assert run.scene is not None
    scene = run.scene
    report = await asyncio.to_thread(
        functools.partial(validate_scene, scene, run.base_dir, hull_cache=hull_cache(run))
    )
    rec.detail.update(report.model_dump(mode="json", include=_summary_fields(report)))
    run.validation = report.model_dump(mode="json")
    if report.collisions.pairs:
        worst = max(p.depth_m for p in report.collisions.pairs)
        run.warnings.append(f"{len(report.collisions.pairs)} colliding pair(s) left, deepest {worst:.3f} m")
    if report.out_of_bounds.objects:
        run.warnings.append(f"{len(report.out_of_bounds.objects)} object(s) out of bounds")
    if report.fell:
        run.warnings.append("object(s) fell in the validation run: " + ", ".join(report.fell[:10]))
    if report.tipped:
        run.warnings.append("object(s) tipped in the validation run: " + ", ".join(report.tipped[:10]))
    for pair in report.nested:
        run.warnings.append(f"furniture nested inside each other's boxes: {pair}")


def _summary_fields(report: Any) -> set[str]:
    """The scalar fields of a report model (counts, booleans, timings) for report.json's stage table."""
    return {
        name
        for name, value in report
        if isinstance(value, int | float | bool | str) or (isinstance(value, list) and len(value) <= 20)
    }


async def _stage_evaluate(run: PipelineRun, rec: StageRecord) -> None:
    """The field's metrics of the base scene and of every variant written, into ``report.json``."""
    from scenemosaic.exchange import read_scene
    from scenemosaic.metrics import evaluate

    assert run.scene is not None
    folders = sorted(run.out_dir.glob("variant_*"), key=lambda p: p.name)[: run.variants_written]
    variants = await asyncio.to_thread(lambda: [read_scene(f) for f in folders])
    result = await asyncio.to_thread(
        functools.partial(
            evaluate, run.scene, variants, base_dir=run.base_dir, variant_dirs=folders, hull_cache=hull_cache(run)
        )
    )
    if not (isinstance(run.config.model, str) and run.config.model == "rules"):
        result["semantic_judge"] = await _judge(run, rec, [run.scene, *variants])
    rec.detail.update(result)
    run.metrics = result


async def _judge(run: PipelineRun, rec: StageRecord, scenes: list[Scene]) -> dict[str, Any]:
    """POS and ROT of the base and each variant from the run's model (not measured without vision)."""
    from scenemosaic.metrics import judge_scene
    from scenemosaic.models import UsageTracker

    model, owned = await _open_model(run, rec)
    tracker = UsageTracker()
    asking = _asking_model(run, model, tracker)
    try:
        verdicts = [await judge_scene(s, asking, settings=_request_settings(run), base_dir=run.base_dir) for s in scenes]
    finally:
        rec.detail["usage"] = _usage_summary(tracker)
        if owned:
            await model.aclose()
    return {"base": verdicts[0], "variants": verdicts[1:]}


async def _stage_export(run: PipelineRun, rec: StageRecord) -> None:
    assert run.scene is not None
    rec.detail["files"] = await asyncio.to_thread(export_base, run.scene, run.out_dir / "base", run.base_dir)
    missing = {fmt: hint for fmt, hint in OPTIONAL_FORMATS.items() if not _format_available(fmt)}
    if missing:
        rec.detail["formats_left_out"] = missing
        log.warning("formats_left_out", formats=sorted(missing), install=sorted(missing.values()))
    if run.variants_written:
        await asyncio.to_thread(contact_sheet, run.out_dir, run.variants_written)
        rec.detail["contact_sheet"] = CONTACT_SHEET


CONTACT_SHEET = "contact_sheet.png"
"""The base scene and its variants side by side (their top-down views), in the output folder."""


def contact_sheet(out_dir: Path, variants: int, tile_px: int = 512) -> Path:
    """Write ``contact_sheet.png``: the top-down views of ``base/`` and ``variant_1..n/`` in a
    grid of up to three columns, each labelled with its folder."""
    from PIL import Image, ImageDraw, ImageFont

    names = ["base", *(f"variant_{i}" for i in range(1, variants + 1))]
    cols = min(3, len(names))
    rows = (len(names) + cols - 1) // cols
    sheet = Image.new("RGB", (cols * tile_px, rows * (tile_px + 28)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    try:
        font: ImageFont.FreeTypeFont | ImageFont.ImageFont = ImageFont.load_default(size=20)
    except (OSError, ValueError, ImportError):
        font = ImageFont.load_default()
    for i, name in enumerate(names):
        x, y = (i % cols) * tile_px, (i // cols) * (tile_px + 28)
        with Image.open(out_dir / name / "topdown.png") as view:
            sheet.paste(view.convert("RGB").resize((tile_px, tile_px)), (x, y + 28))
        draw.text((x + 8, y + 4), name, fill=(25, 25, 30), font=font)
    target = out_dir / CONTACT_SHEET
    sheet.save(target)
    return target


def export_base(scene: Scene, folder: Path, base_dir: Path | None) -> list[str]:
    """Write one scene in the stable output layout; returns the files written (relative to ``folder``).

    ``scene.json`` (+ ``assets/``) first, through the native writer; every delivered format is then
    written from that saved copy (whose mesh uris the native writer rewrote), plus a top-down PNG.
    """
    from scenemosaic.exchange import read_scene, write_scene
    from scenemosaic.render import render_topdown

    folder.mkdir(parents=True, exist_ok=True)
    write_scene(scene, "native", folder, base_dir)
    saved = read_scene(folder)
    for fmt, destination in DELIVERED_FORMATS:
        if fmt in OPTIONAL_FORMATS and not _format_available(fmt):
            continue
        write_scene(saved, fmt, folder / destination if destination else folder, folder)
    if saved.provenance.source_format == "procthor":  # back into the house it came from
        write_scene(saved, "procthor", folder, folder)
    (folder / "topdown.png").write_bytes(render_topdown(saved, base_dir=folder))
    top = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if p.is_file())
    return [*top, *sorted(f"{p.name}/" for p in folder.iterdir() if p.is_dir() and p.name != "assets")]


def _format_available(fmt: str) -> bool:
    """Whether an optional format's extra is installed (``usd``: the ``pxr`` package)."""
    import importlib.util

    return fmt != "usd" or importlib.util.find_spec("pxr") is not None


def export_scene_only(scene: Scene, folder: Path, base_dir: Path | None) -> list[str]:
    """Write only ``scene.json`` (+ its mesh assets): the fast partial result of a stopped run."""
    from scenemosaic.exchange import write_scene

    folder.mkdir(parents=True, exist_ok=True)
    write_scene(scene, "native", folder, base_dir)
    return ["scene.json"]


STAGES: tuple[Stage, ...] = (
    Stage("import", _stage_import),
    Stage("assets", _stage_assets),
    Stage("structure", _stage_structure),
    Stage("stabilize", _stage_stabilize),
    Stage("evolve", _stage_evolve),
    Stage("compose", _stage_compose),
    Stage("validate", _stage_validate),
    Stage("evaluate", _stage_evaluate),
    Stage("export", _stage_export),
)
"""The stages ``generate`` runs, in order."""

STAGE_NAMES: tuple[str, ...] = tuple(stage.name for stage in STAGES)
"""The names of :data:`STAGES`, in order."""

"""The stages of ``generate``, in order: import → assets → structure → stabilize → doors → evolve → compose → validate → evaluate → export.

Each stage is one async function over the :class:`~scenemosaic.pipeline.PipelineRun`: it reads
what the stages before it left there, leaves its own result, and records its figures. The model
stack, the output folder's paths, the delivered formats and the contact sheet live in the
packages that own them (``models``, ``exchange``, ``render``); CPU work runs in worker threads so
the event loop stays free to notice a cancel.
"""

from __future__ import annotations

import asyncio
import functools
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import structlog

from scenemosaic.agents import AgentLog
from scenemosaic.assets import object_hulls, open_scene
from scenemosaic.compose import compose_variants, kept_layouts
from scenemosaic.evolve import EvolutionReport, evolve_scene
from scenemosaic.exceptions import UsageError
from scenemosaic.exchange import deliver_scene, formats_left_out, load_scene
from scenemosaic.metrics import evaluate, judge_scene, nav, plausibility
from scenemosaic.perception import PERCEPTION_INSTALL, is_image_path, perceive
from scenemosaic.physics import (
    ValidationReport,
    check_collisions,
    check_out_of_bounds,
    clear_doors,
    rehang_screens,
    stabilize_scene,
    validate_scene,
)
from scenemosaic.pipeline._state import PipelineRun, Stage, StageRecord
from scenemosaic.render import contact_sheet
from scenemosaic.scene import (
    WALK_MIN_SHARE,
    House,
    RunFolder,
    Scene,
    cut_off_doors,
    door_blockers,
    door_zones,
    functional_holds,
    functional_relations,
    is_screen,
    on_backing_wall,
    wall_crossings,
    write_atomic,
)
from scenemosaic.structure import structure_scene

log = structlog.get_logger(__name__)

__all__ = [
    "NAV_SLACK",
    "STAGES",
    "STAGE_NAMES",
    "deliver_run",
    "floor_share",
    "is_image_input",
    "judge_scenes",
    "note_import_warnings",
    "note_shortfall",
    "validation_warnings",
]

NAV_SLACK = 0.005
"""A variant's NAV must reach ``scene.WALK_MIN_SHARE`` (0.99); where the base scene's own NAV is
lower (a room whose furniture cuts the floor and the critic found no clean move that reopens
it), the base's NAV less this much (one raster cell's worth of noise)."""


def is_image_input(run_input: Path, format: str) -> bool:
    """Whether a run's input is a photograph for the image front end (``format`` ``image``, or
    ``auto`` and an image suffix)."""
    return format == "image" or (format == "auto" and is_image_path(run_input))


# -- import, assets ---------------------------------------------------------------------------------


async def _stage_import(run: PipelineRun, rec: StageRecord) -> None:
    cfg = run.config
    if run.source is not None:  # a room of a house: the house import gave it
        run.scene = run.source
        rec.detail["source_format"] = run.scene.provenance.source_format
        return
    if not is_image_input(run.input_path, cfg.format):
        read = functools.partial(
            _read_one, run.input_path, cfg.format, room=cfg.room, asset_dir=cfg.asset_dir, allow_orphans=cfg.allow_orphans
        )
        run.scene = await asyncio.to_thread(read)
        rec.detail["source_format"] = run.scene.provenance.source_format
        note_import_warnings(run, [run.scene])
        return
    model = await run.asking(rec)
    if cfg.prompt is not None:
        await _draw_prompt(run, rec)
    result = await perceive(
        run.input_path, model.model, detections=cfg.detections, segmenter=cfg.segmenter, reconstructor=cfg.reconstructor,
        hfov_deg=cfg.hfov_deg, camera_height_m=cfg.camera_height_m, out_dir=run.out_dir, policy=run.policy, settings=model.settings, seed=cfg.seed,
        clock=model.clock, agent_log=run.agent_log(),
    )  # fmt: skip
    run.scene = result.scene
    rec.detail["source_format"] = "image"
    rec.detail["perception"] = result.report
    run.note_fallbacks(result.agents.fallbacks)
    if result.report.get("segmenter") == "box" and cfg.segmenter == "auto":
        run.warnings.append(f"no segmenter installed: the objects' boxes stood in for their masks ({PERCEPTION_INSTALL})")


def _read_one(path: Path, format: str, *, room: str | None, asset_dir: Path | None, allow_orphans: bool) -> Scene:
    """The one scene a run's input holds (a house reaches here only with ``room``: ``pipeline/_house.py``)."""
    loaded = load_scene(path, format, room=room, asset_dir=asset_dir, allow_orphans=allow_orphans)
    if isinstance(loaded, House):  # pragma: no cover - the driver sends whole houses to the house run
        raise UsageError(f"{path} is a house; generate it whole, or pick a room with --room ({', '.join(loaded.room_ids)})")
    return loaded


def note_import_warnings(run: PipelineRun, scenes: Sequence[Scene]) -> None:
    """Put what the import let through only because it was told to (a house's orphans, read with
    ``allow_orphans``: ``provenance.import_warnings``) first among the run's warnings,
    so the run ends ``degraded`` with that reason first (the importer has said it on the console)."""
    found: dict[str, None] = {}
    for scene in scenes:
        for text in scene.provenance.import_warnings:
            found[str(text)] = None
    fresh = [f"input: {w}" for w in found if f"input: {w}" not in run.warnings]
    if fresh:
        run.warnings[:0] = fresh


async def _draw_prompt(run: PipelineRun, rec: StageRecord) -> None:
    """Draw the text prompt into ``OUT/prompt.png`` (kept, with ``prompt.json``, so a re-run or a
    resumed run of the same prompt does not pay for it again)."""
    cfg = run.config
    model = await run.asking(rec)
    assert cfg.prompt is not None
    wanted = {"prompt": cfg.prompt, "size": cfg.image_size, "image_model": cfg.image_model, "model": model.detail["model"]}
    record = run.input_path.with_suffix(".json")
    try:
        drawn = json.loads(record.read_text(encoding="utf-8")) == wanted and run.input_path.is_file()
    except (OSError, ValueError):
        drawn = False
    rec.detail["prompt"] = {**wanted, "reused": drawn}
    if drawn:
        return
    png, usage = await model.model.generate_image(cfg.prompt, size=cfg.image_size, model=cfg.image_model)
    await asyncio.to_thread(write_atomic, run.input_path, png)
    await asyncio.to_thread(write_atomic, record, json.dumps(wanted, indent=2) + "\n")
    rec.detail["prompt"]["requests"] = usage.requests


async def _stage_assets(run: PipelineRun, rec: StageRecord) -> None:
    scene, cache = run.need_scene(), run.cache()

    def prepare() -> dict[str, int]:
        counts: dict[str, int] = {}
        for obj in scene.objects:
            counts[obj.asset.kind] = counts.get(obj.asset.kind, 0) + 1
            if obj.asset.kind == "mesh":  # warm the CoACD cache once, before physics needs it
                object_hulls(obj, run.base_dir, cache=cache)
        return counts

    rec.detail["asset_kinds"] = await asyncio.to_thread(prepare)


# -- structure, stabilize --------------------------------------------------------------------------


async def _stage_structure(run: PipelineRun, rec: StageRecord) -> None:
    scene, store = run.need_scene(), run.need_store()
    cfg = run.config
    notes_before = len(scene.provenance.notes)
    model = await run.asking(rec)
    agents = run.agent_log()
    try:
        scene = await structure_scene(
            scene, model.model, agents=cfg.agents, settings=model.settings, policy=run.policy,
            store=store.scoped("agents"),  # finished agents are not asked again on --resume
            seed=cfg.seed, priors_dir=cfg.priors_dir, base_dir=run.base_dir, agent_log=agents,
        )  # fmt: skip
    finally:
        if not model.uses_rule_solvers:
            rec.detail["solver_fallbacks"] = [{"agent": f.agent, "reason": f.reason} for f in agents.fallbacks]
        rec.detail["agents"] = _agent_breakdown(agents)
    run.scene = scene
    run.note_fallbacks(agents.fallbacks)
    # what the agents changed to make the input consistent (objects pulled inside walls...)
    rec.detail["repairs"] = scene.provenance.notes[notes_before:]
    # every re-parenting verification made ("verify: <object> -> <new parent> (<reason>)")
    rec.detail["reparented"] = [n[len("verify: ") :] for n in rec.detail["repairs"] if n.startswith("verify: ") and " -> " in n]
    structure = scene.structure
    rec.detail["units"] = len(structure.units) if structure else 0
    rec.detail["relations"] = len(scene.relations)
    rec.detail["constraints"] = len(scene.constraints)


def _agent_breakdown(agents: AgentLog) -> dict[str, Any]:
    """Per agent: how it was answered, model requests, repairs, tokens (``report.json``)."""
    outcomes, usage = agents.outcomes, agents.usage_summary()["by_agent"]
    out: dict[str, Any] = {}
    for name in sorted(set(outcomes) | set(usage)):
        o, u = outcomes.get(name), usage.get(name, {})
        out[name] = {
            "answered_by": o.answered_by if o else "resumed",
            "requests": o.requests if o else 0,
            "repairs": o.repairs if o else 0,
            "valid_first_time": bool(o and o.answered_by == "model" and o.repairs == 0),
            "input_tokens": u.get("input_tokens", 0),
            "output_tokens": u.get("output_tokens", 0),
            **({"fallback_reason": o.reason} if o and o.reason else {}),
        }
    return out


async def _stage_stabilize(run: PipelineRun, rec: StageRecord) -> None:
    scene = run.need_scene()
    if not run.config.stabilize:
        rec.status = "skipped"
        return
    run.scene, report = await stabilize_scene(scene, base_dir=run.base_dir, seed=run.config.seed, hull_cache=run.cache())
    rec.detail.update(report.model_dump(mode="json", include=_summary_fields(report)))


def _summary_fields(report: Any) -> set[str]:
    """The scalar fields of a report model (counts, booleans, timings) for report.json's stage table."""
    return {
        name
        for name, value in report
        if isinstance(value, int | float | bool | str) or (isinstance(value, list) and len(value) <= 20)
    }


# -- evolve, compose -------------------------------------------------------------------------------


async def _stage_evolve(run: PipelineRun, rec: StageRecord) -> None:
    """Refine every unit through the Critic-Actor loop (and grow unit variants when asked)."""
    scene = run.need_scene()
    cfg = run.config
    if not (cfg.evolve and cfg.stabilize):  # it refines a stabilized scene
        rec.status = "skipped"
        rec.detail["reason"] = "evolve off" if not cfg.evolve else "stabilize off: nothing stabilized to refine"
        return
    shapes = await asyncio.to_thread(run.shapes, scene)
    model = await run.asking(rec)
    run.scene, report = await evolve_scene(
        scene, model.model, shapes, variants=cfg.variants, settings=model.settings, policy=run.policy,
        max_rounds=cfg.evolve_rounds, seed=cfg.seed, base_dir=run.base_dir,
        views_dir=run.folder.evolve if cfg.save_views else None, rules=cfg.layout_rules, agent_log=run.agent_log(),
    )  # fmt: skip
    summary = report.summary()
    rec.detail.update({k: v for k, v in summary.items() if k != "per_layout"})
    rec.detail["layouts"] = summary["per_layout"]
    rec.detail["files"] = await asyncio.to_thread(_write_layouts, report, run.folder)
    refined = run.scene
    blockers = await asyncio.to_thread(door_blockers, refined)
    if (
        blockers
    ):  # the refined base put a piece back in front of a door: cleared again (the variants never do)
        shapes = await asyncio.to_thread(run.shapes, refined)
        run.scene, repair = await asyncio.to_thread(clear_doors, refined, shapes)
        rec.detail["doors_cleared"] = {k: round(v, 3) for k, v in repair.moved.items()}
    kept, run.dropped_layouts = kept_layouts(report)
    run.layouts = {unit: (k.layout_ids, k.poses) for unit, k in kept.items()}
    for unit in report.units:
        for lay in unit.layouts:
            run.note_fallbacks(lay.agents.fallbacks, f" ({unit.anchor_id}/{lay.layout_id})", width=120)
        o = unit.original
        if unit.promoted_from is not None:
            broke = "; ".join(unit.variants[0].violations[:3])
            run.notes.append(f"unit {unit.anchor_id}: the refined layout broke rules ({broke}); its base is layout {o.layout_id}, the valid one closest to it")
        if o.error:
            run.warnings.append(f"unit {unit.anchor_id}: evolution failed, kept the stabilized layout ({o.error[:160]})")
        elif o.violations:
            run.warnings.append(f"unit {unit.anchor_id}: refined layout still breaks rules: {'; '.join(o.violations[:5])}")


def _write_layouts(report: EvolutionReport, folder: RunFolder) -> list[str]:
    """``evolve/<unit>/<layout>.json`` per evolved layout (an output for people and tools, never
    read back): the 2D state, anchor-frame poses, checks and the rounds of its memory."""
    written: list[str] = []
    for unit in report.units:
        for lay in unit.layouts:
            target = folder.evolve_layout(unit.anchor_id, lay.layout_id)
            target.parent.mkdir(parents=True, exist_ok=True)
            payload = {
                **lay.summary(),
                "state": lay.state.model_dump(mode="json") if lay.state else None,
                "local_poses": {k: p.model_dump(mode="json") for k, p in lay.local_poses.items()},
                "memory": [r.model_dump(mode="json") for r in lay.rounds],
                "views": [str(Path(v).relative_to(folder.root)) for v in lay.views],
            }
            payload.pop("wall_s", None)  # timings vary between runs; the files must not
            write_atomic(target, json.dumps(payload, indent=2, sort_keys=True))
            written.append(str(target.relative_to(folder.root)))
    return written


async def _stage_doors(run: PipelineRun, rec: StageRecord) -> None:
    """A TV hung on the wall behind a bed's head or a sofa's back moves to the wall it faces
    (``physics.rehang_screens``); a room with doors (a room of a house): furniture moves out of
    their clearance zones and out of the way from them into the room (``physics.clear_doors``,
    ``docs/houses.md``), before the evolution, whose variants then keep the doors clear by
    construction (``evolve/_plans.py``)."""
    scene = run.need_scene()
    hung_wrong = any(on_backing_wall(scene, o.id) for o in scene.objects if is_screen(o.category))
    if not door_zones(scene) and not hung_wrong:
        rec.status = "skipped"
        rec.detail["reason"] = "no doors"
        return
    shapes = await asyncio.to_thread(run.shapes, scene)
    if hung_wrong:  # a TV behind a bed's head or a sofa's back: to the wall it faces
        scene, rehung, stuck = await asyncio.to_thread(rehang_screens, scene, shapes)
        rec.detail["screens_moved"] = rehung
        if stuck:
            run.warnings.append(f"screens: {', '.join(stuck)} still hang(s) behind a bed's head or a sofa's back")
    if not door_zones(scene):
        run.scene = scene
        return
    run.scene, repair = await asyncio.to_thread(clear_doors, scene, shapes)
    rec.detail["moved"] = {k: round(v, 3) for k, v in repair.moved.items()}
    rec.detail["blocking"] = repair.stuck
    rec.detail["cut_off"] = repair.cut_off
    if repair.stuck:
        run.warnings.append(f"door clearance: {', '.join(repair.stuck)} still stand(s) in front of a door")
    if repair.cut_off:
        run.warnings.append(f"door clearance: door(s) {', '.join(repair.cut_off)} open onto a pocket cut off from the room")


def floor_share(base_nav: float) -> float:
    """The NAV a variant must keep: ``WALK_MIN_SHARE``, or where the base's own NAV is lower, the
    base's less :data:`NAV_SLACK`."""
    return WALK_MIN_SHARE if base_nav >= WALK_MIN_SHARE else base_nav - NAV_SLACK


async def _stage_compose(run: PipelineRun, rec: StageRecord) -> None:
    """Select ``variants`` diverse whole scenes from evolve's unit layouts (held by the run)."""
    from scenemosaic.compose import UnitLayouts

    scene, m = run.need_scene(), run.config.variants
    if m <= 0 or not run.layouts:
        rec.status = "skipped"
        rec.detail["reason"] = "no variants asked for" if m <= 0 else "no evolved unit layouts"
        return
    layouts = {unit: UnitLayouts(unit, ids, poses) for unit, (ids, poses) in run.layouts.items()}
    shapes = await asyncio.to_thread(run.shapes, scene)
    share = floor_share(await asyncio.to_thread(nav, scene))
    blocked = {b.object_id for b in await asyncio.to_thread(door_blockers, scene)}
    cut = set(await asyncio.to_thread(cut_off_doors, scene))
    crossing = {oid for _, oid, _ in await asyncio.to_thread(wall_crossings, scene)}
    relations = await asyncio.to_thread(functional_relations, scene)
    plausible = await asyncio.to_thread(plausibility, scene)

    def walkable(candidate: Scene) -> bool:
        """As connected a walkable floor as the base; no door blocked, no object across a wall anew;
        every functional relation of the base kept (a sofa still facing its TV, a lamp over its table);
        no plausibility rule broken that the base keeps (``metrics.plausibility``: a TV on the headboard wall)."""
        if not all(functional_holds(candidate, r) for r in relations):
            return False
        now = plausibility(candidate)
        if any(now[k] < v for k, v in plausible.items()):
            return False
        if nav(candidate) < share or not {b.object_id for b in door_blockers(candidate)} <= blocked:
            return False
        if not {oid for _, oid, _ in wall_crossings(candidate)} <= crossing:
            return False
        return set(cut_off_doors(candidate)) <= cut

    compose = functools.partial(compose_variants, scene, layouts, shapes, m=m, seed=run.config.seed, accept=walkable)
    variants, report = await asyncio.to_thread(compose)
    report.dropped = run.dropped_layouts + report.dropped
    rec.detail.update(report.summary())
    checked = []
    for i, (variant, picked) in enumerate(zip(variants, report.picked, strict=True), start=1):
        variant.provenance.steps.append("compose")
        variant.provenance.notes.append(f"variant {i}: " + ", ".join(f"{k} {v}" for k, v in picked.items()))
        check = functools.partial(check_collisions, variant, run.base_dir, hull_cache=run.cache())
        bounds = functools.partial(check_out_of_bounds, variant, shapes=shapes)
        cols, oob = await asyncio.to_thread(check), await asyncio.to_thread(bounds)
        name = run.folder.variant(i).name
        checked.append({"folder": name, "collision_pairs": len(cols.pairs), "out_of_bounds": len(oob.objects)})
        if cols.pairs or oob.objects:
            run.warnings.append(f"{name}: {len(cols.pairs)} colliding pair(s), {len(oob.objects)} object(s) out of bounds")
    run.variants = list(variants)
    rec.detail["variants"] = checked
    note_shortfall(run, rec, len(variants), report.pool_size)


def note_shortfall(run: PipelineRun, rec: StageRecord, written: int, pool: int) -> None:
    """Fewer distinct valid variants than asked for: not a fault of the scenes composed, so said
    in the report's ``notes`` (the console prints them), not a warning that degrades the run. A
    room of a house only records it: the house composes its own variants from every room's."""
    m = run.config.variants
    if written >= m:
        return
    rec.detail["shortfall"] = f"{m} variants asked for, {written} distinct valid ones in a pool of {pool}"
    if run.source is None:
        run.notes.append(f"fewer variants than asked for: {rec.detail['shortfall']}")


# -- validate, evaluate ----------------------------------------------------------------------------


async def _stage_validate(run: PipelineRun, rec: StageRecord) -> None:
    report = await asyncio.to_thread(functools.partial(validate_scene, run.need_scene(), run.base_dir, hull_cache=run.cache()))
    rec.detail.update(report.model_dump(mode="json", include=_summary_fields(report)))
    run.validation = report.model_dump(mode="json")
    run.warnings += validation_warnings(report)


def validation_warnings(report: ValidationReport) -> list[str]:
    """What a scene's validation found wrong, in words (each a warning: the run is ``degraded``)."""
    out = []
    if report.collisions.pairs:
        worst = max(p.depth_m for p in report.collisions.pairs)
        out.append(f"{len(report.collisions.pairs)} colliding pair(s) left, deepest {worst:.3f} m")
    if report.out_of_bounds.objects:
        out.append(f"{len(report.out_of_bounds.objects)} object(s) out of bounds")
    if report.fell:
        out.append("object(s) fell in the validation run: " + ", ".join(report.fell[:10]))
    if report.tipped:
        out.append("object(s) tipped in the validation run: " + ", ".join(report.tipped[:10]))
    out += [f"furniture nested inside each other's boxes: {pair}" for pair in report.nested]
    return out


async def _stage_evaluate(run: PipelineRun, rec: StageRecord) -> None:
    """The field's metrics of the base scene and of every variant, into ``report.json``."""
    scene = run.need_scene()
    scenes = [scene, *run.variants]
    measure = functools.partial(
        evaluate, scene, run.variants, base_dir=run.base_dir, variant_dirs=[run.base_dir] * len(run.variants),
        hull_cache=run.cache(),
    )  # fmt: skip
    result = await asyncio.to_thread(measure)
    judged = await judge_scenes(run, rec, scenes)
    if judged is not None:
        result["semantic_judge"] = {"base": judged[0], "variants": judged[1:]}
    rec.detail.update(result)
    run.metrics = result


async def judge_scenes(run: PipelineRun, rec: StageRecord, scenes: list[Scene]) -> list[dict[str, Any]] | None:
    """POS and ROT of each scene from the run's model (the semantic judge); ``None`` with the
    offline rules, which cannot judge a render."""
    if run.uses_rules:
        return None
    model = await run.asking(rec)
    log = run.agent_log()
    return [await judge_scene(s, model.model, settings=model.settings, base_dir=run.base_dir, agent_log=log) for s in scenes]


# -- export ----------------------------------------------------------------------------------------


async def _stage_export(run: PipelineRun, rec: StageRecord) -> None:
    rec.detail["files"] = await asyncio.to_thread(deliver_run, run)
    missing = formats_left_out()
    if missing:
        rec.detail["formats_left_out"] = missing
        log.warning("formats_left_out", formats=sorted(missing), install=sorted(missing.values()))
    if run.variants:
        rec.detail["contact_sheet"] = RunFolder.CONTACT_SHEET


def deliver_run(run: PipelineRun) -> list[str]:
    """Write the base scene to ``base/`` and every variant to ``variant_<i>/`` in the delivered
    layout, their parts in the run's ``open_state``, then the contact sheet; returns the base
    folder's files."""
    state, seed = run.config.open_state, run.config.seed
    files = deliver_scene(open_scene(run.need_scene(), state, seed, run.base_dir), run.folder.base, run.base_dir, hull_cache=run.cache())
    for i, variant in enumerate(run.variants, start=1):
        deliver_scene(open_scene(variant, state, seed, run.base_dir), run.folder.variant(i), run.base_dir, hull_cache=run.cache())
    if run.variants:
        folders = [run.folder.base, *(run.folder.variant(i) for i in range(1, len(run.variants) + 1))]
        contact_sheet([(f.name, f / RunFolder.TOPDOWN) for f in folders], run.folder.contact_sheet)
    return files


STAGES: tuple[Stage, ...] = (
    Stage("import", _stage_import),
    Stage("assets", _stage_assets),
    Stage("structure", _stage_structure),
    Stage("stabilize", _stage_stabilize),
    Stage("doors", _stage_doors),
    Stage("evolve", _stage_evolve),
    Stage("compose", _stage_compose),
    Stage("validate", _stage_validate),
    Stage("evaluate", _stage_evaluate),
    Stage("export", _stage_export),
)
"""A room's stages, in order (the run's plan, ``pipeline/_plan.py``, adds the clutter stage after
compose when asked for, and gives a house's rooms those up to compose)."""

STAGE_NAMES: tuple[str, ...] = tuple(stage.name for stage in STAGES)
"""The names of :data:`STAGES`, in order."""


"""The stages of ``generate``, in order: import → assets → structure → stabilize → doors → evolve → compose → validate → evaluate → export.

One set of stages for a room and a whole house: a house run goes through the same import, compose,
validate, evaluate and export, with its ``rooms`` stage (``pipeline/_house.py``: every room through
the room stages up to its own variants) in place of assets ... evolve. What a stage works on is the
run's world (:meth:`~scenemosaic.pipeline.PipelineRun.need_world`: the room's scene, or the house),
through the one entry point each package has for both (``exchange.load_scene``/``deliver_scene``,
``physics.validate_scene``, ``metrics.evaluate``); compose combines a room's local units or a
house's rooms, the only step that differs in what it combines.

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
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import structlog

from scenemosaic.agents import AgentLog
from scenemosaic.assets import object_hulls, open_scene, part_openings, short_parts
from scenemosaic.compose import compose_house, compose_variants, kept_layouts
from scenemosaic.evolve import EvolutionReport, evolve_scene
from scenemosaic.exceptions import UsageError
from scenemosaic.exchange import (
    deliver_scene,
    formats_left_out,
    load_asset_annotations,
    load_house,
    load_scene,
)
from scenemosaic.metrics import evaluate, furniture, house_checks, judge_scene, nav, plausibility
from scenemosaic.perception import PERCEPTION_INSTALL, is_image_path, perceive
from scenemosaic.physics import (
    ValidationReport,
    check_collisions,
    check_out_of_bounds,
    clear_doors,
    free_part_paths,
    rehang_screens,
    stabilize_scene,
    validate_scene,
)
from scenemosaic.pipeline._clutter import vary_house_repeats
from scenemosaic.pipeline._config import GenerateConfig
from scenemosaic.pipeline._deliveries import deliver_ahead, delivered_worlds, house_deliveries, put_in_place
from scenemosaic.pipeline._state import PipelineRun, Stage, StageRecord, rooms_of
from scenemosaic.render import ContactSheet
from scenemosaic.scene import (
    House,
    HouseFloor,
    RunFolder,
    Scene,
    cut_off_doors,
    door_blockers,
    door_zones,
    functional_holds,
    functional_relations,
    is_screen,
    kept_floor_share,
    on_backing_wall,
    wall_crossings,
    write_atomic,
)
from scenemosaic.structure import structure_scene

log = structlog.get_logger(__name__)

__all__ = [
    "STAGES",
    "STAGE_NAMES",
    "is_image_input",
    "judge_scenes",
    "note_import_warnings",
    "note_shortfall",
    "note_source_faults",
    "planned_room",
    "validation_warnings",
]

def is_image_input(run_input: Path, format: str) -> bool:
    """Whether a run's input is a photograph for the image front end (``format`` ``image``, or
    ``auto`` and an image suffix)."""
    return format == "image" or (format == "auto" and is_image_path(run_input))


# -- import, assets ---------------------------------------------------------------------------------


async def _stage_import(run: PipelineRun, rec: StageRecord) -> None:
    """What the run works on: a house's room as the house import gave it (in memory), the scene or
    whole house the input holds (``exchange.load_scene``; ``load_house`` when the plan runs the
    input as a house), or the scene the image front end reconstructs from a photograph."""
    cfg = run.config
    if run.source is not None:  # a room of a house: the house import gave it
        run.scene = run.source
        rec.detail["source_format"] = run.scene.provenance.source_format
        return
    if not is_image_input(run.input_path, cfg.format):
        world = await asyncio.to_thread(_read_input, run.input_path, cfg, house=run.setup.is_house)
        rooms = rooms_of(world)
        rec.detail["source_format"] = rooms[0].provenance.source_format
        if isinstance(world, House):
            run.house = world
            rec.detail["rooms"] = world.room_ids
        else:
            run.scene = world
        note_import_warnings(run, rooms)
        note_source_faults(run, rec, rooms)
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


def _read_input(path: Path, cfg: GenerateConfig, *, house: bool) -> Scene | House:
    """The one scene a run's input holds, or (``house``: the plan runs the input as a whole house,
    ``pipeline/_plan.py``) its whole house."""
    database = load_asset_annotations(cfg.asset_annotations) if cfg.asset_annotations is not None else None
    if house:
        return load_house(path, cfg.format, asset_database=database, allow_orphans=cfg.allow_orphans, index=cfg.index)
    loaded = load_scene(
        path, cfg.format, room=cfg.room, asset_database=database, asset_dir=cfg.asset_dir,
        allow_orphans=cfg.allow_orphans, index=cfg.index,
    )  # fmt: skip
    if isinstance(loaded, House):  # pragma: no cover - the plan runs whole houses as houses
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


SOURCE_FAULTS_SHOWN = 3
"""How many of the input's mended faults the run's note quotes (the import stage's detail lists all)."""


def note_source_faults(run: PipelineRun, rec: StageRecord, scenes: Sequence[Scene]) -> None:
    """Say once what the input file got wrong and its reader mended (``provenance.source_faults``:
    an object id given twice, a door hole past its wall), and which objects stand in for assets
    the asset database does not hold (``provenance.size_estimates``): every one in the import
    stage's detail, a count (and the first few faults) in the run's notes. The run is not degraded
    by them: what it delivers is whole; the source file is what a user may want to mend."""
    estimated = {oid: how for scene in scenes for oid, how in scene.provenance.size_estimates.items()}
    if estimated:  # assets the database does not hold (Objaverse ids, a fork's own): stand-ins
        rec.detail["size_estimates"] = estimated
        run.notes.append(
            f"input: {len(estimated)} object(s) whose asset the asset database does not hold stand in as boxes "
            "sized from estimates (each: report.json, stage import)"
        )
    found = list(dict.fromkeys(text for scene in scenes for text in scene.provenance.source_faults))
    if not found:
        return
    rec.detail["source_faults"] = found
    shown = "; ".join(found[:SOURCE_FAULTS_SHOWN]) + ("; ..." if len(found) > SOURCE_FAULTS_SHOWN else "")
    run.notes.append(f"input: {len(found)} fault(s) of the source file mended on import (all: report.json, stage import): {shown}")


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
    (``physics.rehang_screens``); furniture whose own drawers, doors or lids cannot open where it
    stands (a fridge flush to a wall on its hinge side) slides sideways the least that lets them
    (``physics.free_part_paths``); a room with doors (a room of a house): furniture moves out of
    their clearance zones and out of the way from them into the room (``physics.clear_doors``,
    ``docs/houses.md``), before the evolution, whose variants then keep the doors clear by
    construction (``evolve/_plans.py``)."""
    scene = run.need_scene()
    hung_wrong = any(on_backing_wall(scene, o.id) for o in scene.objects if is_screen(o.category))
    blocked = await asyncio.to_thread(short_parts, scene, run.base_dir) if scene.room is not None else {}
    if not door_zones(scene) and not hung_wrong and not blocked:
        rec.status = "skipped"
        rec.detail["reason"] = "no doors, and nothing in the way of a part"
        return
    shapes = await asyncio.to_thread(run.shapes, scene)
    if hung_wrong:  # a TV behind a bed's head or a sofa's back: to the wall it faces
        scene, rehung, stuck = await asyncio.to_thread(rehang_screens, scene, shapes)
        rec.detail["screens_moved"] = rehung
        if stuck:
            run.warnings.append(f"screens: {', '.join(stuck)} still hang(s) behind a bed's head or a sofa's back")
    if blocked:  # what cannot open where it stands: the least sideways move that lets it
        scene, parts = await asyncio.to_thread(free_part_paths, scene, shapes, run.base_dir)
        if parts.moved:
            rec.detail["parts_freed"] = {k: round(v, 3) for k, v in parts.moved.items()}
        if parts.stuck:
            rec.detail["parts_blocked"] = parts.stuck
            run.notes.append("parts that cannot open where their furniture stands: " + "; ".join(
                f"{oid} ({', '.join(names)})" for oid, names in sorted(parts.stuck.items())
            ))  # fmt: skip
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


async def _stage_compose(run: PipelineRun, rec: StageRecord) -> None:
    """Select ``variants`` diverse whole variants from the valid variants of the world's units
    (max-min greedy selection over their product, ``compose``): a room's units are its local units
    (evolve's kept layouts, :func:`_combine_units`), a house's are its rooms (each room's own
    variants, as its compose left them: :func:`_combine_rooms`). Every variant is then checked as
    the base was (collisions and bounds in every room; a house's own checks), and a house's
    final ones are delivered ahead while the later stages run (``pipeline/_deliveries.py``)."""
    world, m = run.need_world(), run.config.variants
    house = isinstance(world, House)
    if house and run.config.clutter == "keep":  # nothing here changes the base: it is delivered meanwhile
        await deliver_ahead(run, {RunFolder.BASE})
    combined = "no variants asked for" if m <= 0 else await (_combine_rooms if house else _combine_units)(run, rec)
    if isinstance(combined, str):
        rec.status = "skipped"
        rec.detail["reason"] = combined
        await deliver_ahead(run, {RunFolder.BASE})
        return
    found, pool = combined
    variants: list[Scene | House] = list(found)
    checked: list[dict[str, Any]] = []
    checks_of: list[dict[str, Any]] = []
    for i, variant in enumerate(variants, start=1):
        name = run.folder.variant(i).name
        cols, oob, checks = await _variant_checks(run, variant)
        checks_of.append(checks)
        checked.append({"folder": name, "collision_pairs": cols, "out_of_bounds": oob, **checks})
        problems = _house_problems(checks) + ([f"{cols} colliding pair(s), {oob} object(s) out of bounds"] if cols or oob else [])
        if problems:
            run.warnings.append(f"{name}: " + "; ".join(problems))
    if house:
        run.house_variants, run.variant_checks = [v for v in variants if isinstance(v, House)], checks_of
    else:
        run.variants = [v for v in variants if isinstance(v, Scene)]
    rec.detail["variants"] = checked
    note_shortfall(run, rec, len(variants), pool)
    # every variant is final now: a house's are delivered while validate and evaluate run here
    await deliver_ahead(run, {RunFolder.BASE, *(run.folder.variant(i).name for i in range(1, len(variants) + 1))})


async def _combine_units(run: PipelineRun, rec: StageRecord) -> tuple[list[Scene], int] | str:
    """A room's variants: whole scenes from evolve's kept unit layouts (``compose_variants``), each
    as walkable as the base, no door blocked, no part kept from opening and no functional relation or
    plausibility rule of the base broken; with the candidate pool's size (or why there is nothing to
    combine)."""
    from scenemosaic.compose import UnitLayouts

    if not run.layouts:
        return "no evolved unit layouts"
    scene, m = run.need_scene(), run.config.variants
    layouts = {unit: UnitLayouts(unit, ids, poses) for unit, (ids, poses) in run.layouts.items()}
    shapes = await asyncio.to_thread(run.shapes, scene)
    share = kept_floor_share(await asyncio.to_thread(nav, scene))
    blocked = {b.object_id for b in await asyncio.to_thread(door_blockers, scene)}
    cut = set(await asyncio.to_thread(cut_off_doors, scene))
    crossing = {oid for _, oid, _ in await asyncio.to_thread(wall_crossings, scene)}
    relations = await asyncio.to_thread(functional_relations, scene)
    plausible = await asyncio.to_thread(plausibility, scene)
    short = await asyncio.to_thread(short_parts, scene, run.base_dir)
    placed = {o.id: o.pose for o in scene.objects}

    def walkable(candidate: Scene) -> bool:
        """As connected a walkable floor as the base; no door blocked, no object across a wall anew;
        every functional relation of the base kept (a sofa still facing its TV, a lamp over its table);
        no plausibility rule broken that the base keeps (``metrics.plausibility``: a TV on the headboard wall);
        no drawer, door or lid of a piece that stays where it stands kept from opening by one moved
        into its way, when it opens in the base (``assets.short_parts``: a dining chair moved before
        the fridge's door; a piece moved with its own arrangement is its plan's and its unit's to
        keep free)."""
        if not all(functional_holds(candidate, r) for r in relations):
            return False
        moved = {o.id for o in candidate.objects if placed.get(o.id) != o.pose}
        still = [oid for oid in placed if oid not in moved]
        stopped = short_parts(candidate, run.base_dir, still, near=moved) if moved else {}
        if any(len(names) > len(short.get(oid, ())) for oid, names in stopped.items()):
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
    for i, (variant, picked) in enumerate(zip(variants, report.picked, strict=True), start=1):
        variant.provenance.steps.append("compose")
        variant.provenance.notes.append(f"variant {i}: " + ", ".join(f"{k} {v}" for k, v in picked.items()))
    return list(variants), report.pool_size


async def _combine_rooms(run: PipelineRun, rec: StageRecord) -> tuple[list[House], int] | str:
    """A house's variants: whole houses from one candidate pool over every room's own valid
    variants (``compose_house``), each with every room as reachable as in the base and no floor cut off (``HouseFloor.keeps``); with clutter,
    a room two houses show in the same arrangement gets its small objects varied anew
    (``pipeline._clutter.vary_house_repeats``). With the pool's size (or why there is nothing to
    combine). A house gives at most as many variants as its rooms hold arrangements besides their
    bases (``capped``): asked for more, it composes that many and says why."""
    house, m = run.need_house(), run.config.variants
    room_variants = [_room_variants(run, s.id) for s in house.rooms]
    if not any(room_variants):
        return "no room has a variant"
    arrangements = sum(len(v) for v in room_variants)
    if m > arrangements:  # past it, a house variant only recombines room arrangements others show
        given = ", ".join(f"{s.id} {len(v)}" for s, v in zip(house.rooms, room_variants, strict=True) if v)
        rec.detail["capped"] = (
            f"{m} house variants asked for, {arrangements} given: its rooms hold {arrangements} arrangements "
            f"besides their bases ({given}), and a house variant past that many would only recombine rooms "
            "the others already show"
        )
        rec.detail["capped_at"] = m = arrangements
    unplanned = [s.id for s in house.rooms if furniture(s) and not planned_room(run, s.id)]
    if unplanned:  # said, not hidden: their variants differ in smaller pieces only
        rec.detail["rooms_without_plan"] = unplanned
        run.notes.append(f"room(s) whose free floor holds no other arrangement of their furniture groups: {', '.join(unplanned)}")
    floor = HouseFloor(house)  # the floors and doorways rasterized once, each room arrangement once
    keeps = floor.keeps(house.rooms)  # every room as reachable, no floor of the house cut off
    compose = functools.partial(compose_house, house.rooms, room_variants, m=m, seed=run.config.seed, accept=keeps)
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
    houses = []
    for i, rooms in enumerate(variants, start=1):
        for s in rooms:
            anew = " (its small objects varied anew)" if s.id in varied.get(f"variant_{i}", ()) else ""
            s.provenance.notes.append(f"house variant {i}: this room as {report.picked[i - 1][s.id]}{anew}")
        houses.append(house.with_rooms(rooms))
    return houses, report.pool_size


def _room_variants(run: PipelineRun, room_id: str) -> list[Scene]:
    outcome = run.rooms.get(room_id)
    return list(outcome.state.variants) if outcome is not None and outcome.state is not None else []


def planned_room(run: PipelineRun, room_id: str) -> bool:
    """Whether a house's room kept a room plan among its floor's evolved layouts (``evolve/_plans.py``)."""
    outcome = run.rooms.get(room_id)
    layouts = outcome.state.layouts if outcome is not None and outcome.state is not None else None
    floor = (layouts or {}).get("floor")
    return floor is not None and any(lid.startswith("plan_") for lid in floor[0])


async def _variant_checks(run: PipelineRun, variant: Scene | House) -> tuple[int, int, dict[str, Any]]:
    """A variant's colliding pairs and objects out of bounds over its rooms, and a house's own
    checks (``metrics.house_checks``; a room: none)."""
    cols = oob = 0
    for room in rooms_of(variant):
        shapes = await asyncio.to_thread(run.shapes, room)  # hulls may be computed: off the event loop
        cols += len((await asyncio.to_thread(check_collisions, room, run.base_dir, hull_cache=run.cache())).pairs)
        oob += len((await asyncio.to_thread(functools.partial(check_out_of_bounds, room, shapes=shapes))).objects)
    checks = await asyncio.to_thread(house_checks, variant) if isinstance(variant, House) else {}
    return cols, oob, checks


def _house_problems(checks: dict[str, Any]) -> list[str]:
    """The house checks (``metrics.house_checks``) that fail, in words (a room's run has none)."""
    out = []
    if checks.get("unreachable_rooms"):
        out.append(f"room(s) not reachable from the rest of the house: {', '.join(checks['unreachable_rooms'])}")
    if checks.get("door_blockers"):
        out.append(f"door(s) blocked by {', '.join(checks['door_blockers'][:6])}")
    if checks.get("wall_crossings"):
        out.append(f"object(s) across a wall: {', '.join(checks['wall_crossings'][:6])}")
    return out


def note_shortfall(run: PipelineRun, rec: StageRecord, written: int, pool: int) -> None:
    """Fewer distinct valid variants than asked for: not a fault of the scenes composed, so said
    in the report's ``notes`` (the console prints them), not a warning that degrades the run; a
    house asked for more than its rooms can give says so (``capped``, :func:`_combine_rooms`). A
    room of a house only records it: the house composes its own variants from every room's."""
    m = run.config.variants
    if written >= m:
        return
    if written >= rec.detail.get("capped_at", m):  # a house asked for more than its rooms can give
        rec.detail["shortfall"] = rec.detail["capped"]
    else:
        rec.detail["shortfall"] = f"{m} variants asked for, {written} distinct valid ones in a pool of {pool}"
    if run.source is None:
        run.notes.append(f"fewer variants than asked for: {rec.detail['shortfall']}")


# -- validate, evaluate ----------------------------------------------------------------------------


async def _stage_validate(run: PipelineRun, rec: StageRecord) -> None:
    """The world settled in MuJoCo with every room's checks (``physics.validate_scene``: a room's
    report, or a house's by room with its whole world settled once; with ``--open-state`` the
    settling is the delivered world's, its parts open, the layout's checks the closed one's); then
    a house's own checks (reachability from room to room, door clearance, nothing across a wall)."""
    world = run.need_world()
    cfg = run.config
    found: ValidationReport | dict[str, ValidationReport] = await asyncio.to_thread(
        functools.partial(validate_scene, world, run.base_dir, hull_cache=run.cache())
    )
    # what is delivered, its parts in the run's --open-state: how it moves is what the run reports
    delivered: Scene | House = await asyncio.to_thread(lambda: open_scene(world, cfg.open_state, cfg.seed, run.base_dir))
    if delivered is not world:
        opened = await asyncio.to_thread(functools.partial(validate_scene, delivered, run.base_dir, hull_cache=run.cache()))
        found = _moved_as_delivered(found, opened)
        rec.detail["open_parts"] = sum(len(v) for v in part_openings(delivered).values())
    if isinstance(found, ValidationReport):  # a room's run: the room's report is the run's
        rec.detail.update(found.model_dump(mode="json", include=_summary_fields(found)))
        rec.detail["parts_moved"] = len(found.parts_moved)
        run.validation = found.model_dump(mode="json")
        run.warnings += validation_warnings(found)
        return
    per_room: dict[str, Any] = {}
    for rid, report in found.items():
        per_room[rid] = report.model_dump(mode="json")
        state = run.rooms[rid].state if rid in run.rooms else None
        if state is not None:  # each room's report shows its own
            state.validation = per_room[rid]
        run.warnings += [f"{rid}: {w}" for w in validation_warnings(report)]
    assert isinstance(world, House)  # a house's reports come by room
    checks = await asyncio.to_thread(house_checks, world)
    run.warnings += [f"base: {p}" for p in _house_problems(checks)]
    run.validation = {
        "collision_pairs": sum(len(v["collisions"]["pairs"]) for v in per_room.values()),
        "out_of_bounds": sum(len(v["out_of_bounds"]["objects"]) for v in per_room.values()),
        "fell": sum(len(v["fell"]) for v in per_room.values()),
        "tipped": sum(len(v["tipped"]) for v in per_room.values()),
        "parts_moved": sum(len(v["parts_moved"]) for v in per_room.values()),
        "max_displacement_m": max((v["max_displacement_m"] for v in per_room.values()), default=0.0),
        **checks,
    }
    rec.detail.update({k: v for k, v in run.validation.items() if not isinstance(v, dict | list) or len(v) <= 20})


_MOTION_FIELDS = ("tipped", "fell", "motions", "max_displacement_m", "simulated_s", "parts_moved")
"""The fields of a ``ValidationReport`` the settling simulation fills (the rest are checks of the
layout as it stands)."""


def _moved_as_delivered(
    closed: ValidationReport | dict[str, ValidationReport], opened: ValidationReport | dict[str, ValidationReport]
) -> ValidationReport | dict[str, ValidationReport]:
    """The checks of the layout (collisions, bounds, support gaps, nesting) from the closed world's
    validation, which holds every part on its carcass; how the world moves (tipped, fell,
    motions) from the delivered world's, its parts open."""

    def one(c: ValidationReport, o: ValidationReport) -> ValidationReport:
        return c.model_copy(update={name: getattr(o, name) for name in _MOTION_FIELDS})

    if isinstance(closed, ValidationReport):
        assert isinstance(opened, ValidationReport)
        return one(closed, opened)
    assert isinstance(opened, dict)
    return {rid: one(report, opened[rid]) for rid, report in closed.items()}


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
    if report.parts_moved:
        moved = [f"{k} ({v:g})" for k, v in list(report.parts_moved.items())[:10]]
        out.append("part(s) moved from where they are delivered in the validation run: " + ", ".join(moved))
    out += [f"furniture nested inside each other's boxes: {pair}" for pair in report.nested]
    return out


async def _stage_evaluate(run: PipelineRun, rec: StageRecord) -> None:
    """The field's metrics of the base and of every variant (``metrics.evaluate``: a room's, or each
    room's and the house's with the house checks validate and compose measured), into
    ``report.json``; with a model, each room's POS and ROT (the semantic judge)."""
    world, variants = run.need_world(), run.world_variants
    house = isinstance(world, House)
    checks = {"base_checks": run.validation, "variant_checks": run.variant_checks} if house else {}
    measure = functools.partial(
        evaluate, world, variants, base_dir=run.base_dir, variant_dirs=[run.base_dir] * len(variants),
        hull_cache=run.cache(), **checks,
    )  # fmt: skip
    metrics: dict[str, Any] = await asyncio.to_thread(measure)
    if house:
        frozen = [rid for rid in metrics["house"].get("rooms_not_rearranged") or [] if planned_room(run, rid)]
        if frozen:  # had room plans, none selected (rooms without any were said at compose)
            run.notes.append(f"room(s) whose furniture no selected variant moves: {', '.join(frozen)}")
    for k, room in enumerate(rooms_of(world)):  # POS and ROT per room, from the run's model
        judged = await judge_scenes(run, rec, [room, *(rooms_of(v)[k] for v in variants)])
        if judged is not None:
            (metrics["rooms"][room.id] if house else metrics)["semantic_judge"] = {"base": judged[0], "variants": judged[1:]}
    if house:
        rec.detail["house"] = metrics["house"]
    else:
        rec.detail.update(metrics)
    run.metrics = metrics


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
    """``base/`` and every ``variant_<i>/``, each a scene or a whole house (``exchange.deliver_scene``,
    in the run's ``--open-state``), and the contact sheet of their plans. What was delivered ahead (a
    house run's worker processes, ``pipeline/_deliveries.py``) is waited for and moved into place;
    the rest is delivered here."""
    worlds = await asyncio.to_thread(delivered_worlds, run)
    await deliver_ahead(run, {folder.name for folder, _ in worlds}, worlds)
    files: dict[str, list[str]] = {}
    sheet = ContactSheet(len(worlds)) if len(worlds) > 1 else None  # each plan placed as its world lands
    ahead = house_deliveries(run)
    if ahead is not None:
        async for name, written in ahead.landed():
            final = run.folder.root / name
            await asyncio.to_thread(put_in_place, run.folder.staged / name, final)
            files[str(final)] = written
            if sheet is not None:
                await asyncio.to_thread(sheet.add, name, final / RunFolder.TOPDOWN)
        rec.detail["delivered_ahead"] = sorted(ahead.houses)
        # how long the houses took to deliver, from the first one begun: mostly while other stages ran
        rec.detail["deliveries_s"] = round(time.perf_counter() - ahead.started, 3)
    else:
        cache = run.cache()
        for folder, world in worlds:
            files[str(folder)] = await asyncio.to_thread(functools.partial(deliver_scene, world, folder, run.base_dir, hull_cache=cache))
            if sheet is not None:
                await asyncio.to_thread(sheet.add, folder.name, folder / RunFolder.TOPDOWN)
    rec.detail["files"] = files[str(run.folder.base)]
    if sheet is not None:
        await asyncio.to_thread(sheet.save, run.folder.contact_sheet)
        rec.detail["contact_sheet"] = RunFolder.CONTACT_SHEET
    missing = formats_left_out()
    if missing:
        rec.detail["formats_left_out"] = missing
        log.warning("formats_left_out", formats=sorted(missing), install=sorted(missing.values()))


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
compose when asked for, gives a house's rooms those up to compose, and runs a whole house through
import, its ``rooms`` stage, then compose, validate, evaluate and export: the same stages)."""

STAGE_NAMES: tuple[str, ...] = tuple(stage.name for stage in STAGES)
"""The names of :data:`STAGES`, in order."""


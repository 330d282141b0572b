"""Resuming a stopped run: its state kept in the run store of ``OUT/.checkpoint/``.

One mechanism keeps everything a stopped run needs (``dag``'s :class:`~scenemosaic.dag.FileRunStore`):

* the node ``pipeline`` holds the run's state after its last finished stage (:class:`RunCheckpoint`:
  the scene, the stage records, evolve's kept unit layouts, compose's variants, the warnings...),
  stored under a key made of the settings that decide the results and the input's content hash,
  so a record is only found again by the same input with the same settings;
* the scope ``agents`` holds the structuring agents' outputs (the task graph's own resume);
* ``run.json`` beside them says which input and settings the run had (what ``--resume OUT``
  reads to know what to continue).

The output files (``base/``, ``evolve/``...) are never read back.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import structlog

from scenemosaic.dag import StoredOutput
from scenemosaic.exceptions import UnsafePathError, UsageError
from scenemosaic.exchange import dataset_entry, is_dataset
from scenemosaic.pipeline._config import GenerateConfig, config_from_record, config_record, deciding_settings
from scenemosaic.pipeline._state import PipelineRun, RunCheckpoint, StageRecord
from scenemosaic.scene import RunFolder, confined_path, write_atomic

__all__ = [
    "checkpoint_config",
    "checkpoint_state",
    "input_digest",
    "load_checkpoint",
    "previous_input",
    "save_checkpoint",
    "write_json",
]

log = structlog.get_logger(__name__)

PIPELINE_NODE = "pipeline"
"""The run store node that holds the pipeline's state."""




def input_digest(path: Path, config: GenerateConfig) -> str | None:
    """SHA-256 of the input's bytes (a folder: of its files' relative paths and bytes; a house of
    a dataset: of its line, not of the whole file); ``None`` for a text prompt (the prompt is a
    setting) or an input that is not there."""
    if config.prompt is not None or not path.exists():
        return None
    if config.index is not None and is_dataset(path):
        return dataset_entry(path, config.index).digest
    h = hashlib.sha256()
    # regular files only (is_file follows symlinks and is false for FIFOs and devices: never opened)
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    for f in files:
        h.update(str(f.relative_to(path) if path.is_dir() else f.name).encode() + b"\0")
        with f.open("rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    return h.hexdigest()


def _key(record: dict[str, Any], digest: str | None) -> str:
    payload = json.dumps([record, digest], sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(payload.encode()).hexdigest()


def write_json(path: Path, payload: dict[str, Any]) -> None:
    """Write a JSON document of the run atomically (``scene.write_atomic``), its folder made first."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, json.dumps(payload, indent=2, sort_keys=True))


def checkpoint_state(run: PipelineRun) -> RunCheckpoint:
    """The run's state as its checkpoint keeps it (finished stages only)."""
    return RunCheckpoint(
        scene=run.scene,
        records=[asdict(r) for r in run.records if r.status in ("done", "skipped", "reused")],
        layouts={u: (list(ids), [dict(p) for p in poses]) for u, (ids, poses) in run.layouts.items()}
        if run.layouts is not None
        else None,
        dropped_layouts=run.dropped_layouts,
        variants=run.variants,
        validation=run.validation,
        metrics=run.metrics,
        warnings=run.warnings,
        notes=run.notes,
        fallbacks=[{"agent": f.agent, "reason": f.reason, "given_up": f.given_up} for f in run.fallbacks],
        house=run.house,
        rooms=run.rooms,
        house_variants=run.house_variants,
        variant_checks=run.variant_checks,
    )


def save_checkpoint(run: PipelineRun, digest: str | None) -> None:
    """Keep the run's state (after a finished stage, and once at the start)."""
    store = run.need_store()
    record = config_record(run.config)
    # the input as an absolute path: ``--resume OUT`` may be given from another working directory
    write_json(run.folder.run_record, {"input": str(run.input_path.absolute()), "input_sha256": digest, "config": record})
    state = checkpoint_state(run)
    store.put(PIPELINE_NODE, _key(record, digest), StoredOutput.of(state))


def load_checkpoint(run: PipelineRun, digest: str | None) -> set[str]:
    """Restore a stopped run's state; returns the names of the stages it finished.

    Refuses (:class:`~scenemosaic.exceptions.UsageError`) a folder that holds a run of another
    input; a stale checkpoint — the same input with other settings that decide the results, or an
    input whose content changed since — is refused too, unless ``restart_stale`` is set: then the
    checkpoint is dropped and the run starts over (no stage is reused).
    """
    from scenemosaic.agents import FallbackRecord

    store = run.need_store()
    try:
        data = json.loads(run.folder.run_record.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    if not isinstance(data, dict) or not isinstance(data.get("input"), str):
        raise UsageError(f"cannot resume {run.out_dir}: its {run.folder.run_record.name} is damaged; run it again without --resume")
    if Path(data["input"]).resolve() != run.input_path.resolve():
        raise UsageError(f"{run.out_dir} holds a run of {data.get('input')}, not of {run.input_path}; cannot resume")
    record = config_record(run.config)
    keys = set(deciding_settings())
    changed = [k for k, v in record.items() if k in keys and data.get("config", {}).get(k) != v]
    stale = None
    if changed:
        stale = f"settings differ from the stopped run ({', '.join(changed)})"
    elif data.get("input_sha256") != digest:
        stale = f"{run.input_path} changed since the stopped run"
    if stale is not None:
        if not run.config.restart_stale:
            raise UsageError(f"cannot resume {run.out_dir}: {stale}; run it again without --resume, or add --restart-stale")
        log.warning("stale_checkpoint_restarted", out=str(run.out_dir), reason=stale)
        store.clear()
        for scope in ("agents", "plan"):
            store.scoped(scope).clear()
        return set()
    stored = store.get(PIPELINE_NODE, _key(record, digest))
    if stored is None:
        return set()
    state: RunCheckpoint = stored.output
    _check_confined(state, run)
    run.scene = state.scene
    run.records = [StageRecord(**r) for r in state.records]
    run.layouts = (
        {u: (tuple(ids), tuple(poses)) for u, (ids, poses) in state.layouts.items()} if state.layouts is not None else None
    )
    run.dropped_layouts = list(state.dropped_layouts)
    run.variants = list(state.variants)
    run.validation = state.validation
    run.metrics = state.metrics
    run.warnings = list(state.warnings)
    run.notes = list(state.notes)
    run.fallbacks = [
        FallbackRecord(agent=str(f["agent"]), reason=str(f["reason"]), given_up=bool(f.get("given_up", False)))
        for f in state.fallbacks
    ]
    run.house = state.house
    run.rooms = dict(state.rooms)
    run.house_variants = list(state.house_variants)
    run.variant_checks = list(state.variant_checks)
    return {r.name for r in run.records}


def _check_confined(state: RunCheckpoint, run: PipelineRun) -> None:
    """Every mesh a checkpoint names lies where an import would have allowed it (the input's
    folder): a checkpoint is a file on disk like any input, and resuming must not copy a file
    from elsewhere into the delivered folders."""
    houses = [h for h in (state.house, *state.house_variants) if h is not None]
    rooms = [o.state for o in state.rooms.values() if o.state is not None]
    scenes = [state.scene, *state.variants, *(s for h in houses for s in h.rooms)]
    scenes += [s for r in rooms for s in (r.scene, *r.variants)]
    for scene in scenes:
        for obj in scene.objects if scene is not None else []:
            if obj.asset.kind == "mesh" and obj.asset.uri is not None:
                try:
                    confined_path(run.base_dir, obj.asset.uri)
                except UnsafePathError as exc:
                    raise UsageError(
                        f"cannot resume {run.out_dir}: its checkpoint names a mesh outside the input's folder "
                        f"({obj.id}: {exc}); run it again without --resume"
                    ) from exc


def checkpoint_config(out_dir: str | Path) -> tuple[Path, GenerateConfig]:
    """The input and settings of the run whose checkpoint is in ``out_dir`` (for ``--resume``).

    Raises :class:`~scenemosaic.exceptions.UsageError` when the folder holds no resumable run.
    """
    path = RunFolder(out_dir).run_record
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise UsageError(f"{out_dir} holds no run to resume ({path} unreadable: {exc})") from exc
    if not isinstance(data, dict) or not isinstance(data.get("input"), str) or not isinstance(data.get("config", {}), dict):
        raise UsageError(f"{out_dir} holds no run to resume ({path} is damaged: no input or settings)")
    try:
        config = config_from_record(data.get("config", {}), resume=True)
    except (ValueError, TypeError) as exc:  # pydantic's ValidationError is a ValueError
        raise UsageError(f"{out_dir} holds no run to resume ({path} is damaged: {str(exc).splitlines()[0]})") from exc
    return Path(data["input"]), config


def previous_input(folder: RunFolder) -> str | None:
    """The input of the run whose results (or checkpoint) are in ``folder``, if any."""
    for candidate in (folder.run_record, folder.report):  # run.json's input is absolute
        try:
            value = json.loads(candidate.read_text(encoding="utf-8")).get("input")
        except (OSError, ValueError, AttributeError):
            continue
        if isinstance(value, str):
            return value
    return None

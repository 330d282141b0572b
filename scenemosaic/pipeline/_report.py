"""The report of a run (``OUT/report.json``): :class:`RunReport`, one shape for rooms and houses.

The driver builds it from the run (:func:`run_report`), writes it, returns it in
:class:`~scenemosaic.pipeline.GenerateResult` and the CLI prints from it; a whole-house run adds
``house`` (its rooms and doorways) and ``rooms`` (each room's own stages, warnings and checks).
"""

from __future__ import annotations

import asyncio
import traceback
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.pipeline._config import config_record
from scenemosaic.pipeline._state import PipelineRun, StageRecord

__all__ = ["HouseSummary", "RoomReport", "RunReport", "RunStatus", "StageReport", "run_report"]

RunStatus = Literal["ok", "degraded", "failed", "interrupted"]
"""How a run ended: ``ok``; ``degraded`` (delivered, but see ``warnings``); ``failed``;
``interrupted`` (stopped by a signal or a cancel: resume it)."""


class StageReport(BaseModel):
    """One stage of a run: its time, status and figures."""

    model_config = ConfigDict(extra="forbid")

    name: str
    seconds: float
    status: str
    """``done``, ``skipped``, ``reused`` (from a checkpoint), ``failed`` or ``interrupted``."""
    objects: int | None = None
    detail: dict[str, Any] = Field(default_factory=dict)


class RoomReport(BaseModel):
    """One room of a whole-house run: its own stages (up to its unit variants) and checks."""

    model_config = ConfigDict(extra="forbid")

    room_type: str | None = None
    objects: int
    seconds: float | None = None
    error: str | None = None
    stages: list[StageReport] = Field(default_factory=list)
    warnings: list[str] = Field(default_factory=list)
    validation: dict[str, Any] | None = None


class HouseSummary(BaseModel):
    """What a whole-house run worked on."""

    model_config = ConfigDict(extra="forbid")

    id: str
    rooms: list[str]
    doorways: int


class RunReport(BaseModel):
    """A run's report: what it was given, how each stage went, what it found and delivered."""

    model_config = ConfigDict(extra="forbid")

    input: str
    config: dict[str, Any]
    status: RunStatus
    error: str | None = None
    failed_stage: str | None = None
    traceback: str | None = None
    """The traceback of an unexpected error (a bug, not bad input)."""
    warnings: list[str] = Field(default_factory=list)
    """What makes the outcome ``degraded``, in words (the console prints the same)."""
    notes: list[str] = Field(default_factory=list)
    """What does not degrade the outcome but should be said (fewer variants than asked for)."""
    total_seconds: float
    objects: int
    categories: list[str]
    variants_written: int
    stages: list[StageReport]
    validation: dict[str, Any] | None = None
    metrics: dict[str, Any] | None = None
    partial_files: list[str] | None = None
    """A failed or stopped run: what it kept of its last good scene (marked partial)."""
    partial_export_error: str | None = None
    house: HouseSummary | None = None
    rooms: dict[str, RoomReport] | None = None
    model: dict[str, Any] | None = None
    """A run that asked a model (not the rules): the model's work over the whole run, per agent
    kind (requests, usable and unusable replies, agent runs by how they were answered, fallback
    reasons, tokens, seconds), the kinds the run gave up, and ``summary``, one line of words
    (``models.RunModel.account``)."""

    @property
    def is_house(self) -> bool:
        """Whether this is the report of a whole-house run."""
        return self.house is not None

    def figures(self) -> dict[str, Any]:
        """The validation's headline figures, the same names for a room and a house (a house adds
        its own: rooms, blocked doors, unreachable rooms, objects across walls, house NAV)."""
        v = self.validation or {}
        if not v:
            return {}
        if self.house is not None:
            return {
                "rooms": len(self.house.rooms),
                "collision pairs": v.get("collision_pairs", 0),
                "out of bounds": v.get("out_of_bounds", 0),
                "tipped": v.get("tipped", 0),
                "fell": v.get("fell", 0),
                "parts moved": v.get("parts_moved", 0),
                "blocked doors": len(v.get("door_blockers") or []),
                "unreachable rooms": len(v.get("unreachable_rooms") or []),
                "across walls": len(v.get("wall_crossings") or []),
                "house NAV": v.get("house_nav"),
            }
        return {
            "collision pairs": len(v.get("collisions", {}).get("pairs", [])),
            "out of bounds": len(v.get("out_of_bounds", {}).get("objects", [])),
            "tipped": len(v.get("tipped", [])),
            "fell": len(v.get("fell", [])),
            "parts moved": len(v.get("parts_moved") or {}),
        }

    def to_json(self) -> dict[str, Any]:
        """The report as ``report.json`` holds it (fields that do not apply are left out)."""
        return self.model_dump(mode="json", exclude_none=False, exclude={k for k in _OPTIONAL if getattr(self, k) is None})


_OPTIONAL = ("partial_files", "partial_export_error", "house", "rooms", "model")
"""Fields ``report.json`` holds only when they apply."""


def _stage(r: StageRecord | dict[str, Any], reused: bool = False) -> StageReport:
    rec = r if isinstance(r, StageRecord) else StageRecord(**r)
    status = "reused" if reused and rec.status == "done" else rec.status
    return StageReport(name=rec.name, seconds=round(rec.seconds, 4), status=status, objects=rec.objects, detail=rec.detail)


def _status(run: PipelineRun, failure: BaseException | None) -> RunStatus:
    if isinstance(failure, asyncio.CancelledError):
        return "interrupted"
    if failure is not None:
        return "failed"
    return "degraded" if run.warnings else "ok"


def _rooms(run: PipelineRun) -> dict[str, RoomReport]:
    house = run.need_house()
    reused = any(r.name == "rooms" and r.status == "reused" for r in run.records)  # so were every room's stages
    out: dict[str, RoomReport] = {}
    for s in house.rooms:
        outcome = run.rooms.get(s.id)
        state = outcome.state if outcome else None
        out[s.id] = RoomReport(
            room_type=s.provenance.room_type,
            objects=len(s.objects),
            seconds=round(outcome.seconds, 3) if outcome else None,
            error=outcome.error if outcome else None,
            stages=[_stage(r, reused) for r in (state.records if state else [])],
            warnings=list(state.warnings) if state else [],
            validation=state.validation if state else None,
        )
    return out


def run_report(run: PipelineRun, total_s: float, failure: BaseException | None) -> RunReport:
    """The report of ``run`` after ``total_s`` seconds, ``failure`` the error that stopped it (if any)."""
    status = _status(run, failure)
    error: str | None = None
    trace: str | None = None
    if status == "interrupted":
        error = "interrupted: the run was stopped (signal or cancel); resume it with --resume"
    elif failure is not None:
        error = f"{type(failure).__name__}: {failure}"
        if not isinstance(failure, SceneMosaicError):  # a bug, not bad input: keep everything for the issue
            trace = "".join(traceback.format_exception(failure))
    made = run.result
    delivered = any(r.name == "export" and r.status == "done" for r in run.records)
    return RunReport(
        input=str(run.input_path),
        config=config_record(run.config) | {"variants_requested": run.config.variants},
        status=status,
        error=error,
        failed_stage=next((r.name for r in run.records if r.status in ("failed", "interrupted")), None),
        traceback=trace,
        warnings=list(run.warnings),
        notes=list(run.notes),
        total_seconds=round(total_s, 4),
        objects=len(made.objects) if made else 0,
        categories=sorted({o.category for o in made.objects}) if made else [],
        variants_written=run.delivered_variants if delivered else 0,
        stages=[_stage(r) for r in run.records],
        validation=run.validation,
        metrics=run.metrics,
        house=HouseSummary(id=run.house.id, rooms=run.house.room_ids, doorways=len(run.house.doorways())) if run.house else None,
        rooms=_rooms(run) if run.house is not None else None,
        model=run.model.account() if run.model is not None else None,
    )

"""One batch job: what a worker needs to run it, the function both executors run, and the skip test."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any, Literal

import structlog
from pydantic import BaseModel, ConfigDict

from scenemosaic import pipeline  # the stages load when a job runs
from scenemosaic._processes import STOP_GRACE_S
from scenemosaic.batch._manifest import BatchJob
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.scene import RunFolder

__all__ = ["STOP_GRACE_S", "JobOutcome", "JobSpec", "aexecute_job", "execute_job", "finished_report"]

log = structlog.get_logger(__name__)

_FINISHED = ("ok", "degraded")
_NOT_COMPARED = ("cache_dir", "variants_requested")
"""Report settings that do not decide a job's results (the hull cache only saves time)."""


class JobSpec(BaseModel):
    """Everything a worker (a local worker process or a Ray task) needs to run one job.

    Plain data: it travels as JSON to a local worker and pickled to a Ray task.
    """

    model_config = ConfigDict(frozen=True)

    job: BatchJob
    out_dir: Path
    """The job's output folder (``OUT/<id>``)."""
    cache_dir: Path | None = None
    """The on-disk hull cache every job of the batch shares (``None``: the default cache folder)."""
    reply_cache: Path | None = None
    """The on-disk model reply cache every job of the batch shares (``models.CachedModel``): a
    job run again after a failure or a kill does not pay for the requests it made before."""
    rate_limit_dir: Path | None = None
    """The folder of the request and token rate buckets every job of the batch shares
    (``models.FileTokenBucket``): a line's ``requests_per_minute`` holds for all workers together."""


class JobOutcome(BaseModel):
    """What a worker reports back about one job."""

    status: Literal["ok", "degraded", "failed", "timeout"]
    variants_written: int = 0
    error: str | None = None
    report_status: str | None = None


def _read_report(out_dir: Path) -> dict[str, Any] | None:
    try:
        data = json.loads(RunFolder(out_dir).report.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _expected(value: Any) -> Any:
    return value if isinstance(value, str | int | float | bool | type(None)) else str(value)


def finished_report(job: BatchJob, out_dir: Path) -> dict[str, Any] | None:
    """The report of an earlier, finished run of this very job in ``out_dir``, else ``None``.

    Finished means ``report.json`` says ``ok`` or ``degraded`` (``degraded`` only counts when
    the job is not ``strict``) and ``base/`` holds the delivered scene or house. The report must name the same
    input and agree on every setting it records (all but the hull cache folder): a folder left
    by another version of the manifest line is not a result of this job.
    """
    report = _read_report(out_dir)
    if report is None or report.get("status") not in _FINISHED:
        return None
    if report["status"] == "degraded" and job.settings.get("strict"):
        return None
    if not RunFolder.is_delivered(RunFolder(out_dir).base):
        return None
    if job.input is not None and report.get("input") != str(job.input):  # a prompt: its text is a setting
        return None
    recorded = report.get("config")
    if not isinstance(recorded, dict):
        return None
    config = job.config()
    for key, value in recorded.items():
        if key in _NOT_COMPARED or not hasattr(config, key):
            continue
        if _expected(getattr(config, key)) != value:
            log.info("batch_job_settings_changed", job=job.id, setting=key, recorded=value)
            return None
    return report


def report_status(out_dir: Path) -> str | None:
    """The ``status`` in a job's ``report.json`` (``interrupted`` for a job stopped at its
    time-out), or ``None`` when it has no readable report."""
    status = (_read_report(out_dir) or {}).get("status")
    return status if isinstance(status, str) else None


def _outcome_from_report(out_dir: Path, error: str | None = None) -> JobOutcome:
    return JobOutcome(status="failed", error=error, report_status=report_status(out_dir))


async def aexecute_job(spec: JobSpec) -> JobOutcome:
    """Run one job with :func:`~scenemosaic.pipeline.agenerate`; errors become a ``failed`` outcome.

    Only a cancel propagates (the pipeline has written its report by then).
    """
    job, out_dir = spec.job, spec.out_dir
    bound = log.bind(job=job.id)
    bound.info("batch_job_started", input=job.label, out=str(out_dir))
    try:
        result = await pipeline.agenerate(job.input, out_dir, job.config(cache_dir=spec.cache_dir, reply_cache=spec.reply_cache, rate_limit_dir=spec.rate_limit_dir))
    except SceneMosaicError as exc:
        bound.warning("batch_job_failed", error=str(exc), error_type=type(exc).__name__)
        return _outcome_from_report(out_dir, f"{type(exc).__name__}: {exc}")
    except Exception as exc:  # a bug: the traceback is in the job's report.json
        stage = (_read_report(out_dir) or {}).get("failed_stage")
        where = f" in stage {stage!r}" if isinstance(stage, str) else ""
        bound.error("batch_job_crashed", error=str(exc), error_type=type(exc).__name__)
        return _outcome_from_report(
            out_dir, f"unexpected {type(exc).__name__}{where}: {exc} (traceback in {RunFolder(out_dir).report})"
        )
    report = result.report
    variants = int(report.get("variants_written", 0))
    if result.status == "degraded" and job.settings.get("strict"):
        warnings = "; ".join(str(w) for w in report.get("warnings", [])[:3])
        return JobOutcome(
            status="failed",
            variants_written=variants,
            error=f"degraded under strict: {warnings}",
            report_status=result.status,
        )
    status: Literal["ok", "degraded"] = "degraded" if result.status == "degraded" else "ok"
    bound.info("batch_job_finished", status=status, variants=variants)
    return JobOutcome(status=status, variants_written=variants, report_status=result.status)


def execute_job(spec: JobSpec) -> JobOutcome:
    """Run one job to its end in this process (the function a Ray task runs)."""
    return asyncio.run(aexecute_job(spec))

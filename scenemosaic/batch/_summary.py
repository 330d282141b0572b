"""What a batch reports: one :class:`JobRecord` per job, gathered in a :class:`BatchSummary`."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, Field

from scenemosaic.scene import write_atomic

__all__ = ["FINAL_STATUSES", "SUMMARY_FILE", "BatchSummary", "JobRecord", "JobStatus"]

SUMMARY_FILE = "batch_summary.json"
"""The summary's file name in the batch's output folder."""

JobStatus = Literal["pending", "running", "ok", "degraded", "failed", "timeout", "skipped"]
"""A job's state. ``pending`` and ``running`` only appear while the batch runs (and in the
summary file of a batch that was stopped); a finished batch lists every job as ``ok``,
``degraded`` (files written, with warnings in its report), ``failed`` (an error, recorded in
``error``), ``timeout`` (stopped at its time-out) or ``skipped`` (a finished result was already there)."""

FINAL_STATUSES: frozenset[str] = frozenset({"ok", "degraded", "failed", "timeout", "skipped"})
"""The statuses a job ends with."""


class JobRecord(BaseModel):
    """One job's entry in the batch summary."""

    id: str
    """The job's id: its folder under the batch's output folder."""
    input: str
    """The input file or folder (absolute), or ``prompt: <text>`` for a job drawn from a prompt."""
    out_dir: str
    """The job's output folder (``OUT/<id>``)."""
    status: JobStatus = "pending"
    wall_s: float = 0.0
    """Seconds the job took in this batch, from its start to its end (``0`` when skipped)."""
    variants_written: int = 0
    """Whole-scene variants the job delivered (``variant_<i>/``); for a skipped job, its earlier run's."""
    scenes_written: int = 0
    """Scenes the job delivered: ``base/`` plus its variants (``0`` when it failed or timed out)."""
    error: str | None = None
    """Why the job failed or timed out, in words."""
    report_status: str | None = None
    """The ``status`` in the job's ``report.json`` (``ok``, ``degraded``, ``failed``, ``interrupted``), when it has one."""


class BatchSummary(BaseModel):
    """The outcome of :func:`~scenemosaic.batch.run_batch`, also written to ``OUT/batch_summary.json``."""

    manifest: str
    out: str
    executor: Literal["local", "ray"]
    workers: int
    timeout_s: float | None
    finished: bool = False
    """``True`` once every job has ended; a summary file that says ``False`` belongs to a stopped batch."""
    wall_s: float = 0.0
    counts: dict[str, int] = Field(default_factory=dict)
    """Jobs per status."""
    scenes_written: int = 0
    """Scenes delivered by the jobs of this batch and the skipped ones (base + variants)."""
    jobs: list[JobRecord] = Field(default_factory=list)

    @property
    def ok(self) -> bool:
        """No job failed or timed out (degraded and skipped jobs count as done)."""
        return not any(job.status in ("failed", "timeout") for job in self.jobs)

    def job(self, job_id: str) -> JobRecord:
        """The record of the job with this id (``KeyError`` when there is none)."""
        for job in self.jobs:
            if job.id == job_id:
                return job
        raise KeyError(job_id)

    def refresh(self) -> None:
        """Recompute ``counts`` and ``scenes_written`` from the job records."""
        self.counts = dict(sorted(Counter(job.status for job in self.jobs).items()))
        self.scenes_written = sum(job.scenes_written for job in self.jobs)

    def write(self, folder: Path) -> Path:
        """Write the summary to ``folder / SUMMARY_FILE`` atomically; returns the path."""
        self.refresh()
        return write_atomic(folder / SUMMARY_FILE, self.model_dump_json(indent=2) + "\n")

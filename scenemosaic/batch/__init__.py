"""Batch generation: many ``generate`` jobs from one JSONL manifest, on this machine or on Ray.

::

    from scenemosaic.batch import run_batch

    summary = run_batch("rooms.jsonl", "out/batch", workers=2, timeout_s=600)
    print(summary.counts)               # {"ok": 6, "skipped": 1}

* :func:`load_manifest` reads and checks a manifest (one JSON object a line: ``input`` or a
  ``prompt``, an optional ``id`` and ``timeout_s``, and ``GenerateConfig`` settings by their field
  names, validated by ``GenerateConfig``); :class:`ManifestError` names every bad line.
* :func:`run_batch` runs the jobs — each in its own worker process (``executor="local"``) or
  as a Ray task (``executor="ray"``) — skips the ones already finished, stops each at its
  time-out, records failures without stopping the others, and writes
  ``OUT/batch_summary.json`` (:class:`BatchSummary`, one :class:`JobRecord` per job) as it goes.
* :func:`execute_job` is the function both executors run for one job (a :class:`JobSpec`).

See ``docs/batch.md``.
"""

from scenemosaic.batch._job import STOP_GRACE_S, JobOutcome, JobSpec, execute_job, finished_report
from scenemosaic.batch._manifest import (
    JOB_SETTINGS,
    LINE_KEYS,
    NOT_IN_MANIFEST,
    BatchJob,
    ManifestError,
    ManifestLine,
    load_manifest,
    sanitize_id,
)
from scenemosaic.batch._ray import RAY_INSTALL_HINT
from scenemosaic.batch._run import BATCH_DIR, RATE_LIMITS, REPLY_CACHE, Executor, ProgressCallback, run_batch
from scenemosaic.batch._summary import FINAL_STATUSES, SUMMARY_FILE, BatchSummary, JobRecord, JobStatus

__all__ = [
    "BATCH_DIR",
    "FINAL_STATUSES",
    "JOB_SETTINGS",
    "LINE_KEYS",
    "NOT_IN_MANIFEST",
    "RATE_LIMITS",
    "RAY_INSTALL_HINT",
    "REPLY_CACHE",
    "STOP_GRACE_S",
    "SUMMARY_FILE",
    "BatchJob",
    "BatchSummary",
    "Executor",
    "JobOutcome",
    "JobRecord",
    "JobSpec",
    "JobStatus",
    "ManifestError",
    "ManifestLine",
    "ProgressCallback",
    "execute_job",
    "finished_report",
    "load_manifest",
    "run_batch",
    "sanitize_id",
]

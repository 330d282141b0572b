"""``run_batch``: every job of a manifest, idempotent, isolated, each with its own time-out."""

from __future__ import annotations

import contextlib
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Literal

import structlog

from scenemosaic.batch._job import JobOutcome, JobSpec, finished_report, report_status
from scenemosaic.batch._local import run_local
from scenemosaic.batch._manifest import BatchJob, load_manifest
from scenemosaic.batch._ray import require_ray, run_ray
from scenemosaic.batch._summary import FINAL_STATUSES, BatchSummary, JobRecord
from scenemosaic.exceptions import UsageError

__all__ = ["BATCH_DIR", "RATE_LIMITS", "REPLY_CACHE", "Executor", "ProgressCallback", "run_batch"]

log = structlog.get_logger(__name__)

Executor = Literal["local", "ray"]
"""Where jobs run: ``local`` worker processes, or ``ray`` tasks."""

ProgressCallback = Callable[[JobRecord], None]
"""Called with a job's record each time its status changes (``running``, then how it ended;
``skipped`` jobs only once). Called in the thread that runs :func:`run_batch`."""

BATCH_DIR = ".batch"
"""The batch's own folder inside its output folder: the lock file and, for the ``local``
executor, one log file per job (``logs/<id>.log``), and the reply cache the jobs share
(:data:`REPLY_CACHE`). Job ids never start with a dot, so it cannot clash with a job folder."""
RATE_LIMITS = "limits"
"""The request and token rate buckets of a batch, ``OUT/.batch/limits`` (``models.FileTokenBucket``):
a manifest line's ``requests_per_minute`` / ``tokens_per_minute`` hold for all workers together,
per model (on every Ray node too when ``OUT`` is on a file system with working POSIX locks)."""
REPLY_CACHE = "replies"
"""The model reply cache of a batch, ``OUT/.batch/replies`` (``models.CachedModel``): a job run
again (after a failure, a time-out or a killed batch) is answered from it for every request an
earlier attempt already paid for, whichever worker or Ray node made it."""


@contextlib.contextmanager
def _exclusive(folder: Path) -> Iterator[None]:
    """Hold the batch lock of ``folder``: two batches writing one output folder would mix their results."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle: IO[str] = open(folder / "lock", "a", encoding="utf-8")  # noqa: SIM115 - held for the whole batch
    except OSError as exc:  # under a file, read-only, no permission: the user's to fix, not a crash
        raise UsageError(f"cannot write the output folder {folder.parent}: {exc.strerror or exc}") from exc
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as exc:
            raise UsageError(f"another batch is writing into {folder.parent}; wait for it or choose another --out") from exc
        yield
    finally:
        handle.close()


def _check_cassettes(jobs: list[BatchJob], workers: int) -> None:
    """Parallel jobs recording into one cassette would overwrite each other's entries."""
    if workers < 2:
        return
    users: dict[Path, list[int]] = defaultdict(list)
    for job in jobs:
        cassette = job.recording_cassette
        if cassette is not None:
            users[cassette].append(job.line)
    for cassette, lines in users.items():
        if len(lines) > 1:
            raise UsageError(
                f"manifest lines {', '.join(map(str, lines))} record into the same cassette {cassette}; parallel "
                "jobs would overwrite each other's entries: give each job its own cassette, or use one worker"
            )


def run_batch(
    manifest: str | Path,
    out: str | Path,
    *,
    executor: Executor = "local",
    workers: int = 1,
    timeout_s: float | None = None,
    cache_dir: str | Path | None = None,
    on_progress: ProgressCallback | None = None,
    log_level: str = "warning",
    index: slice | None = None,
) -> BatchSummary:
    """Run every job of ``manifest``, each writing ``generate``'s output layout into ``out/<id>``.

    ``manifest`` may be a dataset of houses (``.jsonl``/``.jsonl.gz``, one house a line): one job a
    house, ``out/<file stem>-<index>`` (``index``: a range of them; ``batch.dataset_jobs``).

    * The manifest is read and checked first (:func:`~scenemosaic.batch.load_manifest`); a bad
      line raises :class:`~scenemosaic.batch.ManifestError` before any job runs.
    * Idempotent: a job whose folder already holds a finished result of the same input and
      settings (``report.json`` says ``ok`` or ``degraded``) is not run again but recorded as
      ``skipped``; an unfinished or failed one runs again from the start.
    * ``executor="local"`` runs each job in its own worker process, ``"ray"`` as a Ray task
      (``pip install 'scenemosaic[ray]'``); at most ``workers`` jobs run at once.
    * ``timeout_s`` (or a line's own ``timeout_s``) bounds each job's wall time; a job past it
      is stopped and recorded as ``timeout``. A failing job is recorded as ``failed`` with its
      error; neither stops the other jobs.
    * ``cache_dir`` is the hull cache every job shares (default: ``$SCENEMOSAIC_CACHE`` or
      ``~/.cache/scenemosaic`` on each machine).
    * ``log_level`` applies in the workers; with the ``local`` executor each job's log goes to
      ``out/.batch/logs/<id>.log``.

    The summary is written to ``out/batch_summary.json`` at the start and after every change of
    a job's status (atomically), so a stopped batch leaves the record of what finished, and is
    returned. Raises :class:`~scenemosaic.exceptions.UsageError` for bad arguments and
    :class:`~scenemosaic.exceptions.MissingExtraError` when the ``ray`` executor lacks Ray.
    """
    if executor not in ("local", "ray"):
        raise UsageError(f"unknown executor {executor!r}; use 'local' or 'ray'")
    if workers < 1:
        raise UsageError(f"workers must be at least 1, got {workers}")
    if timeout_s is not None and not timeout_s > 0:
        raise UsageError(f"timeout_s must be a positive number of seconds, got {timeout_s}")
    jobs = load_manifest(manifest, index)
    if executor == "ray":
        require_ray()
    _check_cassettes(jobs, workers)
    out_dir = Path(out).expanduser().resolve()
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"--out {out_dir} exists and is not a folder")
    shared_cache = Path(cache_dir).expanduser().resolve() if cache_dir is not None else None
    with _exclusive(out_dir / BATCH_DIR):
        return _run(
            jobs,
            Path(manifest).expanduser().resolve(),
            out_dir,
            executor=executor,
            workers=workers,
            timeout_s=timeout_s,
            cache_dir=shared_cache,
            on_progress=on_progress,
            log_level=log_level,
        )


def _run(
    jobs: list[BatchJob],
    manifest: Path,
    out: Path,
    *,
    executor: Executor,
    workers: int,
    timeout_s: float | None,
    cache_dir: Path | None,
    on_progress: ProgressCallback | None,
    log_level: str,
) -> BatchSummary:
    began = time.monotonic()
    summary = BatchSummary(
        manifest=str(manifest), out=str(out), executor=executor, workers=workers, timeout_s=timeout_s
    )
    records: dict[str, JobRecord] = {}
    todo: list[JobSpec] = []
    for job in jobs:
        job_out = out / job.id
        record = JobRecord(id=job.id, input=job.label, out_dir=str(job_out))
        records[job.id] = record
        summary.jobs.append(record)
        report = finished_report(job, job_out)
        if report is None:
            todo.append(
                JobSpec(
                    job=job,
                    out_dir=job_out,
                    cache_dir=cache_dir,
                    reply_cache=out / BATCH_DIR / REPLY_CACHE,
                    rate_limit_dir=out / BATCH_DIR / RATE_LIMITS,
                )
            )
            continue
        variants = int(report.get("variants_written", 0))
        record.status = "skipped"
        record.variants_written = variants
        record.scenes_written = 1 + variants
        record.report_status = str(report["status"])
    log.info("batch_started", jobs=len(jobs), to_run=len(todo), executor=executor, workers=workers)

    def save() -> None:
        summary.wall_s = round(time.monotonic() - began, 3)
        summary.write(out)

    def changed(record: JobRecord) -> None:
        save()
        if on_progress is not None:
            on_progress(record.model_copy())

    def on_start(spec: JobSpec) -> None:
        records[spec.job.id].status = "running"
        changed(records[spec.job.id])

    def on_finish(spec: JobSpec, outcome: JobOutcome, seconds: float) -> None:
        record = records[spec.job.id]
        record.status = outcome.status
        record.wall_s = round(seconds, 3)
        record.variants_written = outcome.variants_written
        record.scenes_written = 1 + outcome.variants_written if outcome.status in ("ok", "degraded") else 0
        record.error = outcome.error
        record.report_status = outcome.report_status
        if record.report_status is None and outcome.status in ("failed", "timeout"):
            # a job stopped at its time-out wrote its report as it stopped: it says `interrupted`
            record.report_status = report_status(spec.out_dir)
        log.info("batch_job_ended", job=spec.job.id, status=outcome.status, seconds=record.wall_s)
        changed(record)

    out.mkdir(parents=True, exist_ok=True)
    save()
    if on_progress is not None:
        for record in summary.jobs:
            if record.status == "skipped":
                on_progress(record.model_copy())
    try:
        if executor == "ray":
            run_ray(todo, workers=workers, timeout_s=timeout_s, log_level=log_level, on_start=on_start, on_finish=on_finish)
        else:
            run_local(
                todo,
                workers=workers,
                timeout_s=timeout_s,
                log_dir=out / BATCH_DIR / "logs",
                log_level=log_level,
                on_start=on_start,
                on_finish=on_finish,
            )
    finally:
        summary.finished = all(record.status in FINAL_STATUSES for record in summary.jobs)
        save()
    log.info("batch_finished", counts=summary.counts, seconds=summary.wall_s)
    return summary

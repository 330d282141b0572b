"""The stage loop every run goes through: one :class:`Stage` after another over a :class:`PipelineRun`,
each recorded, timed, checkpointed, and the first failure returned (not raised) to the driver."""

from __future__ import annotations

import asyncio
import errno
import time
from collections.abc import Sequence

import structlog

from scenemosaic._logging import flush_logs
from scenemosaic.exceptions import ModelEndpointError, NodeFailedError, OutputSpaceError
from scenemosaic.pipeline._checkpoint import save_checkpoint
from scenemosaic.pipeline._state import PipelineRun, Stage, StageCallback, StageRecord

__all__ = ["as_interruption", "run_stages"]

log = structlog.get_logger(__name__)


def as_interruption(exc: BaseException) -> BaseException:
    """``exc``, or a ``CancelledError`` when the run itself is being cancelled (a signal, a batch
    time-out): a stage's task graph turns the cancel it received into a ``RunCancelledError``
    carrying its partial results, but for the run it is an interruption, not a failure."""
    task = asyncio.current_task()
    if not isinstance(exc, asyncio.CancelledError) and task is not None and task.cancelling():
        interrupted = asyncio.CancelledError()
        interrupted.__cause__ = exc
        return interrupted
    return exc


def setup_error(exc: BaseException) -> BaseException:
    """The user's problem behind a stage's failure, stated as such: the model server's set-up
    error itself when a task-graph node failed on one (the message is the fix in one line), and
    a full disk met by any writer as :class:`OutputSpaceError`; else ``exc``."""
    if isinstance(exc, NodeFailedError) and isinstance(exc.cause, ModelEndpointError):
        return exc.cause
    if isinstance(exc, OSError) and not isinstance(exc, OutputSpaceError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        full = OutputSpaceError(str(exc.filename or "the output folder"), exc.errno)
        full.__cause__ = exc
        return full
    return exc


async def run_stages(
    run: PipelineRun,
    finished: set[str],
    digest: str | None,
    on_stage: StageCallback | None,
    stages: Sequence[Stage],
) -> BaseException | None:
    """Run every stage of ``stages`` (the run's plan, ``pipeline/_plan.py``) not finished before;
    returns the failure that stopped the run, if any."""
    for stage in stages:
        name = stage.name
        if name in finished and name != "export":
            for rec in run.records:
                if rec.name == name and rec.status == "done":
                    rec.status = "reused"
            if on_stage:
                on_stage(name, "reused")
            continue
        rec = StageRecord(name=name)
        # a resumed run's record of this stage (an export done before, a stage stopped) is replaced
        run.records[:] = [r for r in run.records if r.name != name]
        run.records.append(rec)
        if on_stage:
            on_stage(name, "started")
        t0 = time.perf_counter()
        run.stage_log, run.stage_mark = None, run.model.mark() if run.model is not None else 0
        bound = log.bind(stage=name)
        bound.info("stage_started")
        try:
            await stage.run(run, rec)
        except (Exception, asyncio.CancelledError) as raised:
            exc = setup_error(as_interruption(raised))
            rec.seconds = time.perf_counter() - t0
            interrupted = isinstance(exc, asyncio.CancelledError)
            rec.status = "interrupted" if interrupted else "failed"
            rec.detail["error"] = "interrupted" if interrupted else f"{type(exc).__name__}: {exc}"
            _record_usage(run, rec)
            if interrupted:  # a stop the user asked for, not a crash
                bound.warning("stage_interrupted")
            else:
                bound.error("stage_failed", error=str(exc) or type(exc).__name__, error_type=type(exc).__name__)
            if on_stage:
                on_stage(name, "failed")
            return exc
        run.note_hull_failures()
        rec.seconds = time.perf_counter() - t0
        if rec.status == "pending":
            rec.status = "done"
        _record_usage(run, rec)
        rec.objects = len(run.scene.objects) if run.scene is not None else None
        bound.info("stage_finished", seconds=round(rec.seconds, 3), objects=rec.objects)
        flush_logs()  # the stage's folded warnings now, not after the next stage's first event
        await asyncio.to_thread(save_checkpoint, run, digest)
        if on_stage:
            on_stage(name, "done")
    return None


def _record_usage(run: PipelineRun, rec: StageRecord) -> None:
    """A stage that asked the model (:meth:`PipelineRun.asking`) gets its usage: its agents'
    requests, from its agent log (:meth:`PipelineRun.agent_log`); a stage that kept none (a
    house's ``rooms`` stage, whose rooms keep their own), the calls of the run's model since the
    stage began."""
    if "usage" not in rec.detail or run.model is None:
        return
    log = run.stage_log
    rec.detail["usage"] = log.usage_summary() if log is not None else run.model.usage_since(run.stage_mark)



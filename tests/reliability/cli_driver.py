"""Runs the ``scenemosaic`` CLI in this process with one stage made slow or broken, for tests.

Usage: ``python cli_driver.py <stage|-> <sleep|block|raise|-> -- <scenemosaic arguments>`` (a stage
of a room's run or of a whole house's).
``sleep`` makes the named stage wait (10 minutes) before doing its work, so a test can send a
signal while that stage runs; ``block`` makes it wait the same in a worker thread (CPU work a
cancel cannot interrupt, like a long compose); ``raise`` makes it fail with an unexpected
``RuntimeError`` (a stand-in for a bug). Prints ``STAGE-STARTED <name>`` on stderr when the slowed stage begins.
"""

from __future__ import annotations

import asyncio
import sys
import time

from scenemosaic.pipeline import PipelineRun, Stage, StageRecord, _plan


def _patched(stages: tuple[Stage, ...], stage_name: str, action: str) -> tuple[Stage, ...]:
    out = []
    for stage in stages:
        if stage.name != stage_name:
            out.append(stage)
            continue
        original = stage.run

        async def slowed(run: PipelineRun, rec: StageRecord, original=original) -> None:  # type: ignore[no-untyped-def]
            print(f"STAGE-STARTED {stage_name}", file=sys.stderr, flush=True)
            if action == "raise":
                raise RuntimeError("injected failure for a test")
            if action == "block":
                await asyncio.to_thread(time.sleep, 600)
            await asyncio.sleep(600)
            await original(run, rec)

        out.append(Stage(stage.name, slowed))
    return tuple(out)


def main() -> None:
    stage, action, sep, *args = sys.argv[1:]
    assert sep == "--"
    if stage != "-":
        # what the run's plan is made of: a room's stages and a house's (its rooms' workers run unpatched)
        _plan.STAGES = _patched(_plan.STAGES, stage, action)  # type: ignore[misc]
        _plan.HOUSE_STAGES = _patched(_plan.HOUSE_STAGES, stage, action)  # type: ignore[misc]
    from scenemosaic.cli import app

    sys.argv = ["scenemosaic", *args]
    app()


if __name__ == "__main__":
    main()

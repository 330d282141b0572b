"""The ``generate`` pipeline: an explicit list of stages over one run.

:data:`STAGES` lists the stages in order — ``import``, ``assets``, ``structure``, ``stabilize``,
``validate``, ``export`` — each a :class:`Stage` (a name and an async function over a
:class:`PipelineRun`). The method's ``evolve`` and ``compose`` stages are two more entries,
between ``validate`` and ``export``. A failing or stopped stage never loses earlier work: the
last good scene is exported to ``base/``, ``report.json`` records which stage stopped and why,
and a stopped run continues with ``resume=True`` (``--resume``). See ``docs/reliability.md``.
"""

from scenemosaic.pipeline._config import (
    GenerateConfig,
    GenerateResult,
    PipelineRun,
    Stage,
    StageCallback,
    StageRecord,
)
from scenemosaic.pipeline._demo import demo_scene
from scenemosaic.pipeline._run import REPORT_FILE, agenerate, checkpoint_config, generate, run_sync
from scenemosaic.pipeline._stages import DELIVERED_FORMATS, STAGE_NAMES, STAGES, export_base

__all__ = [
    "DELIVERED_FORMATS",
    "REPORT_FILE",
    "STAGES",
    "STAGE_NAMES",
    "GenerateConfig",
    "GenerateResult",
    "PipelineRun",
    "Stage",
    "StageCallback",
    "StageRecord",
    "agenerate",
    "checkpoint_config",
    "demo_scene",
    "export_base",
    "generate",
    "run_sync",
]

"""The ``generate`` pipeline: an explicit list of stages over one run.

:data:`STAGES` lists the stages in order — ``import``, ``assets``, ``structure``, ``stabilize``,
``validate``, ``export`` — each a :class:`Stage` (a name and an async function over a
:class:`PipelineRun`). The method's ``evolve`` and ``compose`` stages are two more entries,
between ``validate`` and ``export``. A failing stage never loses earlier work: the last good
scene is exported to ``base/`` and ``report.json`` records which stage failed and why.
"""

from scenemosaic.pipeline._demo import demo_scene
from scenemosaic.pipeline._run import (
    STAGE_NAMES,
    STAGES,
    GenerateConfig,
    GenerateResult,
    PipelineRun,
    Stage,
    StageRecord,
    agenerate,
    export_base,
    generate,
)

__all__ = [
    "STAGES",
    "STAGE_NAMES",
    "GenerateConfig",
    "GenerateResult",
    "PipelineRun",
    "Stage",
    "StageRecord",
    "agenerate",
    "demo_scene",
    "export_base",
    "generate",
]

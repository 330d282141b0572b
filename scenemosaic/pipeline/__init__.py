"""The ``generate`` pipeline: an explicit list of stages over one run.

:data:`STAGES` lists the stages in order — ``import``, ``assets``, ``structure``, ``stabilize``,
``doors``, ``evolve``, ``compose``, ``validate``, ``evaluate``, ``export`` — each a :class:`Stage` (a name
and an async function over a :class:`PipelineRun`, which carries each stage's result to the
next in memory); :func:`plan` says which stages a run goes through (a room's, with the clutter
stage when asked for, or a whole house's :data:`HOUSE_STAGES`), in one place. The run's settings are one :class:`GenerateConfig`; its output folder is an
``exchange.RunFolder``; its model stack is opened once (``models.open_run_model``). A failing or
stopped stage never loses earlier work: the last good scene is delivered to ``base/``,
``report.json`` records which stage stopped and why, and a stopped run continues with
``resume=True`` (``--resume``) from its checkpoint. See ``docs/architecture.md`` and ``docs/reliability.md``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from scenemosaic.pipeline._config import (
    SETTINGS,
    GenerateConfig,
    Setting,
    SettingsError,
    config_from_record,
    config_record,
    setting_options,
    settings_doc,
    settings_table,
)
from scenemosaic.pipeline._result import GenerateResult
from scenemosaic.pipeline._state import (
    PipelineRun,
    RunSetup,
    Stage,
    StageCallback,
    StageRecord,
    default_deadline_s,
)

if TYPE_CHECKING:
    from scenemosaic.pipeline._checkpoint import checkpoint_config
    from scenemosaic.pipeline._demo import demo_scene
    from scenemosaic.pipeline._plan import HOUSE_STAGE_NAMES, HOUSE_STAGES, Plan, plan
    from scenemosaic.pipeline._report import RunReport
    from scenemosaic.pipeline._run import REPORT_FILE, agenerate, generate, run_sync
    from scenemosaic.pipeline._stages import STAGE_NAMES, STAGES

_LAZY = {
    "HOUSE_STAGES": "_plan",
    "HOUSE_STAGE_NAMES": "_plan",
    "RunReport": "_report",
    "REPORT_FILE": "_run",
    "STAGES": "_stages",
    "STAGE_NAMES": "_stages",
    "agenerate": "_run",
    "checkpoint_config": "_checkpoint",
    "demo_scene": "_demo",
    "generate": "_run",
    "run_sync": "_run",
    "Plan": "_plan",
    "plan": "_plan",
}
"""Names whose modules import the stages' backends (MuJoCo, CoACD): loaded on first use, so the
settings (and the CLI's ``--help``) stay light."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'scenemosaic.pipeline' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"scenemosaic.pipeline.{module}"), name)
    globals()[name] = value
    return value


__all__ = [
    "HOUSE_STAGES",
    "HOUSE_STAGE_NAMES",
    "REPORT_FILE",
    "SETTINGS",
    "STAGES",
    "STAGE_NAMES",
    "GenerateConfig",
    "GenerateResult",
    "PipelineRun",
    "Plan",
    "RunReport",
    "RunSetup",
    "Setting",
    "SettingsError",
    "Stage",
    "StageCallback",
    "StageRecord",
    "agenerate",
    "checkpoint_config",
    "config_from_record",
    "config_record",
    "default_deadline_s",
    "demo_scene",
    "generate",
    "plan",
    "run_sync",
    "setting_options",
    "settings_doc",
    "settings_table",
]

"""scenemosaic: simulation-ready indoor scenes and diverse layout variants from one reference scene.

The names a notebook needs, in one place::

    import scenemosaic as sm

    scene = sm.load_scene("room.json")                    # 3D-FRONT, ProcTHOR, SAM3D, SceneEval or native
    result = sm.generate("room.json", "out/room")         # import → structure → stabilize → evolve → export
    print(sm.format_tree(result.scene))

Everything else lives in the sub-packages, which follow the pipeline: ``scene`` (model, tree,
categories, rooms), ``assets`` (meshes, CoACD hulls), ``render``, ``models`` (the VLM seam,
usage), ``dag`` (task-graph runtime), ``agents`` (the task-agent framework), ``structure``
(the structuring agents), ``physics``, ``evolve`` (the Critic-Actor stage), ``exchange`` (every file format), ``pipeline``.

Names are loaded on first use, so ``import scenemosaic`` stays light (no MuJoCo, no CoACD).
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

# public name -> the sub-package that defines it
_EXPORTS: dict[str, str] = {
    # run the pipeline
    "generate": "scenemosaic.pipeline",
    "agenerate": "scenemosaic.pipeline",
    "GenerateConfig": "scenemosaic.pipeline",
    "GenerateResult": "scenemosaic.pipeline",
    "demo_scene": "scenemosaic.pipeline",
    # read and write scenes
    "load_scene": "scenemosaic.exchange",
    "load_scenes": "scenemosaic.exchange",
    "save_scene": "scenemosaic.exchange",
    "write_scene": "scenemosaic.exchange",
    # the scene
    "Scene": "scenemosaic.scene",
    "SceneObject": "scenemosaic.scene",
    "Pose": "scenemosaic.scene",
    "Room": "scenemosaic.scene",
    "Relation": "scenemosaic.scene",
    "LocalUnit": "scenemosaic.scene",
    "CrossUnitConstraint": "scenemosaic.scene",
    "format_tree": "scenemosaic.scene",
    # stages as functions
    "structure_scene": "scenemosaic.structure",
    "stabilize_scene": "scenemosaic.physics",
    "validate_scene": "scenemosaic.physics",
    "evolve_scene": "scenemosaic.evolve",
    # agents and plugins
    "TaskAgent": "scenemosaic.agents",
    "AgentOutput": "scenemosaic.agents",
    "SceneState": "scenemosaic.agents",
    "DEFAULT_AGENTS": "scenemosaic.structure",
    # models
    "Model": "scenemosaic.models",
    "ModelSettings": "scenemosaic.models",
    "RulesModel": "scenemosaic.models",
    "OpenAIChatModel": "scenemosaic.models",
    "ReplayModel": "scenemosaic.models",
    "FunctionModel": "scenemosaic.models",
    "parse_model": "scenemosaic.models",
    # errors (the whole tree is in scenemosaic.exceptions)
    "SceneMosaicError": "scenemosaic.exceptions",
    "UsageError": "scenemosaic.exceptions",
    "ImportFormatError": "scenemosaic.exceptions",
    "SceneValidationError": "scenemosaic.exceptions",
    "AgentOutputError": "scenemosaic.exceptions",
    "ModelError": "scenemosaic.exceptions",
    "PhysicsError": "scenemosaic.exceptions",
    "ExpressionError": "scenemosaic.exceptions",
    "RunError": "scenemosaic.exceptions",
    # logging
    "configure_logging": "scenemosaic._logging",
}

__all__ = [
    "DEFAULT_AGENTS",
    "AgentOutput",
    "AgentOutputError",
    "CrossUnitConstraint",
    "ExpressionError",
    "FunctionModel",
    "GenerateConfig",
    "GenerateResult",
    "ImportFormatError",
    "LocalUnit",
    "Model",
    "ModelError",
    "ModelSettings",
    "OpenAIChatModel",
    "PhysicsError",
    "Pose",
    "Relation",
    "ReplayModel",
    "Room",
    "RulesModel",
    "RunError",
    "Scene",
    "SceneMosaicError",
    "SceneObject",
    "SceneState",
    "SceneValidationError",
    "TaskAgent",
    "UsageError",
    "__version__",
    "agenerate",
    "configure_logging",
    "demo_scene",
    "evolve_scene",
    "format_tree",
    "generate",
    "load_scene",
    "load_scenes",
    "parse_model",
    "save_scene",
    "stabilize_scene",
    "structure_scene",
    "validate_scene",
    "write_scene",
]

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time names load lazily
    from scenemosaic._logging import configure_logging
    from scenemosaic.agents import AgentOutput, SceneState, TaskAgent
    from scenemosaic.evolve import evolve_scene
    from scenemosaic.exceptions import (
        AgentOutputError,
        ExpressionError,
        ImportFormatError,
        ModelError,
        PhysicsError,
        RunError,
        SceneMosaicError,
        SceneValidationError,
        UsageError,
    )
    from scenemosaic.exchange import load_scene, load_scenes, save_scene, write_scene
    from scenemosaic.models import (
        FunctionModel,
        Model,
        ModelSettings,
        OpenAIChatModel,
        ReplayModel,
        RulesModel,
        parse_model,
    )
    from scenemosaic.physics import stabilize_scene, validate_scene
    from scenemosaic.pipeline import GenerateConfig, GenerateResult, agenerate, demo_scene, generate
    from scenemosaic.scene import (
        CrossUnitConstraint,
        LocalUnit,
        Pose,
        Relation,
        Room,
        Scene,
        SceneObject,
        format_tree,
    )
    from scenemosaic.structure import DEFAULT_AGENTS, structure_scene


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'scenemosaic' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    _show_scenes_as_plans()
    return value


def _lazy_plan_png(scene: Any) -> bytes:
    from scenemosaic.render import plan_png  # registers plan_png itself for the next scene

    return plan_png(scene)


def _show_scenes_as_plans() -> None:
    """Once the scene package is loaded, a notebook shows a ``Scene`` (or a ``House``) as its plan
    even when nothing has imported the render package yet (``sm.demo_scene()``): a stand-in
    renderer that imports it on first display."""
    scene = sys.modules.get("scenemosaic.scene")
    if scene is not None and "scenemosaic.render" not in sys.modules:
        scene.register_plan_renderer(_lazy_plan_png)


def __dir__() -> list[str]:
    return sorted(__all__)


if set(__all__) != {"__version__", *_EXPORTS}:  # pragma: no cover - a guard for maintainers
    raise ImportError("scenemosaic.__all__ and _EXPORTS disagree")


def _default_logging() -> None:
    import structlog

    from scenemosaic._logging import configure_logging

    if not structlog.is_configured():  # structlog's own default prints debug lines to stdout
        configure_logging("warning")


_SILENT_MODULES = frozenset({"scenemosaic.cli", "scenemosaic.exceptions", "scenemosaic._logging"})
"""The package's modules that log nothing when imported and import nothing that does."""


class _LoggingDefaults:
    """Sets the package's logging defaults (:func:`_default_logging`) just before the first of its
    modules that may log is imported (every module that logs imports structlog), instead of at
    ``import scenemosaic``: structlog, which loads asyncio and rich's tracebacks with it, then
    loads only with the modules that use it, and ``scenemosaic --help`` goes without it. A finder
    on ``sys.meta_path`` that finds nothing itself; inert once it has fired."""

    fired = False

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> None:
        if not self.fired and fullname.startswith("scenemosaic.") and fullname not in _SILENT_MODULES:
            self.fired = True  # first: the imports below pass through here too
            _default_logging()
        return None


if not any(isinstance(finder, _LoggingDefaults) for finder in sys.meta_path):
    sys.meta_path.insert(0, _LoggingDefaults())

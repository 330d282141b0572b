"""What a ``generate`` run is told: :class:`GenerateConfig`, its settings declared and validated in one place.

Each field of :class:`GenerateConfig` carries a :class:`Setting` marker: its group, whether it
decides the run's results (recorded in ``report.json`` and the checkpoint, compared by
``--resume`` and by a batch's skip test), its ``generate`` flag (or why there is none) and whether
a batch manifest line takes it (or why not). The CLI, the batch manifest, the run record and the
docs (``docs/settings.md``) all read these markers; none of them keeps its own list.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeAlias

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    ValidatorFunctionWrapHandler,
    WrapValidator,
    model_validator,
)

from scenemosaic.exceptions import UsageError
from scenemosaic.models import Model

if TYPE_CHECKING:
    from pydantic import ModelWrapValidatorHandler

    from scenemosaic.agents import SceneState, TaskAgent
    from scenemosaic.evolve import LayoutRule
    from scenemosaic.perception import Reconstructor, Segmenter

__all__ = [
    "SETTINGS",
    "GenerateConfig",
    "Setting",
    "SettingGroup",
    "SettingsError",
    "check_config",
    "config_from_record",
    "config_record",
    "deciding_settings",
]

SettingGroup = Literal["input", "perception", "model", "evolution", "limits", "run"]
"""The groups of :class:`GenerateConfig`'s settings (``docs/settings.md``)."""


@dataclass(frozen=True)
class Setting:
    """What a :class:`GenerateConfig` field is, declared on the field (an ``Annotated`` marker).

    ``group`` sorts the setting (``docs/settings.md``). ``decides``: the setting decides the
    run's results, so it is recorded (``report.json``'s ``config``, the checkpoint) and a resumed
    run or a skipped batch job must agree on it. ``recorded``: a folder or file recorded and
    restored by ``--resume`` but not compared (the same data may sit at another path). ``path``:
    a folder or file, relative to the manifest in a manifest line. ``flag`` is the ``generate``
    option, else ``no_flag`` says why there is none; ``no_manifest`` says why a manifest line
    does not take the setting (``None``: it does).
    """

    group: SettingGroup
    decides: bool = False
    recorded: bool = False
    path: bool = False
    flag: str | None = None
    no_flag: str | None = None
    no_manifest: str | None = None

    def __post_init__(self) -> None:
        if (self.flag is None) == (self.no_flag is None):
            raise ValueError("a setting has a flag, or says why it has none (not both)")


class SettingsError(UsageError):
    """Settings of a run are wrong: ``problems`` holds ``(field, message)`` pairs, one per problem
    (``field`` is ``None`` for a problem of several fields together)."""

    def __init__(self, problems: Sequence[tuple[str | None, str]]) -> None:
        self.problems = list(problems)
        super().__init__("bad settings: " + "; ".join(self.describe()))

    def describe(self, name: Callable[[str], str] | None = None) -> list[str]:
        """One line per problem, each naming its setting through ``name`` (default: ``'field'``)."""
        label = name or (lambda field: repr(field))
        return [f"{label(field)}: {message}" if field else message for field, message in self.problems]


def _problems(error: ValidationError) -> list[tuple[str | None, str]]:
    out: list[tuple[str | None, str]] = []
    for item in error.errors():
        field = str(item["loc"][0]) if item["loc"] else None
        message = str(item["msg"]).removeprefix("Value error, ")
        if item["type"] == "extra_forbidden":
            message = "not a setting of generate"
        out.append((field, message))
    return out


def _priors(value: Path | None) -> Path | None:
    """A priors folder must be usable now: a configuration error fails before the run starts."""
    if value is not None:
        from scenemosaic.scene import priors_problem

        problem = priors_problem(value)
        if problem is not None:
            raise ValueError(f"not a usable priors folder ({problem[:200]})")
    return value


def _segmenter(value: Any) -> Any:
    if isinstance(value, str):
        return value
    from scenemosaic.perception import Segmenter

    if isinstance(value, Segmenter):
        return value
    raise ValueError(f"expected a segmenter name or a Segmenter, got {type(value).__name__}")


def _reconstructor(value: Any) -> Any:
    if isinstance(value, str):
        return value
    from scenemosaic.perception import Reconstructor

    if isinstance(value, Reconstructor):
        return value
    raise ValueError(f"expected a reconstructor name or a Reconstructor, got {type(value).__name__}")


def _agents(value: Any) -> Any:
    if value is None:
        return None
    from scenemosaic.agents import TaskAgent

    if isinstance(value, str | bytes) or not isinstance(value, Sequence):
        raise ValueError(f"expected a sequence of TaskAgent, got {type(value).__name__}")
    bad = [type(a).__name__ for a in value if not isinstance(a, TaskAgent)]
    if bad:
        raise ValueError(f"expected TaskAgent instances, got {', '.join(bad)}")
    return value


def _layout_rules(value: Any) -> Any:
    if isinstance(value, str | bytes) or not isinstance(value, Sequence):
        raise ValueError(f"expected a sequence of layout rules (callables), got {type(value).__name__}")
    bad = [type(r).__name__ for r in value if not callable(r)]
    if bad:
        raise ValueError(f"layout rules must be callables, got {', '.join(bad)}")
    return value


def _number_as_given(value: Any, handler: ValidatorFunctionWrapHandler, info: ValidationInfo) -> Any:
    """A whole number given for a float setting from Python stays an ``int``, so the run's record
    (``report.json``) holds what the caller wrote; from JSON (context ``json_numbers``: a manifest)
    it becomes a ``float``, as a manifest always gave it."""
    checked = handler(value)
    if type(value) is int and not (info.context or {}).get("json_numbers"):
        return value
    return checked


Number = Annotated[float, WrapValidator(_number_as_given)]

if TYPE_CHECKING:
    SegmenterChoice: TypeAlias = str | Segmenter
    ReconstructorChoice: TypeAlias = str | Reconstructor
    AgentList: TypeAlias = Sequence[TaskAgent[SceneState, Any, Any]] | None
    LayoutRules: TypeAlias = Sequence[LayoutRule]
else:  # checked at run time without importing perception, agents or evolve up front
    SegmenterChoice = Annotated[Any, AfterValidator(_segmenter)]
    ReconstructorChoice = Annotated[Any, AfterValidator(_reconstructor)]
    AgentList = Annotated[Any, AfterValidator(_agents)]
    LayoutRules = Annotated[Any, AfterValidator(_layout_rules)]

_OBJECTS = "Python objects: no JSON form"
_BATCH_OWNS = "the batch sets it for every job"

INPUT_SIZE_LIMITS_MB: dict[str, float] = {"scene": 256.0, "image": 64.0}
"""Largest input file of each kind a run reads unless ``--max-input-mb`` says otherwise (MB of
10^6 bytes): a scene document (JSON, any format: the largest shipped house is under 10 MB, and
parsing takes a few times the file's size in memory) and a photograph (its pixels are checked
separately)."""


class GenerateConfig(BaseModel):
    """Settings of one ``generate`` run: a frozen, validated model.

    ``GenerateConfig(model="rules", seed=0)``; a wrong value raises :class:`SettingsError` (a
    :class:`~scenemosaic.exceptions.UsageError`) naming every bad setting. Types are strict
    (``"5"`` is not a number); folders and files may be given as strings. Each field's
    :class:`Setting` marker (see :data:`SETTINGS`) says its group, whether it decides the results,
    its ``generate`` flag and whether a batch manifest line takes it (``docs/settings.md``).
    """

    model_config = ConfigDict(frozen=True, strict=True, extra="forbid", arbitrary_types_allowed=True)

    # -- input -------------------------------------------------------------------------------
    format: Annotated[str, Setting("input", decides=True, flag="--format")] = "auto"
    """Input format (``auto`` or a registered reader: ``native``, ``front3d``, ``procthor``,
    ``holodeck``, ``sam3d``, ``sceneeval``; or ``image``, which ``auto`` picks for ``.png``,
    ``.jpg``... inputs: the image front end, ``docs/perception.md``)."""
    room: Annotated[str | None, Setting("input", decides=True, flag="--room")] = None
    """Room id to take from a multi-room house file."""
    asset_dir: Annotated[
        Path | None, Field(strict=False), Setting("input", recorded=True, path=True, flag="--asset-dir")
    ] = None
    """Folder of asset meshes a SceneEval input names by ``assetId`` (default: ``assets/`` beside it)."""
    max_input_mb: Annotated[Number | None, Field(gt=0), Setting("input", flag="--max-input-mb")] = None
    """Largest input file the run reads, in MB (``--max-input-mb``); ``None``: the limit of the
    input's kind, :data:`INPUT_SIZE_LIMITS_MB` (a scene document, a photograph). A larger file is
    refused before it is read (exit 2)."""
    priors_dir: Annotated[
        Path | None,
        Field(strict=False),
        AfterValidator(_priors),
        Setting("input", recorded=True, path=True, flag="--priors"),
    ] = None
    """ProcTHOR priors folder (receptacles, placement annotations, asset groups) replacing the
    priors shipped with the package."""

    # -- perception (a photograph or a text prompt) ----------------------------------------
    detections: Annotated[
        Path | None, Field(strict=False), Setting("perception", recorded=True, path=True, flag="--detections")
    ] = None
    """Object detections of a photograph input (``--detections``): COCO (``bbox`` = [x, y, w, h])
    or an inventory JSON. The offline ``rules`` model needs them; a vision model takes them as hints."""
    segmenter: Annotated[SegmenterChoice, Setting("perception", decides=True, flag="--segmenter")] = "auto"
    """How a photograph's objects are cut out (``--segmenter``): ``auto``, ``grabcut``, ``box``,
    ``sam3``, an ``http://`` segmentation server, or a :class:`~scenemosaic.perception.Segmenter`."""
    reconstructor: Annotated[ReconstructorChoice, Setting("perception", decides=True, flag="--reconstructor")] = "auto"
    """How a photograph's objects are lifted to 3D (``--reconstructor``): ``auto``, ``box-lifter``,
    ``sam3d[:pipeline.yaml]``, an ``http://`` server, or a :class:`~scenemosaic.perception.Reconstructor`."""
    hfov_deg: Annotated[Number | None, Field(ge=5, le=170), Setting("perception", decides=True, flag="--hfov")] = None
    """Horizontal field of view of a photograph input, degrees, 5 to 170 (``--hfov``); ``None``: from
    its EXIF focal length, else :data:`~scenemosaic.perception.DEFAULT_HFOV_DEG`."""
    camera_height_m: Annotated[Number | None, Field(gt=0.1, le=10), Setting("perception", decides=True, flag="--camera-height")] = None
    """The camera's height above the floor for a photograph input, metres (``--camera-height``),
    when it is known (a tripod, a phone's AR session); ``None``: read from the objects' usual
    sizes. A single view fixes the room only up to one scale, and this sets it."""
    prompt: Annotated[str | None, Setting("perception", decides=True, flag="--prompt")] = None
    """Draw the room from this text first (``--prompt``): the model's images endpoint
    (``/images/generations``) makes ``OUT/prompt.png``, which then goes through the image front
    end like a photograph. Give no input with it."""
    image_model: Annotated[str | None, Setting("perception", decides=True, flag="--image-model")] = None
    """The images endpoint's model name (``--image-model``); ``None``: the chat model's name."""
    image_size: Annotated[str, Setting("perception", decides=True, flag="--image-size")] = "1024x1024"
    """Size asked of the images endpoint (``--image-size``)."""

    # -- model -------------------------------------------------------------------------------
    model: Annotated[str | Model, Setting("model", decides=True, flag="--model")] = "rules"
    """Model string (``rules``, ``openai:<model>[@<base_url>]``, ``replay:<cassette.json>``) or a
    :class:`~scenemosaic.models.Model` instance, which the caller keeps ownership of (not closed here)."""
    vision: Annotated[bool | None, Setting("model", decides=True, flag="--vision")] = None
    """Force the model's vision setting (``False`` for text-only local servers); ``None`` keeps its default."""
    solver_fallback: Annotated[bool, Setting("model", decides=True, flag="--solver-fallback")] = True
    """When a real model's answers stay unusable (after retries and repairs), use the agent's rule
    solver and note it in the report (the run is then ``degraded``), instead of failing the run.
    Configuration errors still fail."""
    fallback: Annotated[Literal["transient", "rules"], Setting("model", decides=True, flag="--fallback")] = "transient"
    """Which model failures the rule solvers answer for, with ``solver_fallback`` on (``--fallback``):
    ``transient`` (default) — time-outs, 429, 5xx and unusable replies, while a model server that
    cannot serve the run (nothing listening, unknown host, key refused, no such model) stops it at
    once with exit 2 and the fix; ``rules`` — those too, so the run completes ``degraded`` on the
    rule solvers (``docs/reliability.md``)."""
    reply_cache: Annotated[
        Path | None,
        Field(strict=False),
        Setting("model", path=True, flag="--reply-cache", no_manifest=f"{_BATCH_OWNS} (OUT/.batch/replies, shared)"),
    ] = None
    """Folder of the on-disk model reply cache (``--reply-cache``; ``models.CachedModel``): an
    equal request is answered from it at no cost, so a re-run or retried job never pays twice.
    ``None``: no cache (the rules model makes no requests either way)."""
    agents: Annotated[AgentList, Setting("model", no_flag=_OBJECTS, no_manifest=_OBJECTS)] = None
    """Structuring agents the manager may schedule; default
    :data:`~scenemosaic.structure.DEFAULT_AGENTS`. Add a plugin with
    ``agents=[*DEFAULT_AGENTS, MyAgent()]``."""

    # -- evolution ---------------------------------------------------------------------------
    variants: Annotated[int, Field(ge=0), Setting("evolution", decides=True, flag="--variants")] = 0
    """Number of diverse whole-scene variants to deliver (m), 0 or more. Above 0, the evolve stage
    grows each unit's structurally different variants (archetypes) beside the refined original, and
    the compose stage selects m diverse valid combinations of them (dynamic max-min greedy on the
    novelty distance), written as ``variant_1/`` ... ``variant_m/`` beside ``base/``; fewer when
    the pool holds fewer distinct valid ones (the report says so). Needs ``evolve``."""
    evolve: Annotated[bool, Setting("evolution", decides=True, flag="--evolve")] = True
    """Run the evolve stage (the Critic-Actor refinement of every unit); ``--no-evolve`` delivers
    the stabilized scene as it is. Skipped too when ``stabilize`` is off (it refines a stabilized scene)."""
    evolve_rounds: Annotated[int, Field(ge=1), Setting("evolution", decides=True, flag="--rounds")] = 8
    """Round cap of each layout's Critic-Actor loop, 1 or more (``--rounds``; ``scenemosaic.evolve.MAX_ROUNDS``)."""
    save_views: Annotated[bool, Setting("evolution", decides=True, flag="--save-views")] = False
    """Write every unit view the critic sees, per round, as PNG under ``evolve/`` (``--save-views``)."""
    layout_rules: Annotated[LayoutRules, Setting("evolution", no_flag=_OBJECTS, no_manifest=_OBJECTS)] = ()
    """Plugin rules of the evolve stage's critic (:data:`~scenemosaic.evolve.LayoutRule`): each
    sees every layout of every unit, and its findings join the built-in ones (``docs/plugins.md``)."""

    # -- limits ------------------------------------------------------------------------------
    request_timeout_s: Annotated[
        Number | None, Field(gt=0), Setting("limits", decides=True, flag="--request-timeout")
    ] = None
    """Time-out of one model request in seconds, above 0 (``--request-timeout``); ``None`` keeps the
    model's own. See ``docs/reliability.md`` for the precedence of time-outs."""
    deadline_s: Annotated[Number | None, Field(gt=0), Setting("limits", decides=True, flag="--deadline")] = None
    """Wall-clock budget for all model requests of the run, in seconds, above 0 (``--deadline``):
    once it has passed, agents answer with their rule solvers (the run is ``degraded``)."""
    max_concurrency: Annotated[int | None, Field(ge=1), Setting("limits", flag="--max-concurrency")] = None
    """Most model requests in flight at once, 1 or more (``--max-concurrency``); more wait in the
    client, so a request's time-out measures the server's work, not a queue. ``None``: the server's
    slot count when it reports one (llama.cpp), else no limit beyond the task graph's."""
    requests_per_minute: Annotated[Number | None, Field(gt=0), Setting("limits", flag="--rpm")] = None
    """Client-side request rate for the model, above 0 (``--rpm``; ``models.RateLimiter``)."""
    tokens_per_minute: Annotated[Number | None, Field(gt=0), Setting("limits", flag="--tpm")] = None
    """Client-side token rate for the model, above 0 (``--tpm``)."""
    rate_limit_dir: Annotated[
        Path | None,
        Field(strict=False),
        Setting(
            "limits",
            path=True,
            no_flag="the batch's business: its workers share one budget (OUT/.batch/limits)",
            no_manifest=f"{_BATCH_OWNS} (OUT/.batch/limits, shared)",
        ),
    ] = None
    """Keep the request and token rates in files in this folder (``models.FileTokenBucket``), so
    every run using the folder shares one budget per model: the workers of a batch
    (``OUT/.batch/limits``). ``None``: the rates hold within this run only."""

    # -- run ---------------------------------------------------------------------------------
    seed: Annotated[int, Setting("run", decides=True, flag="--seed")] = 0
    """Run seed; every random choice derives from it, so equal inputs give identical files."""
    stabilize: Annotated[bool, Setting("run", decides=True, flag="--stabilize")] = True
    """Run the physics stabilization stage (``--no-stabilize`` skips it, and with it evolve)."""
    strict: Annotated[bool, Setting("run", flag="--strict")] = False
    """Treat a ``degraded`` outcome (unresolved collisions, fallen objects, solver fallbacks) as a
    failure: the CLI exits 1 (``--strict``). The files are written either way."""
    overwrite: Annotated[
        bool, Setting("run", flag="--overwrite", no_manifest=f"{_BATCH_OWNS}: on (a batch owns its job folders)")
    ] = False
    """Allow writing into an output folder that holds the results of another input."""
    resume: Annotated[
        bool,
        Setting(
            "run", flag="--resume", no_manifest=f"{_BATCH_OWNS}: off (a finished job is skipped, an unfinished one starts again)"
        ),
    ] = False
    """Continue a stopped run in the same output folder: finished stages (and finished agents of
    the structuring stage) are reused from the run's checkpoints (``--resume OUT``, which takes
    the input and the settings from the checkpoint)."""
    restart_stale: Annotated[
        bool, Setting("run", flag="--restart-stale", no_manifest=f"{_BATCH_OWNS}: off (a batch never resumes)")
    ] = False
    """With ``resume``: when the checkpoint is stale (the input's content or a setting that decides
    the results changed since the stopped run), start the run over instead of refusing
    (``--restart-stale``). Without it such a resume is refused with exit 2."""
    room_workers: Annotated[int | None, Field(ge=1), Setting("run", flag="--room-workers")] = None
    """Processes that work on a house's rooms at once, 1 or more (``--room-workers``; a house input
    only, ``docs/houses.md``). ``None``: one per CPU core, at most one per room. With 1, or with a
    model other than ``rules`` (one model stack serves every room) or Python-object settings, the
    rooms run concurrently in this process instead. The results do not depend on it."""
    cache_dir: Annotated[
        Path | None,
        Field(strict=False),
        Setting("run", recorded=True, path=True, flag="--cache-dir", no_manifest=f"{_BATCH_OWNS} (the batch's --cache-dir)"),
    ] = None
    """Hull cache folder (``--cache-dir``); default ``$SCENEMOSAIC_CACHE`` or ``~/.cache/scenemosaic``."""

    @model_validator(mode="wrap")
    @classmethod
    def _validated_in_one_place(cls, data: Any, handler: ModelWrapValidatorHandler[GenerateConfig]) -> GenerateConfig:
        """Every check of the settings: the field constraints, then those of several fields together.
        Raises :class:`SettingsError` (a ``UsageError``, never a pydantic ``ValidationError``)."""
        try:
            config = handler(data)
        except ValidationError as exc:
            raise SettingsError(_problems(exc)) from None
        problems: list[tuple[str | None, str]] = []
        if config.variants > 0 and not config.evolve:
            problems.append((None, "variants come from the evolve stage: drop --no-evolve (\"evolve\": false), or ask for 0 variants"))
        if config.prompt is not None and not config.prompt.strip():
            problems.append(("prompt", "the text prompt is empty"))
        if problems:
            raise SettingsError(problems)
        return config


def _settings() -> Mapping[str, Setting]:
    out: dict[str, Setting] = {}
    for name, info in GenerateConfig.model_fields.items():
        marks = [m for m in info.metadata if isinstance(m, Setting)]
        if len(marks) != 1:  # pragma: no cover - a guard for maintainers
            raise TypeError(f"GenerateConfig.{name} needs exactly one Setting marker")
        out[name] = marks[0]
    return MappingProxyType(out)


SETTINGS: Mapping[str, Setting] = _settings()
"""Every :class:`GenerateConfig` field's :class:`Setting` marker, by field name, in declaration order."""


def deciding_settings() -> tuple[str, ...]:
    """The names of the settings that decide a run's results (``Setting.decides``)."""
    return tuple(name for name, s in SETTINGS.items() if s.decides)


def _json_value(value: Any) -> Any:
    return value if isinstance(value, str | int | float | bool | type(None)) else getattr(value, "name", str(value))


def config_record(config: GenerateConfig) -> dict[str, Any]:
    """The JSON-ready record of a run's settings (``report.json``'s ``config``, the checkpoint):
    every deciding setting (an object by its ``name``), then the recorded folders and files as
    strings."""
    out: dict[str, Any] = {name: _json_value(getattr(config, name)) for name, s in SETTINGS.items() if s.decides}
    for name, s in SETTINGS.items():
        if s.recorded:
            value = getattr(config, name)
            out[name] = str(value) if value is not None else None
    return out


def config_from_record(record: Mapping[str, Any], **overrides: Any) -> GenerateConfig:
    """The settings a :func:`config_record` holds (keys that are not recorded settings are
    ignored), with ``overrides`` on top; validated like any other."""
    kwargs: dict[str, Any] = {k: v for k, v in record.items() if k in SETTINGS and SETTINGS[k].decides}
    for name, s in SETTINGS.items():
        if s.recorded and record.get(name):
            kwargs[name] = Path(record[name])
    return GenerateConfig(**(kwargs | overrides))


def check_config(config: GenerateConfig) -> None:
    """Check ``config`` again (one built with ``model_construct`` skipped the checks).

    Raises :class:`SettingsError`.
    """
    GenerateConfig.model_validate({name: getattr(config, name) for name in SETTINGS})

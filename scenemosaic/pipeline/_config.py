"""What a ``generate`` run is told: :class:`GenerateConfig`, its settings declared and validated in one place.

Each field of :class:`GenerateConfig` carries a :class:`Setting` marker: its group, whether it
decides the run's results (recorded in ``report.json`` and the checkpoint, compared by
``--resume`` and by a batch's skip test), its ``generate`` flag (or why there is none) and whether
a batch manifest line takes it (or why not). The CLI, the batch manifest, the run record and the
docs (``docs/settings.md``) all read these markers; none of them keeps its own list.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType, UnionType
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeAlias, Union, get_args, get_origin

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    ValidatorFunctionWrapHandler,
    WrapValidator,
    model_validator,
)

from scenemosaic.exceptions import UsageError
from scenemosaic.models import DEFAULT_UNUSABLE_REPLIES, Model

if TYPE_CHECKING:
    from pydantic import ModelWrapValidatorHandler

    from scenemosaic.agents import SceneState, TaskAgent
    from scenemosaic.evolve import LayoutRule
    from scenemosaic.perception import Reconstructor, Segmenter

__all__ = [
    "SETTINGS",
    "SETTINGS_TABLE_BEGIN",
    "SETTINGS_TABLE_END",
    "GenerateConfig",
    "Setting",
    "SettingGroup",
    "SettingOption",
    "SettingsError",
    "check_config",
    "config_from_record",
    "config_record",
    "deciding_settings",
    "setting_bounds",
    "setting_options",
    "settings_doc",
    "settings_table",
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


def _annotations(value: Path | None) -> Path | None:
    """An annotations file must be readable now: a configuration error fails before the run starts."""
    if value is not None:
        from scenemosaic.exceptions import ImportFormatError
        from scenemosaic.exchange import load_asset_annotations

        try:
            load_asset_annotations(value)
        except ImportFormatError as exc:
            raise ValueError(f"not usable asset annotations ({str(exc)[:200]})") from exc
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


def _seconds_or_word(value: Any) -> Any:
    """A number written as text (the command line's ``--deadline 300``) as a number; a word as it is."""
    if isinstance(value, str) and value.strip().lower() != "none":
        try:
            return float(value)
        except ValueError:
            return value
    return value.strip().lower() if isinstance(value, str) else value

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
    its ``generate`` flag and whether a batch manifest line takes it (``docs/settings.md``). Each
    field's docstring is its ``description``; its first sentence is the ``generate`` option's help
    (:func:`setting_options`).
    """

    model_config = ConfigDict(
        frozen=True, strict=True, extra="forbid", arbitrary_types_allowed=True, use_attribute_docstrings=True
    )

    # -- input -------------------------------------------------------------------------------
    format: Annotated[str, Setting("input", decides=True, flag="--format")] = "auto"
    """Input format: ``auto`` or a registered reader (``native``, ``front3d``, ``procthor``,
    ``holodeck``, ``sam3d``, ``sceneeval``), or ``image``. ``auto`` picks ``image`` for a ``.png``
    or ``.jpg`` input: the image front end (``docs/perception.md``)."""
    room: Annotated[str | None, Setting("input", decides=True, flag="--room")] = None
    """Take one room of a multi-room house, by its id (such as ``room|3``); without it the whole
    house is generated (``docs/houses.md``)."""
    asset_dir: Annotated[
        Path | None, Field(strict=False), Setting("input", recorded=True, path=True, flag="--asset-dir")
    ] = None
    """Folder of the ``<assetId>.glb`` meshes a SceneEval input names (default: ``assets/`` beside
    the input)."""
    index: Annotated[int | None, Field(ge=0), Setting("input", decides=True, flag="--index")] = None
    """Which house of a dataset input (a ``.jsonl``/``.jsonl.gz`` file, one house a line, as
    ProcTHOR-10k ships) is generated, counting from 0 (``docs/batch.md`` runs a whole dataset)."""
    max_input_mb: Annotated[Number | None, Field(gt=0), Setting("input", flag="--max-input-mb")] = None
    """Largest input file the run reads, in MB (default: 256 for a scene file, 64 for a
    photograph). A larger file is refused before it is read (exit 2); ``None`` takes the limit of
    the input's kind from :data:`INPUT_SIZE_LIMITS_MB`."""
    allow_orphans: Annotated[bool, Setting("input", decides=True, flag="--allow-orphans")] = False
    """Read a house whose objects lie outside every room, or whose doors open onto rooms it does
    not hold (a room's record is missing), putting each in the nearest room. Off by default: such
    a house is refused with exit 2, naming the objects and doors. On, the run goes on, says so on
    the console and ends ``degraded`` with that reason first (``docs/importers.md``)."""
    priors_dir: Annotated[
        Path | None,
        Field(strict=False),
        AfterValidator(_priors),
        Setting("input", recorded=True, path=True, flag="--priors"),
    ] = None
    """ProcTHOR priors folder (receptacles, placement annotations, asset groups) replacing the
    priors shipped with the package."""
    asset_annotations: Annotated[
        Path | None,
        Field(strict=False),
        AfterValidator(_annotations),
        Setting("input", recorded=True, path=True, flag="--asset-annotations"),
    ] = None
    """Sizes, by asset id, of assets the asset database lacks (Objaverse's annotations JSON).
    Laid over the database for the Objaverse ids of a Holodeck or ProcTHOR-Objaverse house, or a
    fork's own assets: objathor's ``thor_metadata.assetMetadata.boundingBox`` entries (``.json``
    or ``.json.gz``), or any JSON of ``boundingBox`` entries by asset id (``docs/importers.md``)."""

    # -- perception (a photograph or a text prompt) ----------------------------------------
    detections: Annotated[
        Path | None, Field(strict=False), Setting("perception", recorded=True, path=True, flag="--detections")
    ] = None
    """A photograph's object boxes: COCO JSON (``bbox`` = [x, y, w, h]) or an inventory JSON
    (needed with the ``rules`` model). A vision model takes them as hints."""
    segmenter: Annotated[SegmenterChoice, Setting("perception", decides=True, flag="--segmenter")] = "auto"
    """A photograph's segmenter: ``auto``, ``grabcut``, ``box``, ``sam3`` or a segmentation server
    (``http://HOST:PORT/segment``). From Python, a :class:`~scenemosaic.perception.Segmenter` too."""
    reconstructor: Annotated[ReconstructorChoice, Setting("perception", decides=True, flag="--reconstructor")] = "auto"
    """A photograph's 3D lifter: ``auto``, ``box-lifter``, ``sam3d[:pipeline.yaml]`` or a
    reconstruction server (``http://HOST:PORT/reconstruct``). From Python, a
    :class:`~scenemosaic.perception.Reconstructor` too."""
    hfov_deg: Annotated[Number | None, Field(ge=5, le=170), Setting("perception", decides=True, flag="--hfov")] = None
    """A photograph's horizontal field of view in degrees (default: from its EXIF focal length,
    else 60). The fallback is :data:`~scenemosaic.perception.DEFAULT_HFOV_DEG`."""
    camera_height_m: Annotated[Number | None, Field(gt=0.1, le=10), Setting("perception", decides=True, flag="--camera-height")] = None
    """A photograph's camera height above the floor in metres, when it is known: a tripod, a
    phone's AR session (default: read from the objects' usual sizes). A single view fixes the room
    only up to one scale, and this sets it."""
    prompt: Annotated[str | None, Setting("perception", decides=True, flag="--prompt")] = None
    """Draw the room from this text first, instead of an input. The model's images endpoint
    (``/images/generations``) makes ``OUT/prompt.png``, which then goes through the image front
    end like a photograph."""
    image_model: Annotated[str | None, Setting("perception", decides=True, flag="--image-model")] = None
    """The images endpoint's model (default: the chat model's name)."""
    image_size: Annotated[str, Setting("perception", decides=True, flag="--image-size")] = "1024x1024"
    """Size asked of the images endpoint."""

    # -- model -------------------------------------------------------------------------------
    model: Annotated[str | Model, Setting("model", decides=True, flag="--model")] = "rules"
    """The model: ``rules``, ``openai:<model>[@<base_url>]`` or ``replay:<cassette.json>``. From
    Python, a :class:`~scenemosaic.models.Model` instance too, which the caller keeps ownership of
    (it is not closed here)."""
    vision: Annotated[bool | None, Setting("model", decides=True, flag="--vision")] = None
    """Send images to the model (off for text-only servers; default: the model's own setting)."""
    solver_fallback: Annotated[bool, Setting("model", decides=True, flag="--solver-fallback")] = True
    """Use an agent's rule solver when the model's answers stay unusable after retries and
    repairs (default), or fail the run. A fallback is noted in the report and the run is then
    ``degraded``; configuration errors still fail."""
    fallback: Annotated[Literal["transient", "rules"], Setting("model", decides=True, flag="--fallback")] = "transient"
    """Which model failures the rule solvers answer for: ``transient`` (time-outs, 429, 5xx,
    unusable replies) or ``rules`` (a model server that cannot serve the run too). With
    ``transient`` such a server (nothing listening, unknown host, key refused, no such model) stops
    the run at once with exit 2 and the fix; with ``rules`` the run completes ``degraded`` on the
    rule solvers (``docs/reliability.md``). Either needs ``solver_fallback`` on."""
    unusable_replies: Annotated[int, Field(ge=0), Setting("model", decides=True, flag="--unusable-replies")] = (
        DEFAULT_UNUSABLE_REPLIES
    )
    """Unusable replies of one agent kind in a row after which the run stops asking the model for it.
    A reply is unusable when it is not JSON, breaks the schema, is cut off or is refused by the
    agent's checks; the kind's agents then answer with their rule solvers, said once
    (``models.QualityBreaker``). 0: keep asking whatever comes back. Needs ``solver_fallback``; the
    rules model asks nothing."""
    reply_cache: Annotated[
        Path | None,
        Field(strict=False),
        Setting("model", path=True, flag="--reply-cache", no_manifest=f"{_BATCH_OWNS} (OUT/.batch/replies, shared)"),
    ] = None
    """Folder of an on-disk model reply cache: equal requests are answered from it at no cost.
    A re-run or retried job never pays twice (``models.CachedModel``); ``None``: no cache (the
    rules model makes no requests either way)."""
    agents: Annotated[AgentList, Setting("model", no_flag=_OBJECTS, no_manifest=_OBJECTS)] = None
    """Structuring agents the manager may schedule; default
    :data:`~scenemosaic.structure.DEFAULT_AGENTS`. Add a plugin with
    ``agents=[*DEFAULT_AGENTS, MyAgent()]``."""

    # -- evolution ---------------------------------------------------------------------------
    variants: Annotated[int, Field(ge=0), Setting("evolution", decides=True, flag="--variants")] = 0
    """Number of diverse whole-scene variants to deliver (m); above 0, the evolve stage also grows
    unit variants. Those are each unit's structurally different variants (archetypes) beside the
    refined original, and the compose stage selects m diverse valid combinations of them (dynamic
    max-min greedy on the novelty distance), written as ``variant_1/`` ... ``variant_m/`` beside
    ``base/``; fewer when the pool holds fewer distinct valid ones (the report says so). Needs
    ``evolve``."""
    evolve: Annotated[bool, Setting("evolution", decides=True, flag="--evolve")] = True
    """Refine every unit through the evolve stage's Critic-Actor loop (default on). Off
    (``--no-evolve``) delivers the stabilized scene as it is; skipped too when ``stabilize`` is
    off (it refines a stabilized scene)."""
    evolve_rounds: Annotated[int, Field(ge=1), Setting("evolution", decides=True, flag="--rounds")] = 8
    """Round cap of each layout's Critic-Actor loop. The default is
    ``scenemosaic.evolve.MAX_ROUNDS``."""
    save_views: Annotated[bool, Setting("evolution", decides=True, flag="--save-views")] = False
    """Write every unit view the critic sees, per round, as PNG under ``OUT/evolve/``."""
    layout_rules: Annotated[LayoutRules, Setting("evolution", no_flag=_OBJECTS, no_manifest=_OBJECTS)] = ()
    """Plugin rules of the evolve stage's critic (:data:`~scenemosaic.evolve.LayoutRule`): each
    sees every layout of every unit, and its findings join the built-in ones (``docs/plugins.md``)."""
    clutter: Annotated[Literal["keep", "vary", "fill"], Setting("evolution", decides=True, flag="--clutter")] = "keep"
    """What becomes of a room's small objects (a book, a mug, a plate): ``keep``, ``vary`` or
    ``fill`` (``docs/clutter.md``). ``keep`` (default): the input's, as the evolution left them;
    the run and its files are those of a run without this setting. ``vary``: in every variant
    they move between the receptacles their type may use, their counts per receptacle change
    within the source's range and some become another asset of their type and size; needs
    variants. ``fill``: receptacles emptier than the ProcTHOR priors' typical density first get
    objects drawn from the priors for their type and the room's kind, in the base and every
    variant, which then also vary. Every object added or moved is packed, settled in MuJoCo with
    its unit, and kept only when it rests."""
    clutter_density: Annotated[
        Number, Field(gt=0, le=40), Setting("evolution", decides=True, flag="--clutter-density")
    ] = 10.0
    """Small objects per square metre of receptacle surface (a top, a shelf, a drawer) that
    ``fill`` places. The default, 10, lays sixteen things on a 1.6 square metre dining table and
    two or three on a nightstand or a shelf board: about three small objects per piece of
    furniture in the shipped rooms. The packing stops earlier on a surface with no free place
    left; a receptacle type that holds fewer than three objects in the priors (a chair) is filled
    to its share of this, and none takes more than four times its typical count (at least six).
    Only ``fill`` reads it."""

    # -- limits ------------------------------------------------------------------------------
    request_timeout_s: Annotated[
        Number | None, Field(gt=0), Setting("limits", decides=True, flag="--request-timeout")
    ] = None
    """Seconds one model request may take (default: the model's own). See
    ``docs/reliability.md`` for the precedence of time-outs."""
    deadline_s: Annotated[
        Number | Literal["none"] | None, BeforeValidator(_seconds_or_word), Setting("limits", decides=True, flag="--deadline")
    ] = None
    """Seconds all model requests of the run may take (above 0); then agents use their rule solvers.
    Once this wall-clock budget has passed, the run is ``degraded``. Unset, a run with a model gets
    60 s plus 10 s per object of its input (``pipeline.default_deadline_s``; the report's model
    detail says which); ``none``: no deadline, wait for every reply. The rules model asks nothing."""
    max_concurrency: Annotated[int | None, Field(ge=1), Setting("limits", flag="--max-concurrency")] = None
    """Most model requests in flight at once (default: the server's slots when it says). More wait
    in the client, so a request's time-out measures the server's work, not a queue; a server that
    reports no slot count (llama.cpp reports one) gets no limit beyond the task graph's."""
    requests_per_minute: Annotated[Number | None, Field(gt=0), Setting("limits", flag="--rpm")] = None
    """Most model requests per minute (client side: ``models.RateLimiter``)."""
    tokens_per_minute: Annotated[Number | None, Field(gt=0), Setting("limits", flag="--tpm")] = None
    """Most model tokens per minute (client side)."""
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
    """Run seed. Every random choice derives from it, so equal inputs give identical files."""
    open_state: Annotated[
        Literal["closed", "open", "random"] | None, Setting("run", decides=True, flag="--open-state")
    ] = None
    """The pose drawers, doors and lids are delivered in: ``closed``, ``open`` or ``random`` (drawn
    from ``seed``). Unset (default), the furniture is closed and the rooms' doors stand open (the
    doorways passable); ``closed`` shuts the rooms' doors too; ``open`` puts each part at its upper
    joint limit (a room's door as far as it swings clear), ``random`` somewhere in its range, each
    only as far as its path is free of other objects and walls. Every export places the parts so
    and what stands in a drawer comes out with it; the joints' limits stay 0 (closed) to open, and
    validation settles the world as delivered, its parts open (``docs/articulation.md``)."""
    stabilize: Annotated[bool, Setting("run", decides=True, flag="--stabilize")] = True
    """Run the physics stabilization (default on); off skips evolve too."""
    strict: Annotated[bool, Setting("run", flag="--strict")] = False
    """Treat a degraded result (unresolved collisions, fallen objects, solver fallbacks) as a
    failure: the CLI exits 1. The files are written either way."""
    overwrite: Annotated[
        bool, Setting("run", flag="--overwrite", no_manifest=f"{_BATCH_OWNS}: on (a batch owns its job folders)")
    ] = False
    """Replace an output folder that holds another input's results."""
    resume: Annotated[
        bool,
        Setting(
            "run", flag="--resume", no_manifest=f"{_BATCH_OWNS}: off (a finished job is skipped, an unfinished one starts again)"
        ),
    ] = False
    """Continue the stopped run in this output folder (INPUT and settings come from it). Its
    finished stages (and the finished agents of the structuring stage) are reused from the run's
    checkpoints; the flag takes the folder (``--resume OUT``)."""
    restart_stale: Annotated[
        bool, Setting("run", flag="--restart-stale", no_manifest=f"{_BATCH_OWNS}: off (a batch never resumes)")
    ] = False
    """With ``--resume``: when the input or a setting changed since the stopped run, start over
    instead of refusing. The checkpoint is stale when the input's content or a setting that
    decides the results changed; without this such a resume is refused with exit 2."""
    room_workers: Annotated[int | None, Field(ge=1), Setting("run", flag="--room-workers")] = None
    """Processes for a house's rooms (default: one per core, at most one per room). A house input
    only (``docs/houses.md``). With 1, or with a
    model other than ``rules`` (one model stack serves every room) or Python-object settings, the
    rooms run concurrently in this process instead. The results do not depend on it."""
    cache_dir: Annotated[
        Path | None,
        Field(strict=False),
        Setting("run", recorded=True, path=True, flag="--cache-dir", no_manifest=f"{_BATCH_OWNS} (the batch's --cache-dir)"),
    ] = None
    """Hull cache folder (default: ``$SCENEMOSAIC_CACHE`` or ``~/.cache/scenemosaic``)."""

    @property
    def hull_cache_dir(self) -> Path | None:
        """The folder of the run's CoACD hull cache (``cache_dir/hulls``; ``None``: the default cache)."""
        return self.cache_dir / "hulls" if self.cache_dir else None

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
        if isinstance(config.deadline_s, float | int) and not config.deadline_s > 0:
            problems.append(("deadline_s", f"the deadline must be above 0 seconds (or none), got {config.deadline_s:g}"))
        if config.clutter == "vary" and config.variants == 0:
            problems.append(("clutter", "vary changes the variants' small objects: ask for variants (--variants N)"))
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


# -- the settings as the CLI and the docs show them ------------------------------------------------
# Derived from the fields alone (type, default, constraints, docstring, marker): ``scenemosaic
# generate`` builds its options from :func:`setting_options` and ``docs/settings.md`` holds
# :func:`settings_table`, so neither restates a default, a bound or a help text.

_ROLE = re.compile(r":[a-z]+:`(~?)([^`<]*?)\s*(?:<[^>]*>)?`")
_LITERAL = re.compile(r"``(.+?)``")


@dataclass(frozen=True)
class SettingOption:
    """A setting's ``generate`` option, derived from its :class:`GenerateConfig` field.

    ``decls``: the option's declaration (``--evolve/--no-evolve`` for a switch: a bool that is on
    or unset by default; else the flag). ``kind``: what the option parses (``bool``, ``int``,
    ``float``, ``str`` or ``Path``); ``choices``: a ``Literal`` field's values (shown; checked by
    :class:`GenerateConfig` with the other settings). ``help``: plain text, the first sentence of
    the field's docstring, then its bounds in brackets (:func:`setting_bounds`).
    """

    field: str
    flag: str
    decls: str
    kind: type
    default: Any
    choices: tuple[str, ...]
    help: str
    group: SettingGroup

    @property
    def switch(self) -> bool:
        """The option is ``--x/--no-x``."""
        return "/" in self.decls


def _members(annotation: Any) -> list[Any]:
    """The types a field's annotation allows, ``Annotated`` unwrapped, ``None`` left out."""
    members = get_args(annotation) if get_origin(annotation) in (Union, UnionType) else (annotation,)
    out = []
    for member in members:
        while get_origin(member) is Annotated:
            member = get_args(member)[0]
        if member is not type(None):
            out.append(member)
    return out


def _first_sentence(text: str) -> str:
    """The first sentence of a docstring: up to the first full stop outside parentheses and
    literals that ends a word."""
    depth, literal, i = 0, False, 0
    while i < len(text):
        if text.startswith("``", i):
            literal, i = not literal, i + 2
            continue
        char = text[i]
        if not literal:
            depth += (char == "(") - (char == ")")
            if char == "." and depth == 0 and (i + 1 == len(text) or text[i + 1].isspace()) and text[i - 1] != ".":
                return text[: i + 1]
        i += 1
    return text


def _rst(text: str, literal: Callable[[str], str]) -> str:
    """reStructuredText of a docstring as one line: roles by their (short) name, literals through ``literal``."""
    text = _ROLE.sub(lambda m: literal(m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2)), text)
    return " ".join(_LITERAL.sub(lambda m: literal(m.group(1)), text).split())


def _number(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def setting_bounds(field: str) -> str:
    """A numeric setting's bounds in words (``1 or more``, ``above 0``, ``5 to 170``), from the
    field's constraints; ``""`` for a setting without bounds."""
    bounds: dict[str, Any] = {}
    for mark in GenerateConfig.model_fields[field].metadata:
        for key in ("gt", "ge", "lt", "le"):
            if getattr(mark, key, None) is not None:
                bounds[key] = getattr(mark, key)
    if "ge" in bounds and "le" in bounds:
        return f"{_number(bounds['ge'])} to {_number(bounds['le'])}"
    words = {"gt": "above {}", "ge": "{} or more", "lt": "below {}", "le": "at most {}"}
    return ", ".join(words[key].format(_number(value)) for key, value in bounds.items())


def setting_options() -> tuple[SettingOption, ...]:
    """The ``generate`` option of every setting that has a flag, in declaration order."""
    out = []
    for name, setting in SETTINGS.items():
        if setting.flag is None:
            continue
        info = GenerateConfig.model_fields[name]
        (first, *others) = _members(info.annotation)
        choices: tuple[str, ...] = get_args(first) if get_origin(first) is Literal else ()
        kind = first if first in (bool, int, float, str, Path) else str
        if kind in (int, float) and any(get_origin(m) is Literal for m in others):
            kind = str  # a number or a word (``--deadline none``): the settings parse it
        switch = kind is bool and info.default is not False
        decls = f"{setting.flag}/--no-{setting.flag.removeprefix('--')}" if switch else setting.flag
        summary = _rst(_first_sentence(info.description or ""), str).removesuffix(".")
        bounds = setting_bounds(name)
        text = f"{summary}. [{bounds}]" if bounds else f"{summary}."
        out.append(SettingOption(name, setting.flag, decls, kind, info.default, choices, text, setting.group))
    return tuple(out)


SETTINGS_TABLE_BEGIN = "<!-- settings table: made by scenemosaic.pipeline._config.settings_table(), from GenerateConfig's fields -->"
SETTINGS_TABLE_END = "<!-- end of the settings table -->"


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def settings_table() -> str:
    """``docs/settings.md``'s table of every setting, rendered from the fields: group, whether it
    decides the results, flag, whether a manifest line takes it, default, values and docstring."""
    options = {option.field: option for option in setting_options()}
    rows = [
        "| field | group | decides | flag | manifest | default | values | description |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, setting in SETTINGS.items():
        info = GenerateConfig.model_fields[name]
        option = options.get(name)
        values = setting_bounds(name)
        if option is not None and option.choices:
            values = " or ".join(f"`{choice}`" for choice in option.choices)
        elif option is not None and option.switch:
            values = f"off: `--no-{option.flag.removeprefix('--')}`"
        text = _rst(info.description or "", lambda s: f"`{s}`")
        if setting.no_flag:
            text += f" *No flag*: {setting.no_flag}."
        if setting.no_manifest:
            text += f" *Not in a manifest*: {setting.no_manifest}."
        cells = [
            f"`{name}`",
            setting.group,
            "yes" if setting.decides else "recorded" if setting.recorded else "",
            f"`{setting.flag}`" if setting.flag else "—",
            "—" if setting.no_manifest else "yes",
            f"`{info.default!r}`",
            values,
            text,
        ]
        rows.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    return "\n".join(rows) + "\n"


def settings_doc(text: str) -> str:
    """``text`` (``docs/settings.md``) with the part between :data:`SETTINGS_TABLE_BEGIN` and
    :data:`SETTINGS_TABLE_END` replaced by :func:`settings_table`; the prose around it is kept."""
    head, begin, rest = text.partition(SETTINGS_TABLE_BEGIN)
    _, end, tail = rest.partition(SETTINGS_TABLE_END)
    if not begin or not end:
        raise ValueError(f"the settings table's markers are missing: {SETTINGS_TABLE_BEGIN} ... {SETTINGS_TABLE_END}")
    return f"{head}{begin}\n{settings_table()}{end}{tail}"

"""What one ``generate`` run carries from stage to stage (:class:`PipelineRun`) and how a stage is declared."""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from pydantic import BaseModel, ConfigDict

from scenemosaic.exceptions import StageOrderError
from scenemosaic.pipeline._config import GenerateConfig
from scenemosaic.scene import House, Pose, RunFolder, Scene

if TYPE_CHECKING:
    from scenemosaic._processes import WorkerPool
    from scenemosaic.agents import AgentLog, AgentPolicy, FallbackRecord
    from scenemosaic.assets import HullCache
    from scenemosaic.dag import FileRunStore
    from scenemosaic.models import RunModel
    from scenemosaic.physics import ObjectShape

__all__ = [
    "DeliveriesAhead",
    "PipelineRun",
    "RoomOutcome",
    "RunCheckpoint",
    "RunSetup",
    "Stage",
    "StageCallback",
    "StageFn",
    "StageRecord",
    "UnitLayoutRecord",
    "default_deadline_s",
    "open_model",
    "rooms_of",
]

StageCallback = Callable[[str, str], None]
"""Called as ``callback(stage_name, status)``: first ``"planned"`` for every stage of the run's plan,
in order (before any stage starts: a progress display's total), then ``"started"``, ``"done"``,
``"reused"`` or ``"failed"`` as each runs."""

UnitLayoutRecord = tuple[tuple[str, ...], tuple[Mapping[str, Pose], ...]]
"""One unit's kept layouts for composition: their ids (the refined original first) and their
anchor-frame poses."""


class RunCheckpoint(BaseModel):
    """A run's state after its last finished stage: what the checkpoint keeps of a :class:`PipelineRun`
    (``pipeline/_checkpoint.py`` saves and loads it)."""

    model_config = ConfigDict(arbitrary_types_allowed=False)

    scene: Scene | None = None
    records: list[dict[str, Any]] = []
    layouts: dict[str, tuple[list[str], list[dict[str, Pose]]]] | None = None
    dropped_layouts: list[str] = []
    variants: list[Scene] = []
    validation: dict[str, Any] | None = None
    metrics: dict[str, Any] | None = None
    warnings: list[str] = []
    notes: list[str] = []
    fallbacks: list[dict[str, str | bool]] = []
    house: House | None = None
    rooms: dict[str, RoomOutcome] = {}
    house_variants: list[House] = []
    variant_checks: list[dict[str, Any]] = []


class RoomOutcome(BaseModel):
    """What one room's run of a house left for the house: its state, or why it has none (sent
    back over the pipe from a worker process, kept in the house's checkpoint)."""

    room_id: str
    state: RunCheckpoint | None = None
    error: str | None = None
    error_type: str | None = None
    seconds: float = 0.0


RunCheckpoint.model_rebuild()


class DeliveriesAhead(Protocol):
    """Deliveries a run started before its export stage (a house run's, ``pipeline/_deliveries.py``):
    the driver stops those the export stage did not wait for."""

    async def stop(self) -> None:
        """Stop every delivery still running and drop what it wrote."""


@dataclass
class StageRecord:
    """Timing and outcome of one pipeline stage, as written to ``report.json``."""

    name: str
    seconds: float = 0.0
    status: str = "pending"
    """``pending``, ``done``, ``skipped``, ``reused`` (from a checkpoint), ``failed`` or ``interrupted``."""
    objects: int | None = None
    detail: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class RunSetup:
    """What a run is given, fixed for its whole length: its input, output folder, settings and the
    folder the input's mesh paths start from (a room of a house: its scene, in memory)."""

    input_path: Path
    folder: RunFolder
    config: GenerateConfig
    base_dir: Path
    """Folder relative mesh paths of the input start from."""
    source: Scene | None = None
    """The scene to start from, given in memory (a room of a house run): the import stage takes
    it instead of reading ``input_path``."""
    room_stages: tuple[Stage, ...] = ()
    """A house run: the stages each of its rooms goes through (the plan's, ``pipeline/_plan.py``)."""

    @property
    def is_house(self) -> bool:
        """Whether the run's plan runs its input as a whole house (its rooms have stages of their own)."""
        return bool(self.room_stages)


@dataclass
class PipelineRun:
    """One run: what it is given (:attr:`setup`, fixed), the services its stages share (the model
    stack, the run store, the hull cache: opened on first use) and what its stages have made so
    far (the scene or house, variants, checks, warnings), in memory. Files are outputs (and the
    checkpoint, for ``--resume``). A stage reads a result an earlier stage must have left through
    :meth:`need_scene` / :meth:`need_house`."""

    setup: RunSetup
    scene: Scene | None = None
    """The scene as the last finished stage left it."""
    house: House | None = None
    """A whole-house run: the house as the last finished stage left it (its rooms: ``pipeline/_house.py``)."""
    rooms: dict[str, RoomOutcome] = field(default_factory=dict)
    """A whole-house run: each room's run, by room id, as the ``rooms`` stage left it."""
    house_variants: list[House] = field(default_factory=list)
    """A whole-house run: compose's whole-house variants, in selection order."""
    variant_checks: list[dict[str, Any]] = field(default_factory=list)
    """A whole-house run: the house checks of each variant, as compose measured them."""
    records: list[StageRecord] = field(default_factory=list)
    layouts: dict[str, UnitLayoutRecord] | None = None
    """Evolve's kept unit layouts, by anchor id: what compose combines."""
    dropped_layouts: list[str] = field(default_factory=list)
    """Unit variants local filtering dropped (``unit/layout: why``)."""
    variants: list[Scene] = field(default_factory=list)
    """Compose's whole-scene variants, in selection order."""
    validation: dict[str, Any] | None = None
    """The validate stage's full report (JSON-ready), written to ``report.json``."""
    metrics: dict[str, Any] | None = None
    """The evaluate stage's metrics (base, variants, diversity), written to ``report.json``."""
    fallbacks: list[FallbackRecord] = field(default_factory=list)
    """Agents answered by their rule solvers instead of the model."""
    warnings: list[str] = field(default_factory=list)
    """What makes the outcome ``degraded``, in words."""
    notes: list[str] = field(default_factory=list)
    """What the user should know that does not degrade the outcome (fewer variants than asked for), in words."""
    model: RunModel | None = None
    """The run's one model stack (``models.open_run_model``), once a stage has asked for it."""
    store: FileRunStore | None = None
    """The run's store in ``.checkpoint/``: the stages' state and the structuring agents' outputs."""
    stage_log: AgentLog | None = None
    """The current stage's collector of agent results (:meth:`agent_log`): its usage, fallbacks and
    per-agent breakdown; the driver starts each stage without one."""
    stage_mark: int = 0
    """The model usage reading when the current stage began: the usage of a stage that asked the
    model without an agent log of its own (a house's ``rooms`` stage) is the difference."""
    hull_cache: HullCache | None = None
    """The run's CoACD hull cache, opened on first use and shared by the stages."""
    started: float = field(default_factory=time.monotonic)
    """``time.monotonic()`` when the run began: the run deadline counts from here."""
    workers: WorkerPool | None = None
    """A house run's worker processes (``pipeline/_workers.py``), started by the first stage that
    needs them and kept for the next (the rooms' workers deliver the houses); closed when the run ends."""
    deliveries: DeliveriesAhead | None = None
    """A house run's deliveries started ahead of its export stage (``pipeline/_deliveries.py``, into
    :attr:`RunFolder.staged`), in its worker processes; the export stage waits for them."""

    @property
    def input_path(self) -> Path:
        """The run's input."""
        return self.setup.input_path

    @property
    def folder(self) -> RunFolder:
        """The run's output folder and its paths."""
        return self.setup.folder

    @property
    def config(self) -> GenerateConfig:
        """The run's settings."""
        return self.setup.config

    @property
    def base_dir(self) -> Path:
        """Folder relative mesh paths of the input start from."""
        return self.setup.base_dir

    @property
    def source(self) -> Scene | None:
        """The scene given in memory (a room of a house run), if any."""
        return self.setup.source

    def need_scene(self) -> Scene:
        """The scene the stages before this one made (raises :class:`StageOrderError` when none did)."""
        if self.scene is None:
            raise StageOrderError("this stage needs the scene an earlier stage makes (import); none did")
        return self.scene

    def need_store(self) -> FileRunStore:
        """The run's store (the driver opens it before the first stage)."""
        if self.store is None:
            raise StageOrderError("this stage needs the run store the driver opens; none was opened")
        return self.store

    def need_house(self) -> House:
        """The house of a whole-house run (raises :class:`StageOrderError` when no stage made one)."""
        if self.house is None:
            raise StageOrderError("this stage needs the house the house import makes; none did")
        return self.house

    @property
    def result(self) -> Scene | House | None:
        """What the run has made so far: the house of a whole-house run, else the scene."""
        return self.house if self.house is not None else self.scene

    def need_world(self) -> Scene | House:
        """What the run works on as a whole, as the stages before this one left it: the house of a
        whole-house run, else the scene (raises :class:`StageOrderError` when no stage made one)."""
        world = self.result
        if world is None:
            raise StageOrderError("this stage needs the scene or house an earlier stage makes (import); none did")
        return world

    @property
    def world_variants(self) -> list[Scene] | list[House]:
        """Compose's whole variants, in selection order: whole houses for a house run, else scenes."""
        return self.house_variants if self.house is not None else self.variants

    @property
    def delivered_variants(self) -> int:
        """How many variants the run has (whole houses for a house run)."""
        return len(self.world_variants)

    @property
    def out_dir(self) -> Path:
        """The output folder."""
        return self.folder.root

    @property
    def policy(self) -> AgentPolicy:
        """How agents treat the model's answers in this run."""
        from scenemosaic.agents import AgentPolicy

        quality = self.model.quality if self.model is not None else None
        return AgentPolicy(
            solver_fallback=self.config.solver_fallback, endpoint_fallback=self.config.fallback == "rules", quality=quality
        )

    async def asking(self, rec: StageRecord) -> RunModel:
        """The run's one model stack, for a stage that asks the model: opened by the first stage
        that needs it and kept for the rest of the run (the driver closes it). The stage's record
        gets the model's description now and its usage when the stage ends."""
        if self.model is None:
            world = self.result
            self.model = await open_model(self.config, self.started, len(world.objects) if world is not None else None)
        rec.detail.update(self.model.detail)
        rec.detail["usage"] = {}  # filled by the driver: the stage's agent log's usage (else between its marks)
        return self.model

    def agent_log(self) -> AgentLog:
        """The current stage's collector of agent results, made on first use: a stage hands it to
        the agents' runner (``structure_scene``, ``evolve_scene``, ``perceive``) and reads its
        fallbacks and per-agent breakdown from it; the driver records its usage as the stage's."""
        from scenemosaic.agents import AgentLog

        if self.stage_log is None:
            self.stage_log = AgentLog()
        return self.stage_log

    @property
    def uses_rules(self) -> bool:
        """Whether the run's model is the offline rules model (which makes no requests)."""
        spec = self.config.model
        return spec == "rules" if isinstance(spec, str) else spec.uses_rule_solvers

    def cache(self) -> HullCache:
        """The run's hull cache (opened on first use: a resumed run skips the assets stage)."""
        from scenemosaic.assets import HullCache

        if self.hull_cache is None:
            self.hull_cache = HullCache(self.config.hull_cache_dir)
        return self.hull_cache

    def shapes(self, scene: Scene) -> dict[str, ObjectShape]:
        """Every object's collision shape (hulls from the cache)."""
        from scenemosaic.physics import object_shape

        cache = self.cache()
        return {o.id: object_shape(o, self.base_dir, cache=cache) for o in scene.objects}

    def note_hull_failures(self) -> None:
        """Record the CoACD decompositions of the run's hull cache that failed since the last call
        (one warning, naming how many and why: their collision shapes are single convex hulls)."""
        if self.hull_cache is None:
            return
        failures = self.hull_cache.take_failures()
        if failures:
            reasons = "; ".join(dict.fromkeys(failures))
            self.warnings.append(
                f"CoACD failed on {len(failures)} mesh(es), whose collision shapes are single convex hulls: {reasons[:300]}"
            )

    def note_fallbacks(self, fallbacks: list[FallbackRecord], where: str = "", width: int = 160) -> None:
        """Record agents answered by their rule solvers (each a warning: the run is ``degraded``); the
        agents of a kind the run gave up asking for are said once, at the first."""
        self.fallbacks.extend(fallbacks)
        for f in fallbacks:
            if f.given_up:
                said = f"agent {f.agent!r} answered by its rule solver from {where.strip(' ()') or 'here'} on: "
                if any(w.startswith(f"agent {f.agent!r}") and " on: " in w for w in self.warnings):
                    continue
                self.warnings.append(said + f.reason[:width])
                continue
            self.warnings.append(f"agent {f.agent!r}{where} answered by its rule solver: {f.reason[:width]}")


DEADLINE_BASE_S = 60.0
"""A model run's default deadline: this much for the requests every run makes (the manager, the
first request of each kind) ..."""
DEADLINE_PER_OBJECT_S = 10.0
"""... plus this much per object of the input. A whole rules run with two variants took 0.3 to 1.2 s
per object of the shipped PhyScene rooms on two cores (``benchmarks/real_model.py`` prints both
walls), so the model is given about ten times what the rules need before the remaining agents use them."""
DEADLINE_OBJECTS_UNKNOWN = 30
"""Objects counted when the model is first asked before the input's objects are known (a photograph)."""


def default_deadline_s(objects: int | None) -> float:
    """The wall-clock budget of a model run's requests when ``--deadline`` is not given:
    :data:`DEADLINE_BASE_S` plus :data:`DEADLINE_PER_OBJECT_S` per object (``None``: not known yet)."""
    count = DEADLINE_OBJECTS_UNKNOWN if objects is None else objects
    return DEADLINE_BASE_S + DEADLINE_PER_OBJECT_S * count


def _deadline(config: GenerateConfig, objects: int | None) -> tuple[float | None, str]:
    """The run's deadline for model requests, and where it came from (for the report)."""
    if config.deadline_s == "none":
        return None, "none (--deadline none)"
    if config.deadline_s is not None:
        return float(config.deadline_s), "given"
    if config.model == "rules" or (not isinstance(config.model, str) and config.model.uses_rule_solvers):
        return None, "none (the rules model asks nothing)"
    count = "objects not known yet" if objects is None else f"{objects} objects"
    return default_deadline_s(objects), f"default: {DEADLINE_BASE_S:g} s + {DEADLINE_PER_OBJECT_S:g} s x {count}"


async def open_model(config: GenerateConfig, started: float, objects: int | None = None) -> RunModel:
    """The run's model stack (``models.open_run_model``) as the settings describe it; ``started``
    is when the run began (``time.monotonic``: the deadline counts from it); ``objects``: how many
    the input holds, for the default deadline (``None``: not known yet)."""
    from scenemosaic.models import RunModelSettings, open_run_model

    deadline, why = _deadline(config, objects)
    settings = RunModelSettings(
        vision=config.vision, max_concurrency=config.max_concurrency, request_timeout_s=config.request_timeout_s,
        deadline_s=deadline, requests_per_minute=config.requests_per_minute,
        tokens_per_minute=config.tokens_per_minute, rate_limit_dir=config.rate_limit_dir, reply_cache=config.reply_cache,
        unusable_replies=config.unusable_replies if config.solver_fallback else 0,  # no solver: keep asking
    )  # fmt: skip
    stack = await open_run_model(config.model, settings, started=started)
    if not stack.uses_rule_solvers:
        stack.detail["deadline_s"] = deadline
        stack.detail["deadline"] = why
    return stack


def rooms_of(world: Scene | House) -> list[Scene]:
    """The rooms of what a run works on: a house's rooms, or the one scene of a room's run."""
    return list(world.rooms) if isinstance(world, House) else [world]


StageFn = Callable[[PipelineRun, StageRecord], Awaitable[None]]
"""A stage's body: reads the run, leaves its result on it, records its figures in the stage record."""


@dataclass(frozen=True)
class Stage:
    """One named step of the pipeline."""

    name: str
    run: StageFn

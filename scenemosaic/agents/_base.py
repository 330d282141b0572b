"""Task agents: typed units of work that read a scene state and answer about it.

A task agent is typed on the state it works on, its evidence and its output
(``TaskAgent[StateT, EvidenceT, OutputT]``; the output type is the third parameter). It declares a
name, the agents it depends on, how it gathers its evidence, its prompt template
(``prompts/<prompt>.md``), its rule solver (the offline path), which output fields name objects
(checked for unknown and repeated ids by the base class) and how else it checks an output against
the scene. :meth:`TaskAgent.run` returns an :class:`AgentResult` (the checked output, how it was
answered, its model requests and usage, the problems of refused answers) and changes nothing in
the state. An agent whose output changes the state also has an ``apply`` (:class:`AppliesOutput`);
an agent that only judges has none. Whoever runs the agent applies the result
(``scenemosaic.agents.run_agent``: the task-graph nodes, the evolve loop, perception) and hands it
to an :class:`~scenemosaic.agents.AgentLog`. The scheduler (``scenemosaic.dag``) turns agents into
graph nodes.

Plugins are subclasses (or any object with the same attributes) passed in by the caller;
there is no global registry.
"""

from __future__ import annotations

import abc
import asyncio
import contextvars
import dataclasses
import functools
import inspect
import time
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import (
    Any,
    ClassVar,
    Generic,
    Literal,
    Protocol,
    TypeVar,
    cast,
    get_args,
    get_origin,
    runtime_checkable,
)

import structlog
from pydantic import BaseModel, ConfigDict

from scenemosaic.agents._evidence import NESTED_ROWS_NOTE, TABLE_NOTE, evidence_legend, evidence_text
from scenemosaic.exceptions import (
    AgentOutputError,
    ModelConfigError,
    ModelContextLengthError,
    ModelDeadlineExceeded,
    ModelEndpointError,
    ModelError,
    ModelHTTPError,
    ModelUnavailableError,
    OutputValidationError,
    ReplayMissError,
    UsageError,
)
from scenemosaic.models import (
    GivenUp,
    ImagePart,
    Message,
    Model,
    ModelSettings,
    QualityBreaker,
    RequestContext,
    TextPart,
    Usage,
    UsageRecord,
    charged_usage,
)
from scenemosaic.scene import MAX_OBJECTS, Scene

__all__ = [
    "MAX_ITEMS",
    "PROMPTS_FOLDER",
    "AgentOutcome",
    "AgentOutput",
    "AgentPolicy",
    "AgentResult",
    "AppliesOutput",
    "FallbackRecord",
    "Need",
    "SceneState",
    "TaskAgent",
    "calls_of",
    "load_prompt",
    "prompt_paths",
    "run_blocking",
]

PROMPTS_FOLDER = "prompts"
"""Name of the folder, beside the module that defines an agent class, holding its prompt templates."""

MAX_ITEMS = MAX_OBJECTS
"""Upper bound on list lengths in agent outputs: the scene's object limit (keeps constrained decoding from looping)."""


class AgentOutput(BaseModel):
    """Base of agent outputs: unknown keys are rejected, so a model's extra fields fail validation."""

    model_config = ConfigDict(extra="forbid")


@dataclass(frozen=True)
class Need:
    """What an agent says about running on a scene a scheduler looked at (:meth:`TaskAgent.needed`):
    whether to run it and why, and whether a plan that leaves it out is refused."""

    run: bool
    """Whether the scheduler's rules run the agent here."""
    reason: str
    """Why (or why not), in words: the plan shows it."""
    required: bool = False
    """Every plan must schedule the agent, whatever the scene (a tree needs a room, parents and a
    final check)."""
    evidence: tuple[str, ...] = ()
    """What in the scene calls for the agent; a plan that leaves it out while there is some is
    refused, naming it (``insist``)."""
    insist: str = ""
    """The refusal's words when ``evidence`` is left unserved."""


_log = structlog.get_logger(__name__)

StateT = TypeVar("StateT", bound="SceneState", contravariant=True)
EvidenceT = TypeVar("EvidenceT", bound=BaseModel)
OutputT = TypeVar("OutputT", bound=BaseModel)
R = TypeVar("R")


async def run_blocking(fn: Callable[..., R], *args: Any, offload: bool = True) -> R:
    """Call ``fn(*args)`` in a worker thread (inline when ``offload`` is false).

    Scene work of an agent (gathering evidence over every object pair, rendering images,
    checking or applying an output) can take a noticeable fraction of a second on a large
    scene; in a worker thread it never stalls the event loop, where model requests and
    other scenes' nodes are waiting. A thread cannot be interrupted, so when the awaiting
    task is cancelled this waits for the call to end before re-raising: no half-applied
    change outlives the agent's hold on ``SceneState.lock``, and no worker is left writing
    to the state after the run has stopped.
    """
    if not offload:
        return fn(*args)
    loop = asyncio.get_running_loop()
    call = functools.partial(contextvars.copy_context().run, fn, *args)
    future = loop.run_in_executor(None, call)
    try:
        await asyncio.wait([future])
    except asyncio.CancelledError:
        while not future.done():
            try:
                await asyncio.wait([future])
            except asyncio.CancelledError:
                continue
        if not future.cancelled():
            future.exception()  # retrieved: the run is stopping anyway
        raise
    return future.result()


def prompt_paths(agent_cls: type, name: str) -> list[Path]:
    """Where the template ``name`` of ``agent_cls`` may live, in lookup order.

    For each class in the agent's MRO that defines ``prompt`` (so a subclass may reuse its
    base's templates): ``prompts/<name>.md`` beside the module defining that class, then
    ``<name>.md`` beside it.
    """
    paths: list[Path] = []
    for cls in agent_cls.__mro__:
        if "prompt" not in vars(cls):
            continue
        try:
            folder = Path(inspect.getfile(cls)).resolve().parent
        except (TypeError, OSError):  # a class made at run time, with no source file
            continue
        for candidate in (folder / PROMPTS_FOLDER / f"{name}.md", folder / f"{name}.md"):
            if candidate not in paths:
                paths.append(candidate)
    return paths


def load_prompt(agent_cls: type, name: str | None = None) -> str:
    """The system prompt template of ``agent_cls``.

    ``prompt`` on the class is either the template's text itself (anything containing a
    newline) or a template name, found beside the module that defines the agent (see
    :func:`prompt_paths`). Built-in agents keep theirs in ``<package>/prompts/``; a one-file
    plugin may put the text in the class or a ``.md`` file beside its module.
    """
    prompt = name if name is not None else getattr(agent_cls, "prompt", "")
    if "\n" in prompt:
        return prompt
    if not prompt:
        raise AgentOutputError(f"agent class {agent_cls.__name__} sets no prompt", agent=agent_cls.__name__)
    paths = prompt_paths(agent_cls, prompt)
    for path in paths:
        if path.is_file():
            return path.read_text(encoding="utf-8")
    raise UsageError(
        f"prompt template {prompt!r} of agent class {agent_cls.__name__} not found; looked in "
        + ", ".join(str(p) for p in paths)
    )


@dataclass(frozen=True)
class AgentPolicy:
    """How task agents treat a model's answers (one policy per run)."""

    max_attempts: int = 3
    """Model requests per agent run, first answer and repairs together. A reply that is not
    JSON, breaks the output schema, or fails the agent's :meth:`TaskAgent.check` uses one
    attempt and is sent back with the problems in words."""
    solver_fallback: bool = False
    """When the attempts are used up, or the model fails in a way retries cannot fix (time-outs,
    5xx after the transport's own retries, dropped connections), answer with the agent's rule
    solver and say so in the run's :class:`AgentResult` (``fallback``), instead of failing the run.
    Configuration errors (HTTP 401, a cassette miss, vision on a text-only server) still raise.
    Off by default for direct use (an unusable answer raises); ``generate`` turns it on
    (``GenerateConfig.solver_fallback``) so batch runs still deliver scenes."""
    endpoint_fallback: bool = False
    """With ``solver_fallback``, also answer with the rule solver when the model server cannot
    serve the run at all (:class:`~scenemosaic.exceptions.ModelEndpointError`: nothing listening,
    unknown host, key refused, no such model). Off by default: such a run stops at once with the
    fix, rather than quietly delivering rule answers (``--fallback rules`` turns it on)."""
    quality: QualityBreaker | None = field(default=None, compare=False)
    """The run's judge of replies per agent kind (``RunModel.quality``): every reply is reported to
    it as usable or not, and an agent whose kind it has given up answers with its rule solver
    without asking. Needs ``solver_fallback``. ``None``: every agent run asks."""

    def __post_init__(self) -> None:
        if self.max_attempts < 1:
            raise UsageError(f"max_attempts must be >= 1, got {self.max_attempts}")
        if self.quality is not None and self.quality.threshold is not None and not self.solver_fallback:
            raise UsageError("a quality breaker routes agents to their rule solvers: it needs solver_fallback on")


@dataclass(frozen=True)
class FallbackRecord:
    """One agent answered by its rule solver instead of the model, and why."""

    agent: str
    reason: str
    given_up: bool = False
    """The run had given up asking the model for this agent's kind (``AgentPolicy.quality``): the
    solver answered without a request, or after the reply that gave the kind up."""


AnsweredBy = Literal["rules", "model", "solver_without_call", "solver_fallback"]


@dataclass(frozen=True)
class AgentOutcome:
    """How one agent's answer came about, for run reports.

    ``answered_by``: ``rules`` (the offline model: the solver), ``model`` (a model reply, perhaps
    after repairs), ``solver_without_call`` (the evidence left nothing to decide, see
    :meth:`TaskAgent.answer_without_model`) or ``solver_fallback`` (the model's replies stayed unusable or
    it failed; ``reason`` says why). ``requests``: model requests made; ``repairs``: replies
    sent back with their problems (a reply used at the first request has 0).
    """

    agent: str
    answered_by: AnsweredBy
    requests: int = 0
    repairs: int = 0
    reason: str = ""


@dataclass(frozen=True)
class AgentResult(Generic[OutputT]):
    """What one :meth:`TaskAgent.run` produced: a checked output, not yet applied to the state.

    ``outcome`` says how the answer came about (model, rules, solver without a call, or solver
    fallback with the reason); ``fallback`` is the record of a solver fallback (``None`` when the
    answer is the model's or the rules'); ``problems`` holds the check's problems with each model
    answer that was refused, in order (schema errors not included). ``calls`` has one record per
    model request the run made (a request the run's own circuit breaker or deadline refused before
    sending is none), counted as the run's usage tracker counts them (:func:`~scenemosaic.models.charged_usage`);
    ``usage`` is their sum. ``notes`` are what the runner adds to the scene's provenance notes when
    it applies the result (a solver fallback says so there).
    """

    output: OutputT
    outcome: AgentOutcome
    usage: Usage = field(default_factory=Usage)
    problems: tuple[tuple[str, ...], ...] = ()
    fallback: FallbackRecord | None = None
    calls: tuple[UsageRecord, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def agent(self) -> str:
        """The agent's name."""
        return self.outcome.agent


_CALLS = "agent_calls"
"""Attribute of an exception raised by :meth:`TaskAgent.run` that holds the run's model requests."""


def calls_of(exc: BaseException) -> tuple[UsageRecord, ...]:
    """The model requests an agent run made before it raised ``exc`` (an ``AgentResult`` never
    came back to carry them): a runner hands them to its log, so a failed stage still counts them."""
    calls = getattr(exc, _CALLS, ())
    return tuple(calls) if isinstance(calls, tuple) else ()


@dataclass
class SceneState:
    """The shared state task agents read during a run, and their runner writes.

    ``scene`` is replaced (not mutated behind readers' backs) by ``apply``; ``lock``
    serializes the agents' reads and the runner's applies, so concurrent agents never see
    half-written changes. ``outputs`` keeps each agent's applied output by agent name and
    ``revision`` counts the results applied (both kept by the runner). How each agent's answer
    came about is not kept here: :meth:`TaskAgent.run` returns it (:class:`AgentResult`).
    """

    scene: Scene
    seed: int = 0
    base_dir: Path | None = None
    """Folder relative mesh paths start from (agents that draw the scene's meshes need it)."""
    policy: AgentPolicy = field(default_factory=AgentPolicy)
    outputs: dict[str, BaseModel] = field(default_factory=dict)
    lock: asyncio.Lock = field(default_factory=asyncio.Lock)
    revision: int = 0
    """How many agent results were applied to this state: when it moved while an agent ran, the
    runner checks that agent's answer again before applying it (``scenemosaic.agents.run_agent``)."""


S_contra = TypeVar("S_contra", bound=SceneState, contravariant=True)
O_contra = TypeVar("O_contra", bound=BaseModel, contravariant=True)


@runtime_checkable
class AppliesOutput(Protocol[S_contra, O_contra]):
    """An agent whose output changes the state: it has ``apply(output, state)``, which writes a
    checked output into the state (the runner calls it, holding ``state.lock``). An agent that
    only judges (the manager's plan, the critic, the judge) has no ``apply``: its output is read
    by whoever ran it."""

    def apply(self, output: O_contra, state: S_contra) -> None:
        """Write a checked output into the scene state."""


REPAIR_ECHO_CHARS = 6000
"""A rejected reply is quoted back at most this long (a runaway reply would fill the context)."""


_SHOWN_PROBLEMS = 5
"""Problems an unusable rule solver's error message quotes (the exception keeps them all)."""


def _repair(prompt: list[Message], reply: str, intro: str, problems: list[str]) -> list[Message]:
    """The request that asks again: the original prompt, the last reply, what is wrong with it.
    Earlier failed tries are not repeated, so repairs do not make the prompt grow."""
    quoted = reply if len(reply) <= REPAIR_ECHO_CHARS else reply[:REPAIR_ECHO_CHARS] + " ...(cut)"
    return [
        *prompt,
        Message.text("assistant", quoted),
        Message.text("user", intro + "\n- " + "\n- ".join(problems[:20]) + "\nReply again with only the corrected JSON object."),
    ]


def _recoverable(exc: ModelError | ModelConfigError, policy: AgentPolicy) -> bool:
    """Whether a model failure is the model's (fall back) rather than the user's set-up (raise)."""
    if isinstance(exc, ModelEndpointError):
        return policy.endpoint_fallback  # no server to ask: stop, unless the run asked for rules
    if isinstance(exc, ReplayMissError | ModelConfigError):
        return False  # a cassette mismatch or a wrong setting is a set-up error, not a flaky model
    if isinstance(exc, ModelContextLengthError):
        return True  # the evidence outgrew this model's window: the rule solver needs no window
    if isinstance(exc, ModelHTTPError):
        return exc.status_code == 429 or exc.status_code >= 500
    return True  # time-outs, dropped connections after the transport's retries


def _field_values(value: Any, path: list[str]) -> Iterator[str]:
    """The strings at a dotted ``path`` below ``value``, walking through lists (``None`` skipped)."""
    if isinstance(value, list | tuple):
        for item in value:
            yield from _field_values(item, path)
        return
    if value is None:
        return
    if not path:
        if isinstance(value, str):
            yield value
        return
    yield from _field_values(getattr(value, path[0]), path[1:])


def _given_up_words(given: GivenUp) -> str:
    """Why an agent of a kind the run gave up answers with its solver (the outcome's reason)."""
    if given.cause == "deadline":
        return given.reason
    return (
        f"the model's {given.kind} replies stayed unusable ({given.requests} asked, {given.usable} usable; "
        f"last: {given.reason[:200]}); the run no longer asks it for {given.kind}"
    )


def _sent(exc: BaseException) -> bool:
    """Whether a request that raised ``exc`` reached the model: the run's circuit breaker and its
    deadline refuse before sending (a deadline that passed during the request did send it)."""
    if isinstance(exc, ModelUnavailableError):
        return False
    return not isinstance(exc, ModelDeadlineExceeded) or exc.__cause__ is not None


@dataclass
class _Tally:
    """Requests, repairs, model calls and refused answers of one agent run, over all its requests."""

    requests: int = 0
    repairs: int = 0
    calls: list[UsageRecord] = field(default_factory=list)
    refused: list[tuple[str, ...]] = field(default_factory=list)

    def called(
        self, context: RequestContext, model: str, usage: Usage | None, latency_s: float, error: BaseException | None
    ) -> None:
        """Record one request as the run's usage tracker records it (nothing for one never sent)."""
        if error is not None and not _sent(error):
            return
        if error is not None:
            spent = getattr(error, "usage", None)
            usage = spent if isinstance(spent, Usage) else Usage()
        cancelled = isinstance(error, asyncio.CancelledError | ModelDeadlineExceeded)
        charged = charged_usage(usage or Usage(), cancelled=cancelled)
        self.calls.append(UsageRecord(context.agent, context.node, model, charged, latency_s, error is None, None))

    def result(
        self,
        agent: str,
        output: OutputT,
        answered_by: AnsweredBy,
        reason: str = "",
        notes: tuple[str, ...] = (),
        *,
        given_up: bool = False,
    ) -> AgentResult[OutputT]:
        fallback = (
            FallbackRecord(agent=agent, reason=reason[:500], given_up=given_up) if answered_by == "solver_fallback" else None
        )
        outcome = AgentOutcome(agent, answered_by, self.requests, self.repairs, reason[:300])
        usage = sum((c.usage for c in self.calls), Usage())
        return AgentResult(output, outcome, usage, tuple(self.refused), fallback, tuple(self.calls), notes)


@dataclass
class _Reply(Generic[OutputT]):
    """Where one ask/check/repair loop ended: an accepted output, or the problems and why it stopped."""

    output: OutputT | None = None
    problems: list[str] = field(default_factory=list)
    """The last answer's problems (repairable ones: schema or check)."""
    error: str | None = None
    """A model failure the solver may answer for (``solver_fallback`` on); ``None``: the budget ran out."""
    schema_error: OutputValidationError | None = None
    """The last answer's schema error, when it was one."""


def _output_parameter(cls: type) -> type[BaseModel] | TypeVar | None:
    """The output type a class's generic bases give ``TaskAgent``'s ``OutputT`` (a class, or a type
    variable when the class is itself generic in its output), ``None`` when they say nothing."""
    for base in vars(cls).get("__orig_bases__", ()):
        origin = get_origin(base)
        if origin is TaskAgent:
            variable = cast(Any, TaskAgent).__parameters__[2]  # OutputT
        else:
            variable = getattr(origin, "_output_variable", None)
        if variable is None:
            continue
        given = dict(zip(getattr(origin, "__parameters__", ()), get_args(base), strict=False))
        found = given.get(variable)
        if isinstance(found, TypeVar) or (isinstance(found, type) and issubclass(found, BaseModel)):
            return found
    return None


class TaskAgent(abc.ABC, Generic[StateT, EvidenceT, OutputT]):
    """Base class of every task agent: ``TaskAgent[StateT, EvidenceT, OutputT]``.

    ``StateT`` is the state the hooks work on (:class:`SceneState`, or a subclass such as the
    evolve stage's ``EvolveState``), ``EvidenceT`` what :meth:`gather` collects, ``OutputT`` the
    pydantic model a reply must validate as (it becomes ``output_type``; do not set it as well).

    Class attributes to set in a subclass:

    * ``name`` — unique node name in a graph.
    * ``depends_on`` — names of agents whose outputs this one needs when they run; the
      scheduler drops names of agents that are not part of the run.
    * ``runs_last`` — ``True`` for an agent that must see every other agent's output (the
      verification agent); it then depends on all agents of the run that do not run last.
    * ``prompt`` — the prompt template's name (``<name>.md`` in a ``prompts/`` folder beside
      the module defining the class, or beside the module itself), or the prompt text itself.
    * ``object_id_fields`` / ``object_ref_fields`` — output fields that name objects; the base
      check reports unknown ids (and, for ``object_id_fields``, ids listed twice).
    * ``offload`` — run :meth:`gather`, :meth:`messages`, :meth:`check` (and the runner runs
      ``apply``) in a worker thread (default), holding ``state.lock`` so they still see and leave a
      consistent scene. Set it to ``False`` for an agent whose hooks must run on the event
      loop (e.g. an ``apply`` that adds graph nodes through ``current_context()``).

    An agent whose output changes the state defines ``apply(output, state)``
    (:class:`AppliesOutput`); one that only judges defines none. :meth:`run` never applies: it
    returns the checked output, and the runner applies it.

    The agent owns its answer: it validates, repairs within ``state.policy.max_attempts``
    requests, and falls back to :meth:`solve`. Models never call agent code; with the offline
    ``rules`` model (``model.uses_rule_solvers``) the agent answers with :meth:`solve` directly.
    """

    name: ClassVar[str]
    depends_on: ClassVar[tuple[str, ...]] = ()
    runs_last: ClassVar[bool] = False
    prompt: ClassVar[str]
    output_type: ClassVar[type[BaseModel]]
    """The output model: the class's third type parameter (set here only for a class whose
    parameter is not a concrete model, e.g. one made at run time)."""
    offload: ClassVar[bool] = True
    chunk_size: ClassVar[int | None] = None
    """Largest number of objects one request answers for; a larger scene is asked in chunks
    (:meth:`split`), so prompt and reply fit a small model's context. Needs ``items_field``."""
    items_field: ClassVar[str | None] = None
    """Name of the output's per-object list (items carrying an ``object_id``), for chunking."""
    object_id_fields: ClassVar[tuple[str, ...]] = ()
    """Output fields that name each object at most once, as dotted paths through lists
    (``"objects.object_id"``): an id not in :meth:`known_ids` or listed twice is a problem."""
    object_ref_fields: ClassVar[tuple[str, ...]] = ()
    """Output fields that may name an object more than once (``"within_unit.reference_id"``):
    an id not in :meth:`known_ids` is a problem."""
    id_scope: ClassVar[str] = "scene"
    """What :meth:`known_ids` holds, in the words of the unknown-id problem ("... does not exist in this scene")."""
    prompt_omit: ClassVar[frozenset[str]] = frozenset()
    """Evidence fields this agent's decisions do not need: left out of the prompt text (the rule
    solver still reads them), to keep prompts small."""
    reply_tokens: ClassVar[tuple[int, int] | None] = None
    """``(base, per_object)``: the reply cap is ``base + per_object x`` the objects in the evidence
    (never above the run's ``max_tokens``), so a small model that starts repeating itself is cut
    early instead of filling the whole default cap. ``None``: the run's cap."""
    prompt_extra: ClassVar[frozenset[str]] = frozenset()
    """Evidence fields marked ``prompt=False`` that this agent's prompt shows all the same."""
    nested_rows: ClassVar[bool] = False
    """Write the lists of records inside the evidence's table cells as rows of their own
    (:data:`~scenemosaic.agents.NESTED_ROWS_NOTE`), not as JSON objects repeating every key: for an
    agent whose evidence nests many records (verification's receptacle options)."""
    _output_variable: ClassVar[Any] = None
    """The type variable standing for the output in a generic subclass's own parameters."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Take ``output_type`` from the class's type parameters (declared once, there)."""
        super().__init_subclass__(**kwargs)
        found = _output_parameter(cls)
        if isinstance(found, TypeVar):  # a generic subclass: its own subclasses say what it is
            cls._output_variable = found
        elif found is not None:
            if "output_type" in vars(cls):
                raise TypeError(
                    f"{cls.__name__} declares its output type twice: the type parameter "
                    f"{found.__name__} is the output type, leave output_type out"
                )
            cls.output_type = found
            cls._output_variable = None

    # -- what a subclass provides ------------------------------------------------------------
    def needed(self, summary: Any) -> Need:
        """Whether a scheduler should run this agent on the scene it summarized (the structuring
        manager hands its ``SceneSummary``), and why. The built-in agents say when they have work
        (containment only over containers, ...); a plugin runs whenever it is given, unless it
        says otherwise here: built-ins and plugins go through this one seam."""
        del summary
        return Need(True, "plugin agent given by the caller")

    @abc.abstractmethod
    def gather(self, state: StateT) -> EvidenceT:
        """Collect this agent's structured evidence from the scene state."""

    @abc.abstractmethod
    def solve(self, evidence: EvidenceT) -> OutputT:
        """The deterministic offline solver: evidence in, output out."""

    def check(self, output: OutputT, state: StateT) -> list[str]:
        """Problems, beyond unknown and repeated ids, that make ``output`` unusable on this scene.

        Each problem is a sentence a model can act on; an empty list means usable. The ids of
        ``object_id_fields`` / ``object_ref_fields`` are checked before (:meth:`problems`), so an
        override needs no id checks of its own (it may skip items whose id is unknown).
        """
        return []

    def known_ids(self, state: StateT) -> Collection[str]:
        """The ids an output may name (default: the scene's objects)."""
        return {o.id for o in state.scene.objects}

    def id_problems(self, output: OutputT, state: StateT) -> list[str]:
        """Unknown ids in the output's id fields, and ids listed twice in an ``object_id_fields`` field."""
        if not (self.object_id_fields or self.object_ref_fields):
            return []
        known = self.known_ids(state)
        problems: list[str] = []
        unknown: set[str] = set()
        for path in (*self.object_id_fields, *self.object_ref_fields):
            once = path in self.object_id_fields
            seen: set[str] = set()
            repeated: set[str] = set()
            for oid in _field_values(output, path.split(".")):
                if oid not in known:
                    if oid not in unknown:
                        unknown.add(oid)
                        problems.append(f"object id {oid!r} does not exist in this {self.id_scope}")
                elif once and oid in seen and oid not in repeated:
                    repeated.add(oid)
                    problems.append(f"object {oid!r} is listed twice")
                seen.add(oid)
        return problems

    def problems(self, output: OutputT, state: StateT) -> list[str]:
        """Every problem with ``output``: :meth:`id_problems`, then :meth:`check`'s."""
        return self.id_problems(output, state) + self.check(output, state)

    def reply_settings(self, settings: ModelSettings | None, evidence: BaseModel) -> ModelSettings | None:
        """``settings`` with the reply cap of :attr:`reply_tokens` for ``evidence``."""
        if self.reply_tokens is None:
            return settings
        base, per_object = self.reply_tokens
        objects = getattr(evidence, "objects", None)
        cap = base + per_object * (len(objects) if isinstance(objects, list) else 0)
        current = settings or ModelSettings()
        if current.max_tokens is not None:
            cap = min(cap, current.max_tokens)
        return dataclasses.replace(current, max_tokens=cap, retry_truncated=False)

    def answer_without_model(self, evidence: EvidenceT) -> OutputT | None:
        """The answer when ``evidence`` leaves a model nothing to decide, else ``None`` (default).

        An agent whose evidence holds nothing to decide (a verification pass with nothing to
        fix) returns its rule solver's answer here: it is then used without a request, which
        keeps a model run's critical path short. The answer is still checked.
        """
        return None

    def images(self, evidence: EvidenceT, state: StateT) -> list[ImagePart]:
        """Images to send to vision models (none by default)."""
        return []

    def render_evidence_text(self, evidence: EvidenceT) -> str:
        """Text rendering of the evidence (also what text-only models get instead of images):
        compact tables, numbers to 1 cm, ``prompt_omit`` left out (:func:`scenemosaic.agents.evidence_text`)."""
        return evidence_text(evidence, omit=self.prompt_omit, extra=self.prompt_extra, nested_rows=self.nested_rows)

    def system_prompt(self, evidence: EvidenceT, *, legend: bool = True) -> str:
        """The template, how to read the evidence and what its fields mean (``legend``), and the
        reply format. The output schema itself travels with the request (a strict
        ``response_format``; a model without one pastes it, see ``OpenAIChatModel``)."""
        parts = [load_prompt(type(self))]
        if legend:
            note = f"{TABLE_NOTE} {NESTED_ROWS_NOTE}" if self.nested_rows else TABLE_NOTE
            parts += [note, evidence_legend(type(evidence), self.prompt_omit, self.prompt_extra)]
        parts.append("Reply with one JSON object of the requested schema, and nothing else.")
        return "\n\n".join(p for p in parts if p)

    def compact_messages(self, evidence: EvidenceT, state: StateT, *, vision: bool) -> list[Message]:
        """A shorter prompt for a model whose context the full one did not fit: no format note or
        field legend, numbers to 1 dm. Images are kept for vision models."""
        parts: list[TextPart | ImagePart] = [
            TextPart(
                "Evidence:\n"
                + evidence_text(
                    evidence, digits=1, omit=self.prompt_omit, extra=self.prompt_extra, nested_rows=self.nested_rows
                )
            )
        ]
        if vision:
            parts.extend(self.images(evidence, state))
        return [
            Message.text("system", self.system_prompt(evidence, legend=False)),
            Message(role="user", parts=tuple(parts)),
        ]

    def messages(self, evidence: EvidenceT, state: StateT, *, vision: bool) -> list[Message]:
        """System prompt (:meth:`system_prompt`), then the evidence as text (and images for vision models)."""
        parts: list[TextPart | ImagePart] = [TextPart("Evidence:\n" + self.render_evidence_text(evidence))]
        if vision:
            parts.extend(self.images(evidence, state))
        return [Message.text("system", self.system_prompt(evidence)), Message(role="user", parts=tuple(parts))]

    # -- the generic run -----------------------------------------------------------------------
    async def run(
        self,
        state: StateT,
        model: Model,
        settings: ModelSettings | None = None,
        *,
        node: str | None = None,
    ) -> AgentResult[OutputT]:
        """Gather evidence, answer (model or rule solver), check, repair; return the result.

        Scene work runs in a worker thread under ``state.lock`` (see ``offload``); only the
        model request runs without the lock, so concurrent agents overlap on their requests.
        One budget, ``state.policy.max_attempts``, covers every reason to ask again. Nothing in
        the state changes: the returned :class:`AgentResult` holds the checked output (for the
        runner to apply, ``scenemosaic.agents.run_agent``) and how it came about. An exception
        raised here carries the run's model requests (:func:`calls_of`).
        """
        tally = _Tally()
        try:
            result = await self._answer(state, model, settings, tally, node=node)
            if state.policy.quality is not None:  # the run's account of the model's work, per kind
                o = result.outcome
                state.policy.quality.answered(self.name, o.answered_by, o.repairs, o.reason)
            return result
        except BaseException as exc:
            if tally.calls:
                setattr(exc, _CALLS, (*calls_of(exc), *tally.calls))
            raise

    async def _answer(
        self, state: StateT, model: Model, settings: ModelSettings | None, tally: _Tally, *, node: str | None
    ) -> AgentResult[OutputT]:
        if model.uses_rule_solvers:
            async with state.lock:
                output = await run_blocking(self._solved, state, offload=self.offload)
            return tally.result(self.name, output, "rules")
        async with state.lock:
            evidence, messages, settled = await run_blocking(self._prepare, state, model.vision, offload=self.offload)
            if settled is not None:  # nothing to decide: the solver's answer, checked, no call
                _log.info("agent_answered_without_model", agent=self.name)
                await run_blocking(self._require_usable, settled, state, [], offload=self.offload)
                return tally.result(self.name, settled, "solver_without_call")
            chunks = self._chunks(evidence)
        quality = state.policy.quality
        given = quality.given_up(self.name) if quality is not None and state.policy.solver_fallback else None
        if given is not None:  # the model cannot do this kind (or the deadline passed): the solver, quietly
            return await self._fall_back(state, _given_up_words(given), [], tally, quiet=True)
        if len(chunks) > 1:
            return await self._run_chunked(state, model, settings, evidence, chunks, tally, node=node)
        compact = functools.partial(self.compact_messages, evidence, state, vision=model.vision)
        accept = functools.partial(self.problems, state=state)
        reply = await self._ask(state, model, settings, evidence, messages, accept, tally, node=node, compact=compact)
        if reply.output is not None:
            return tally.result(self.name, reply.output, "model")
        reason = reply.error or f"unusable after {state.policy.max_attempts} attempts: " + "; ".join(reply.problems)
        if not state.policy.solver_fallback:
            if reply.schema_error is not None:  # the last reply was not even schema-valid: say so, with it
                raise reply.schema_error
            raise AgentOutputError(f"agent {self.name!r} gave an {reason}", agent=self.name, problems=reply.problems)
        quiet = quality is not None and quality.given_up(self.name) is not None  # the breaker said it
        return await self._fall_back(state, reason, reply.problems, tally, quiet=quiet)

    async def _ask(
        self,
        state: StateT,
        model: Model,
        settings: ModelSettings | None,
        evidence: EvidenceT,
        prompt: list[Message],
        accept: Callable[[OutputT], list[str]],
        tally: _Tally,
        *,
        node: str | None,
        compact: Callable[[], list[Message]] | None = None,
    ) -> _Reply[OutputT]:
        """The ask/check/repair loop of one request (the whole evidence, or one chunk of it).

        ``accept`` (run under the lock) returns an answer's problems; an answer without any is
        the reply's output. A reply that is not JSON, breaks the schema or has problems is sent back with them
        (the original prompt, the last reply, the problems: repairs do not make the prompt grow)
        while the budget lasts. ``compact``, when given, is asked once for a shorter prompt when
        the model's context overflows. A model failure raises unless the solver may answer for it
        (``policy.solver_fallback`` and a failure retries cannot fix): then ``error`` says why.
        """
        context = RequestContext(agent=self.name, node=node or self.name, evidence=evidence)
        settings = self.reply_settings(settings, evidence)
        policy = state.policy
        reply = _Reply[OutputT]()
        messages = prompt
        for attempt in range(policy.max_attempts):
            reply.schema_error = None
            ticket = await policy.quality.admit(self.name) if policy.quality is not None else None
            if ticket is not None and ticket.given_up is not None:  # given up meanwhile (by this run or another)
                reply.error = _given_up_words(ticket.given_up)
                return reply
            try:
                tally.requests += 1
                answer = await self._request(model, messages, settings, context, tally)
            except OutputValidationError as exc:  # not JSON, or not the schema: repairable
                reply.schema_error = exc
                problems, text = exc.errors or [str(exc)], exc.raw_reply
                intro = f"That reply is not a valid {self.output_type.__name__} JSON object:"
                if ticket is not None and (given := ticket.unusable(problems[0])) is not None:
                    reply.problems, reply.error = problems, _given_up_words(given)
                    return reply
            except (ModelError, ModelEndpointError) as exc:
                if ticket is not None:
                    ticket.close(sent=_sent(exc))
                if isinstance(exc, ModelDeadlineExceeded) and policy.quality is not None:
                    policy.quality.stop(str(exc).split(" (request by")[0])  # every later agent: the solver, quietly
                if isinstance(exc, ModelContextLengthError) and compact is not None:
                    # once: a shorter prompt, then (if it still does not fit) the solver
                    _log.warning("agent_prompt_compacted", agent=self.name, reason=str(exc)[:200])
                    async with state.lock:
                        messages = prompt = await run_blocking(compact, offload=self.offload)
                    compact = None
                    reply.problems = [f"the prompt did not fit the model's context: {exc}"]
                    continue
                if not (policy.solver_fallback and _recoverable(exc, policy)):
                    raise
                reply.error = f"{type(exc).__name__}: {exc}"
                return reply
            else:
                output = cast(OutputT, answer)
                async with state.lock:
                    problems = await run_blocking(accept, output, offload=self.offload)
                if not problems:
                    if ticket is not None:
                        ticket.usable()
                    reply.output, reply.problems = output, []
                    return reply
                tally.refused.append(tuple(problems))
                text = output.model_dump_json()
                intro = "That answer cannot be applied to this scene:"
                if ticket is not None and (given := ticket.unusable(problems[0])) is not None:
                    reply.problems, reply.error = problems, _given_up_words(given)
                    return reply
            finally:
                if ticket is not None:
                    ticket.close()  # no reply to judge (a time-out, a cancel): counts neither way
            reply.problems = problems
            if attempt + 1 < policy.max_attempts:
                tally.repairs += 1
                messages = _repair(prompt, text, intro, problems)
        return reply

    async def _request(
        self,
        model: Model,
        messages: list[Message],
        settings: ModelSettings | None,
        context: RequestContext,
        tally: _Tally,
    ) -> BaseModel:
        """One model request, recorded in ``tally`` however it ends: the answer (its usage is in ``tally``)."""
        started = time.perf_counter()
        try:
            answer, usage = await model.request(messages, self.output_type, settings, context=context)
        except BaseException as exc:
            tally.called(context, model.name, None, time.perf_counter() - started, exc)
            raise
        tally.called(context, model.name, usage, time.perf_counter() - started, None)
        return answer

    # -- large scenes: one request per chunk of objects ------------------------------------------
    def _chunks(self, evidence: EvidenceT) -> list[tuple[list[str], EvidenceT]]:
        if self.chunk_size is None or self.items_field is None:
            return [([], evidence)]
        return self.split(evidence, self.chunk_size)

    def split(self, evidence: EvidenceT, size: int) -> list[tuple[list[str], EvidenceT]]:
        """Evidence for each chunk of at most ``size`` objects, with the ids the chunk answers for.

        Agents that set ``chunk_size`` and ``items_field`` override this; a single chunk (the
        default) means no chunking.
        """
        return [([], evidence)]

    def _items(self, output: BaseModel) -> list[Any]:
        assert self.items_field is not None
        items: list[Any] = getattr(output, self.items_field)
        return items

    def _with_items(self, base: OutputT, items: list[Any]) -> OutputT:
        assert self.items_field is not None
        data = base.model_dump()
        data[self.items_field] = [i.model_dump() if isinstance(i, BaseModel) else i for i in items]
        return cast(OutputT, self.output_type.model_validate(data))

    async def _run_chunked(
        self,
        state: StateT,
        model: Model,
        settings: ModelSettings | None,
        evidence: EvidenceT,
        chunks: list[tuple[list[str], EvidenceT]],
        tally: _Tally,
        *,
        node: str | None,
    ) -> AgentResult[OutputT]:
        """Ask for each chunk of objects in turn (:meth:`_ask`); each chunk's answer is checked in
        the context of the whole scene (the rule solver's answer stands in for the other chunks),
        and replaced by the solver's part when it stays unusable. The merged answer is checked
        once more and returned."""
        base = await run_blocking(self.solve, evidence, offload=self.offload)
        policy = state.policy
        kept: list[Any] = []
        failed: list[str] = []
        for ids, part in chunks:
            wanted = set(ids)
            others = [i for i in self._items(base) if getattr(i, "object_id", None) not in wanted]
            mine = [i for i in self._items(base) if getattr(i, "object_id", None) in wanted]

            def in_chunk(output: BaseModel, wanted: set[str] = wanted) -> list[Any]:
                """The output's items about this chunk's objects (others, shown as context, are ignored)."""
                return [i for i in self._items(output) if getattr(i, "object_id", None) in wanted]

            def accept(output: OutputT, others: list[Any] = others, in_chunk: Any = in_chunk) -> list[str]:
                return self.problems(self._with_items(base, others + in_chunk(output)), state)

            async with state.lock:
                prompt = await run_blocking(
                    functools.partial(self.messages, vision=model.vision), part, state, offload=self.offload
                )
            reply = await self._ask(state, model, settings, part, prompt, accept, tally, node=node)
            if reply.output is not None:
                kept += in_chunk(reply.output)
                continue
            problems = [reply.error] if reply.error is not None else reply.problems
            if not policy.solver_fallback:
                raise AgentOutputError(
                    f"agent {self.name!r} gave an unusable answer for {', '.join(ids[:8])}: " + "; ".join(problems),
                    agent=self.name,
                    problems=problems,
                )
            failed.append(f"{len(ids)} objects ({'; '.join(problems)[:200]})")
            kept += mine
        merged = self._with_items(base, kept)
        async with state.lock:
            problems = await run_blocking(self.problems, merged, state, offload=self.offload)
        if problems:  # chunks that each fit, together do not (a cycle across chunks): the solver
            reason = "chunk answers inconsistent together: " + "; ".join(problems)
            return await self._fall_back(state, reason, problems, tally)
        if failed:
            note = f"{self.name}: model answer unusable for part of the scene, used the rule solver there"
            return tally.result(self.name, merged, "solver_fallback", "rule solver for " + ", ".join(failed), (note,))
        return tally.result(self.name, merged, "model")

    def _solved(self, state: StateT) -> OutputT:
        """The rules path: the agent's own solver answers; its output must pass the agent's check."""
        output = self.solve(self.gather(state))
        self._require_usable(output, state, [])
        return output

    def _prepare(self, state: StateT, vision: bool) -> tuple[EvidenceT, list[Message], OutputT | None]:
        evidence = self.gather(state)
        settled = self.answer_without_model(evidence)
        messages = self.messages(evidence, state, vision=vision) if settled is None else []
        return evidence, messages, settled

    def _require_usable(self, output: OutputT, state: StateT, model_problems: list[str]) -> None:
        solver_problems = self.problems(output, state)
        if solver_problems:  # the solver itself is wrong: a bug worth failing loudly on
            what = "the model's output and the rule solver's are" if model_problems else "the rule solver's output is"
            every = model_problems + solver_problems
            more = f"; and {len(every) - _SHOWN_PROBLEMS} more" if len(every) > _SHOWN_PROBLEMS else ""
            raise AgentOutputError(  # one line: the first problems; all of them on the exception
                f"agent {self.name!r}: {what} unusable: " + "; ".join(every[:_SHOWN_PROBLEMS]) + more,
                agent=self.name,
                problems=model_problems + solver_problems,
            )

    async def _fall_back(
        self, state: StateT, reason: str, problems: list[str], tally: _Tally, *, quiet: bool = False
    ) -> AgentResult[OutputT]:
        """The rule solver's answer instead of the model's, with ``reason``; ``quiet``: no warning
        (a kind the run has given up was said once, by the breaker)."""

        def fall_back() -> OutputT:
            # the scene as it is now: agents running beside this one may have changed it meanwhile
            output = self.solve(self.gather(state))
            self._require_usable(output, state, problems)
            return output

        if not quiet:
            _log.warning("agent_fell_back_to_solver", agent=self.name, reason=reason[:200])
        async with state.lock:
            output = await run_blocking(fall_back, offload=self.offload)
        note = f"{self.name}: model output unusable, used the rule solver"
        return tally.result(self.name, output, "solver_fallback", reason, (note,), given_up=quiet)

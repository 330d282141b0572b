"""Task agents: typed units of work that read a scene state and write their answer back to it.

A task agent is typed on the state it works on, its evidence and its output
(``TaskAgent[StateT, EvidenceT, OutputT]``; the output type is the third parameter). It declares a
name, the agents it depends on, how it gathers its evidence, its prompt template
(``prompts/<prompt>.md``), its rule solver (the offline path), which output fields name objects
(checked for unknown and repeated ids by the base class), how else it checks an output against
the scene, and how it applies it. :meth:`TaskAgent.run` returns an :class:`AgentResult` (the
output, its usage, how it was answered, the problems of refused answers) and writes nothing but
the applied output into the state; the runner (``scenemosaic.agents.run_agents``, the evolve
loop) collects the results. The scheduler (``scenemosaic.dag``) turns agents into graph nodes.

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
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Generic, Literal, TypeVar, cast, get_args, get_origin

import structlog
from pydantic import BaseModel, ConfigDict

from scenemosaic.agents._evidence import TABLE_NOTE, evidence_legend, evidence_text
from scenemosaic.exceptions import (
    AgentOutputError,
    ModelConfigError,
    ModelContextLengthError,
    ModelEndpointError,
    ModelError,
    ModelHTTPError,
    OutputValidationError,
    ReplayMissError,
    UsageError,
)
from scenemosaic.models import ImagePart, Message, Model, ModelSettings, RequestContext, TextPart, Usage
from scenemosaic.scene import MAX_OBJECTS, Scene

__all__ = [
    "MAX_ITEMS",
    "PROMPTS_FOLDER",
    "AgentOutcome",
    "AgentOutput",
    "AgentPolicy",
    "AgentResult",
    "FallbackRecord",
    "SceneState",
    "TaskAgent",
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

    def __post_init__(self) -> None:
        if self.max_attempts < 1:
            raise UsageError(f"max_attempts must be >= 1, got {self.max_attempts}")


@dataclass(frozen=True)
class FallbackRecord:
    """One agent answered by its rule solver instead of the model, and why."""

    agent: str
    reason: str


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
    """What one :meth:`TaskAgent.run` produced; the output is already applied to the state.

    ``outcome`` says how the answer came about (model, rules, solver without a call, or solver
    fallback with the reason); ``fallback`` is the record of a solver fallback (``None`` when the
    answer is the model's or the rules'); ``problems`` holds the check's problems with each model
    answer that was refused, in order (schema errors not included).
    """

    output: OutputT
    outcome: AgentOutcome
    usage: Usage = field(default_factory=Usage)
    problems: tuple[tuple[str, ...], ...] = ()
    fallback: FallbackRecord | None = None

    @property
    def agent(self) -> str:
        """The agent's name."""
        return self.outcome.agent


@dataclass
class SceneState:
    """The shared state task agents read and write during a run.

    ``scene`` is replaced (not mutated behind readers' backs) by ``apply``; ``lock``
    serializes applies so concurrent agents never interleave half-written changes.
    ``outputs`` keeps each agent's applied output by agent name. How each agent's answer came
    about is not kept here: :meth:`TaskAgent.run` returns it (:class:`AgentResult`).
    """

    scene: Scene
    seed: int = 0
    base_dir: Path | None = None
    """Folder relative mesh paths start from (agents that draw the scene's meshes need it)."""
    policy: AgentPolicy = field(default_factory=AgentPolicy)
    outputs: dict[str, BaseModel] = field(default_factory=dict)
    lock: asyncio.Lock = field(default_factory=asyncio.Lock)


REPAIR_ECHO_CHARS = 6000
"""A rejected reply is quoted back at most this long (a runaway reply would fill the context)."""


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


@dataclass
class _Tally:
    """Requests, repairs, usage and refused answers of one agent run, over all its requests."""

    requests: int = 0
    repairs: int = 0
    usage: Usage = field(default_factory=Usage)
    refused: list[tuple[str, ...]] = field(default_factory=list)

    def result(self, agent: str, output: OutputT, answered_by: AnsweredBy, reason: str = "") -> AgentResult[OutputT]:
        fallback = FallbackRecord(agent=agent, reason=reason[:500]) if answered_by == "solver_fallback" else None
        outcome = AgentOutcome(agent, answered_by, self.requests, self.repairs, reason[:300])
        return AgentResult(output, outcome, self.usage, tuple(self.refused), fallback)


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
    * ``offload`` — run :meth:`gather`, :meth:`messages`, :meth:`check` and :meth:`apply`
      in a worker thread (default), holding ``state.lock`` so they still see and leave a
      consistent scene. Set it to ``False`` for an agent whose hooks must run on the event
      loop (e.g. an ``apply`` that adds graph nodes through ``current_context()``).

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

    @abc.abstractmethod
    def apply(self, output: OutputT, state: StateT) -> None:
        """Write a checked output into the scene state."""

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
        return evidence_text(evidence, omit=self.prompt_omit, extra=self.prompt_extra)

    def system_prompt(self, evidence: EvidenceT, *, legend: bool = True) -> str:
        """The template, how to read the evidence and what its fields mean (``legend``), and the
        reply format. The output schema itself travels with the request (a strict
        ``response_format``; a model without one pastes it, see ``OpenAIChatModel``)."""
        parts = [load_prompt(type(self))]
        if legend:
            parts += [TABLE_NOTE, evidence_legend(type(evidence), self.prompt_omit, self.prompt_extra)]
        parts.append("Reply with one JSON object of the requested schema, and nothing else.")
        return "\n\n".join(p for p in parts if p)

    def compact_messages(self, evidence: EvidenceT, state: StateT, *, vision: bool) -> list[Message]:
        """A shorter prompt for a model whose context the full one did not fit: no format note or
        field legend, numbers to 1 dm. Images are kept for vision models."""
        parts: list[TextPart | ImagePart] = [
            TextPart(
                "Evidence:\n" + evidence_text(evidence, digits=1, omit=self.prompt_omit, extra=self.prompt_extra)
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
        """Gather evidence, answer (model or rule solver), check, repair, apply; return the result.

        Scene work runs in a worker thread under ``state.lock`` (see ``offload``); only the
        model request runs without the lock, so concurrent agents overlap on their requests.
        One budget, ``state.policy.max_attempts``, covers every reason to ask again. The state
        receives the applied output (and ``outputs[name]``); how the answer came about is in the
        returned :class:`AgentResult`, for the caller to collect.
        """
        tally = _Tally()
        if model.uses_rule_solvers:
            async with state.lock:
                output = await run_blocking(self._solve_and_apply, state, offload=self.offload)
            return tally.result(self.name, output, "rules")
        async with state.lock:
            evidence, messages, settled = await run_blocking(self._prepare, state, model.vision, offload=self.offload)
            if settled is not None:  # nothing to decide: the solver's answer, checked, no call
                _log.info("agent_answered_without_model", agent=self.name)
                await run_blocking(self._use, settled, state, offload=self.offload)
                return tally.result(self.name, settled, "solver_without_call")
            chunks = self._chunks(evidence)
        if len(chunks) > 1:
            return await self._run_chunked(state, model, settings, evidence, chunks, tally, node=node)
        compact = functools.partial(self.compact_messages, evidence, state, vision=model.vision)
        apply = functools.partial(self._check_and_apply, state=state)
        reply = await self._ask(state, model, settings, evidence, messages, apply, tally, node=node, compact=compact)
        if reply.output is not None:
            return tally.result(self.name, reply.output, "model")
        reason = reply.error or f"unusable after {state.policy.max_attempts} attempts: " + "; ".join(reply.problems)
        if not state.policy.solver_fallback:
            if reply.schema_error is not None:  # the last reply was not even schema-valid: say so, with it
                raise reply.schema_error
            raise AgentOutputError(f"agent {self.name!r} gave an {reason}", agent=self.name, problems=reply.problems)
        return await self._fall_back(state, reason, reply.problems, tally)

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

        ``accept`` (run under the lock) returns an answer's problems, applying it when there are
        none. A reply that is not JSON, breaks the schema or has problems is sent back with them
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
            try:
                tally.requests += 1
                answer, usage = await model.request(messages, self.output_type, settings, context=context)
            except OutputValidationError as exc:  # not JSON, or not the schema: repairable
                reply.schema_error = exc
                tally.usage = tally.usage + (exc.usage if isinstance(exc.usage, Usage) else Usage())
                problems, text = exc.errors or [str(exc)], exc.raw_reply
                intro = f"That reply is not a valid {self.output_type.__name__} JSON object:"
            except (ModelError, ModelEndpointError) as exc:
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
                tally.usage = tally.usage + usage
                output = cast(OutputT, answer)
                async with state.lock:
                    problems = await run_blocking(accept, output, offload=self.offload)
                if not problems:
                    reply.output, reply.problems = output, []
                    return reply
                tally.refused.append(tuple(problems))
                text = output.model_dump_json()
                intro = "That answer cannot be applied to this scene:"
            reply.problems = problems
            if attempt + 1 < policy.max_attempts:
                tally.repairs += 1
                messages = _repair(prompt, text, intro, problems)
        return reply

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
        and replaced by the solver's part when it stays unusable. The merged answer is applied."""
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

        def apply_merged() -> list[str]:
            problems = self._check_and_apply(merged, state)
            if failed and not problems:
                note = f"{self.name}: model answer unusable for part of the scene, used the rule solver there"
                state.scene.provenance.notes.append(note)
            return problems

        async with state.lock:
            problems = await run_blocking(apply_merged, offload=self.offload)
        if problems:  # chunks that each fit, together do not (a cycle across chunks): the solver
            reason = "chunk answers inconsistent together: " + "; ".join(problems)
            return await self._fall_back(state, reason, problems, tally)
        if failed:
            return tally.result(self.name, merged, "solver_fallback", "rule solver for " + ", ".join(failed))
        return tally.result(self.name, merged, "model")

    def _solve_and_apply(self, state: StateT) -> OutputT:
        """The rules path: the agent's own solver answers; its output must pass the agent's check."""
        output = self.solve(self.gather(state))
        self._use(output, state)
        return output

    def _prepare(self, state: StateT, vision: bool) -> tuple[EvidenceT, list[Message], OutputT | None]:
        evidence = self.gather(state)
        settled = self.answer_without_model(evidence)
        messages = self.messages(evidence, state, vision=vision) if settled is None else []
        return evidence, messages, settled

    def _use(self, output: OutputT, state: StateT) -> None:
        """Check and apply a solver answer (caller holds the lock)."""
        self._require_usable(output, state, [])
        self._apply_output(output, state)

    def _apply_output(self, output: OutputT, state: StateT) -> None:
        self.apply(output, state)
        state.outputs[self.name] = output

    def _check_and_apply(self, output: OutputT, state: StateT) -> list[str]:
        """Problems with ``output``; when there are none, it is applied (caller holds the lock)."""
        problems = self.problems(output, state)
        if not problems:
            self._apply_output(output, state)
        return problems

    def _require_usable(self, output: OutputT, state: StateT, model_problems: list[str]) -> None:
        solver_problems = self.problems(output, state)
        if solver_problems:  # the solver itself is wrong: a bug worth failing loudly on
            what = "the model's output and the rule solver's are" if model_problems else "the rule solver's output is"
            raise AgentOutputError(
                f"agent {self.name!r}: {what} unusable: " + "; ".join(model_problems + solver_problems),
                agent=self.name,
                problems=model_problems + solver_problems,
            )

    async def _fall_back(self, state: StateT, reason: str, problems: list[str], tally: _Tally) -> AgentResult[OutputT]:
        def fall_back() -> OutputT:
            # the scene as it is now: agents running beside this one may have changed it meanwhile
            output = self.solve(self.gather(state))
            self._require_usable(output, state, problems)
            self._apply_output(output, state)
            state.scene.provenance.notes.append(f"{self.name}: model output unusable, used the rule solver")
            return output

        _log.warning("agent_fell_back_to_solver", agent=self.name, reason=reason[:200])
        async with state.lock:
            output = await run_blocking(fall_back, offload=self.offload)
        return tally.result(self.name, output, "solver_fallback", reason)

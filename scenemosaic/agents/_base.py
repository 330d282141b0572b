"""Task agents: typed units of work that read the shared scene state and write back to it.

A task agent declares a name, the agents it depends on, how it gathers its evidence,
its prompt template (``prompts/<prompt>.md``), its pydantic output type, its rule solver
(the offline path), how it checks an output against the scene, and how it applies it.
The scheduler (``scenemosaic.dag``) turns agents into graph nodes and runs them.

Plugins are subclasses (or any object with the same attributes) passed in by the caller;
there is no global registry.
"""

from __future__ import annotations

import abc
import asyncio
import contextvars
import functools
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel

from scenemosaic.exceptions import AgentOutputError
from scenemosaic.models._base import ImagePart, Message, Model, ModelSettings, RequestContext, TextPart, Usage
from scenemosaic.scene import Scene

__all__ = ["PROMPTS_DIR", "SceneState", "TaskAgent", "load_prompt", "run_blocking"]

PROMPTS_DIR = Path(__file__).resolve().parent.parent / "_prompts"
"""Where prompt templates live inside the installed package (``prompts/`` at the repo root links here)."""

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


def load_prompt(name: str) -> str:
    """Text of ``<name>.md`` from the prompts folder."""
    path = PROMPTS_DIR / f"{name}.md"
    return path.read_text(encoding="utf-8")


@dataclass
class SceneState:
    """The shared state task agents read and write during a run.

    ``scene`` is replaced (not mutated behind readers' backs) by ``apply``; ``lock``
    serializes applies so concurrent agents never interleave half-written changes.
    ``outputs`` keeps each agent's validated output by agent name.
    """

    scene: Scene
    seed: int = 0
    outputs: dict[str, BaseModel] = field(default_factory=dict)
    artifacts: dict[str, Any] = field(default_factory=dict)
    lock: asyncio.Lock = field(default_factory=asyncio.Lock)


class TaskAgent(abc.ABC, Generic[EvidenceT, OutputT]):
    """Base class of every task agent.

    Class attributes to set in a subclass:

    * ``name`` — unique node name in a graph.
    * ``depends_on`` — names of agents whose outputs this one needs.
    * ``prompt`` — prompt template file name (without ``.md``) under ``prompts/``.
    * ``output_type`` — the pydantic model a reply must validate as.
    * ``max_repairs`` — how many times an output that fails :meth:`check` is sent back.
    * ``offload`` — run :meth:`gather`, :meth:`messages`, :meth:`check` and :meth:`apply`
      in a worker thread (default), holding ``state.lock`` so they still see and leave a
      consistent scene. Set it to ``False`` for an agent whose hooks must run on the event
      loop (e.g. an ``apply`` that adds graph nodes through ``current_context()``).
    """

    name: ClassVar[str]
    depends_on: ClassVar[tuple[str, ...]] = ()
    prompt: ClassVar[str]
    output_type: ClassVar[type[BaseModel]]
    max_repairs: ClassVar[int] = 2
    offload: ClassVar[bool] = True

    # -- what a subclass provides ------------------------------------------------------------
    @abc.abstractmethod
    def gather(self, state: SceneState) -> EvidenceT:
        """Collect this agent's structured evidence from the scene state."""

    @abc.abstractmethod
    def solve(self, evidence: EvidenceT) -> OutputT:
        """The deterministic offline solver: evidence in, output out."""

    def check(self, output: OutputT, state: SceneState) -> list[str]:
        """Problems that make ``output`` unusable on this scene (unknown ids, cycles...).

        Each problem is a sentence a model can act on; an empty list means usable.
        """
        return []

    @abc.abstractmethod
    def apply(self, output: OutputT, state: SceneState) -> None:
        """Write a checked output into the scene state."""

    def images(self, evidence: EvidenceT, state: SceneState) -> list[ImagePart]:
        """Images to send to vision models (none by default)."""
        return []

    def render_evidence_text(self, evidence: EvidenceT) -> str:
        """Text rendering of the evidence (also what text-only models get instead of images)."""
        return json.dumps(evidence.model_dump(mode="json"), indent=1, sort_keys=True)

    # -- the generic run loop ----------------------------------------------------------------
    def messages(self, evidence: EvidenceT, state: SceneState, *, vision: bool) -> list[Message]:
        """System prompt from the template, then the evidence as text (and images for vision models)."""
        schema = json.dumps(self.output_type.model_json_schema(), sort_keys=True)
        system = load_prompt(self.prompt) + "\n\nReply with one JSON object matching this schema:\n" + schema
        parts: list[TextPart | ImagePart] = [TextPart("Evidence:\n" + self.render_evidence_text(evidence))]
        if vision:
            parts.extend(self.images(evidence, state))
        return [Message.text("system", system), Message(role="user", parts=tuple(parts))]

    async def run(
        self,
        state: SceneState,
        model: Model,
        settings: ModelSettings | None = None,
        *,
        node: str | None = None,
    ) -> tuple[OutputT, Usage]:
        """Gather evidence, ask the model, check (repairing up to ``max_repairs`` times), apply.

        Scene work runs in a worker thread under ``state.lock`` (see ``offload``); only the
        model request runs without the lock, so concurrent agents overlap on their requests.
        """
        vision = model.vision
        async with state.lock:
            evidence, messages = await run_blocking(self._prepare, state, vision, offload=self.offload)
        context = RequestContext(agent=self.name, node=node or self.name, evidence=evidence, solve=self.solve)
        total = Usage()
        problems: list[str] = []
        for attempt in range(self.max_repairs + 1):
            output, usage = await model.request(messages, self.output_type, settings, context=context)  # type: ignore[arg-type]
            total = total + usage
            async with state.lock:
                problems = await run_blocking(self._check_and_apply, output, state, offload=self.offload)
            if not problems:
                return output, total  # type: ignore[return-value]
            if attempt < self.max_repairs:
                messages = [
                    *messages,
                    Message.text("assistant", output.model_dump_json()),
                    Message.text(
                        "user",
                        "That answer cannot be applied to this scene:\n- "
                        + "\n- ".join(problems)
                        + "\nReply again with a corrected JSON object.",
                    ),
                ]
        if getattr(model, "solver_fallback", False):
            async with state.lock:
                fallback = await run_blocking(
                    self._fall_back_and_apply, evidence, state, model, problems, offload=self.offload
                )
            return fallback, total
        raise AgentOutputError(
            f"agent {self.name!r} gave an unusable output after {self.max_repairs} repairs: {'; '.join(problems)}",
            agent=self.name,
            problems=problems,
        )

    def _prepare(self, state: SceneState, vision: bool) -> tuple[EvidenceT, list[Message]]:
        evidence = self.gather(state)
        return evidence, self.messages(evidence, state, vision=vision)

    def _check_and_apply(self, output: OutputT, state: SceneState) -> list[str]:
        """Problems with ``output``; when there are none, it is applied (caller holds the lock)."""
        problems = self.check(output, state)
        if not problems:
            self.apply(output, state)
            state.outputs[self.name] = output
        return problems

    def _fall_back_and_apply(
        self, evidence: EvidenceT, state: SceneState, model: Model, problems: list[str]
    ) -> OutputT:
        output = self._fall_back(evidence, state, model, problems)
        self.apply(output, state)
        state.outputs[self.name] = output
        state.scene.provenance.notes.append(f"{self.name}: model output unusable, used the rule solver")
        return output

    def _fall_back(
        self, evidence: EvidenceT, state: SceneState, model: Model, problems: list[str]
    ) -> OutputT:
        """Use the rule solver's answer (the model asked for it through ``solver_fallback``)."""
        output = self.solve(evidence)
        solver_problems = self.check(output, state)
        if solver_problems:  # the solver itself is wrong: a bug worth failing loudly on
            raise AgentOutputError(
                f"agent {self.name!r}: the model's output and the rule solver's are both unusable: "
                + "; ".join(problems + solver_problems),
                agent=self.name,
                problems=problems + solver_problems,
            )
        record = getattr(model, "record", None)
        if callable(record):
            record(self.name, "unusable after repairs: " + "; ".join(problems))
        return output

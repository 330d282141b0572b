"""``QualityBreaker``: stop asking the model for a kind of answer it keeps getting wrong.

:class:`~scenemosaic.models.CircuitBreakerModel` watches the endpoint (a server that is down).
This breaker watches what a working server sends back, one *kind* at a time: the kind is the
asking agent's name (``RequestContext.agent``: ``support``, ``walls``, ``critic``, ...). A reply
is *unusable* when it is not JSON, breaks the output schema, is cut off at the token cap, or is
refused by the agent's own checks; it is *usable* when the agent takes it. After ``threshold``
unusable replies of one kind with no usable one between them, the kind is *given up*: for the
rest of the run its agents answer with their rule solvers without asking (said once, as a warning
naming the kind, how many requests it was asked and the last reply's fault). A kind that answers
usably keeps being asked; a kind given up stays given up until the run ends.

Concurrency cannot overrun the threshold: while a kind has given no usable reply in the run, at
most ``threshold`` minus its unusable replies so far are out at once, and a further request of
that kind waits for one to come back (:meth:`QualityBreaker.admit` hands out a :class:`Ticket`,
which the asker settles with the reply's verdict). A kind that has answered
usably once is no longer held back. So a model that cannot do a kind is asked for it at most
``threshold`` times in the whole run.

The agents layer reports to it (``AgentPolicy.quality``); the run's model stack owns one per run
(:attr:`~scenemosaic.models.RunModel.quality`), shared by every stage and every room.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field
from typing import Any

import structlog

from scenemosaic.exceptions import ModelConfigError

__all__ = ["DEFAULT_UNUSABLE_REPLIES", "GivenUp", "QualityBreaker", "Ticket"]

log = structlog.get_logger(__name__)

DEFAULT_UNUSABLE_REPLIES = 2
"""Unusable replies of one kind, with no usable one between, after which a run stops asking for it.
Two: one repair of a first bad reply is still tried; a model that fails the repair too is not asked
again for that kind, since each further try of a small local model costs seconds to tens of seconds
(the shared 0.5B server: 6 to 40 s a structure request on two cores, ``benchmarks/real_model.py``)."""


@dataclass(frozen=True)
class GivenUp:
    """A kind the run stopped asking the model for."""

    kind: str
    """The agent's name."""
    requests: int
    """Requests of this kind that had been sent when it was given up."""
    usable: int
    """Usable replies of this kind before (an earlier run of the agent may have answered well)."""
    reason: str
    """The last unusable reply's fault, in words (or why the run stopped asking, for ``deadline``)."""
    cause: str = "unusable"
    """``unusable``: the kind's own replies; ``deadline``: the run's deadline for model requests
    passed, which stops every kind (:meth:`QualityBreaker.stop`)."""

    def words(self) -> str:
        """One line: the kind, after how many requests, why."""
        if self.cause == "deadline":
            return f"{self.kind}: not asked after the deadline ({self.reason[:160]})"
        return f"{self.kind}: given up after {self.requests} requests ({self.reason[:160]})"


@dataclass
class _Kind:
    requests: int = 0
    usable: int = 0
    unusable: int = 0
    streak: int = 0
    out: int = 0
    given_up: GivenUp | None = None
    answers: dict[str, int] = field(default_factory=dict)
    """Agent runs of this kind by how they were answered (``model``, ``repaired``, ``solver_fallback``, ...)."""
    reasons: dict[str, int] = field(default_factory=dict)
    """Why the solver answered, by reason's first words (a handful per kind)."""


@dataclass
class Ticket:
    """One request of a kind the breaker let out (:meth:`QualityBreaker.admit`), or its refusal:
    ``given_up`` is the kind's record when nothing may be sent. The asker settles an admitted
    ticket once: :meth:`usable`, :meth:`unusable`, or :meth:`close` (no reply to judge: a
    time-out, a refused connection, a prompt over the context window, a cancelled run)."""

    kind: str
    given_up: GivenUp | None = None
    _breaker: QualityBreaker | None = field(default=None, repr=False)

    def _take(self) -> QualityBreaker | None:
        breaker, self._breaker = self._breaker, None
        return breaker

    def usable(self) -> None:
        """The reply was taken by the agent."""
        breaker = self._take()
        if breaker is not None:
            breaker._settle(self.kind, None)

    def unusable(self, fault: str) -> GivenUp | None:
        """The reply could not be taken (``fault`` says why); the kind's record when this reply
        gives it up, else ``None``."""
        breaker = self._take()
        return breaker._settle(self.kind, fault) if breaker is not None else None

    def close(self, *, sent: bool = True) -> None:
        """No reply to judge (counts neither way; ``sent=False``: the request never left, it is not
        counted as one); nothing when the ticket was settled already."""
        breaker = self._take()
        if breaker is not None:
            if not sent:
                state = breaker._kind(self.kind)
                state.requests = max(state.requests - 1, 0)
            breaker._release(self.kind)


@dataclass
class QualityBreaker:
    """Per agent kind: unusable replies in a row, and the kinds given up (see the module docstring).

    ``threshold`` — unusable replies in a row that give a kind up (at least 1); ``None``: no kind
    is given up, the replies and answers are only counted (the report's account).
    """

    threshold: int | None = DEFAULT_UNUSABLE_REPLIES
    stopped: str | None = None
    """Why the run asks no kind any more (its deadline passed), else ``None``."""
    _kinds: dict[str, _Kind] = field(default_factory=dict, repr=False)
    _changed: asyncio.Event | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.threshold is not None and self.threshold < 1:
            raise ModelConfigError(f"the unusable replies that give a kind up must be at least 1, got {self.threshold}")

    def _kind(self, kind: str) -> _Kind:
        return self._kinds.setdefault(kind, _Kind())

    def given_up(self, kind: str) -> GivenUp | None:
        """The record of ``kind`` when the run has stopped asking for it, else ``None``."""
        state = self._kind(kind)
        if state.given_up is None and self.stopped is not None:
            state.given_up = GivenUp(kind, state.requests, state.usable, self.stopped, "deadline")
        return state.given_up

    def stop(self, reason: str) -> None:
        """Ask no kind any more (the run's deadline for model requests passed: ``reason``); every
        later agent answers with its rule solver without trying, quietly (the caller says it once)."""
        if self.stopped is None:
            self.stopped = reason
            log.warning("model_deadline_passed", reason=reason[:200], then="every agent uses its rule solver from now on")
            if self._changed is not None:
                self._changed.set()
                self._changed = None

    async def admit(self, kind: str) -> Ticket:
        """Wait until a request of ``kind`` may be sent and count it out; the ticket's
        ``given_up`` is set instead when the kind is given up (then nothing may be sent)."""
        state = self._kind(kind)
        while (
            self.threshold is not None
            and self.given_up(kind) is None
            and state.usable == 0
            and state.streak + state.out >= self.threshold
        ):
            if self._changed is None:
                self._changed = asyncio.Event()
            await self._changed.wait()
        if self.given_up(kind) is not None:
            return Ticket(kind, state.given_up)
        state.out += 1
        state.requests += 1
        return Ticket(kind, None, self)

    def _release(self, kind: str) -> None:
        state = self._kind(kind)
        state.out = max(state.out - 1, 0)
        if self._changed is not None:  # wake every waiter; they look again at their kind
            self._changed.set()
            self._changed = None

    def _settle(self, kind: str, fault: str | None) -> GivenUp | None:
        state = self._kind(kind)
        if fault is None:
            state.usable += 1
            state.streak = 0
        else:
            state.unusable += 1
            state.streak += 1
            if state.given_up is None and self.threshold is not None and state.streak >= self.threshold:
                state.given_up = GivenUp(kind, state.requests, state.usable, fault)
                log.warning(
                    "model_kind_given_up", kind=kind, requests=state.requests, reason=fault[:200],
                    then="its agents use their rule solvers for the rest of the run",
                )  # fmt: skip
        self._release(kind)
        return state.given_up if fault is not None else None

    def answered(self, kind: str, answered_by: str, repairs: int, reason: str = "") -> None:
        """One agent run of ``kind`` ended: ``answered_by`` as the agent's outcome says (``model``
        with ``repairs`` above 0 is counted as ``repaired``), ``reason`` a fallback's."""
        state = self._kind(kind)
        how = "repaired" if answered_by == "model" and repairs else answered_by
        state.answers[how] = state.answers.get(how, 0) + 1
        if reason and answered_by == "solver_fallback":
            key = reason.split(";")[0].split(":")[0][:80]
            if key in state.reasons or len(state.reasons) < 5:
                state.reasons[key] = state.reasons.get(key, 0) + 1

    def summary(self) -> dict[str, Any]:
        """Per kind asked: replies (requests, usable, unusable), agent runs by how they were
        answered (``answers``: ``model`` first time, ``repaired``, ``solver_fallback``,
        ``solver_without_call``) with the fallbacks' reasons, whether (and why) the kind was given
        up; and the kinds given up, in words (the report's ``model``)."""
        kinds = {
            kind: {
                "requests": s.requests,
                "usable": s.usable,
                "unusable": s.unusable,
                "answers": dict(sorted(s.answers.items())),
                "given_up": s.given_up is not None and s.given_up.cause == "unusable",
                **({"reason": s.given_up.reason[:300]} if s.given_up is not None else {}),
                **({"after_deadline": True} if s.given_up is not None and s.given_up.cause == "deadline" else {}),
                **({"fallback_reasons": dict(s.reasons)} if s.reasons else {}),
            }
            for kind, s in sorted(self._kinds.items())
            if s.requests or s.answers or s.given_up is not None
        }
        return {
            "threshold": self.threshold,
            "kinds": kinds,
            "given_up": [
                s.given_up.words() for _, s in sorted(self._kinds.items()) if s.given_up and s.given_up.cause == "unusable"
            ],
            "stopped": self.stopped,
        }

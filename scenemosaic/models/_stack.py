"""One model stack per run: the configured model opened once, with every wrapper a run needs.

:func:`open_run_model` builds, from a model string or instance and the run's limits, the model
every stage's agents ask::

    parse_model(spec)                  (slot count of a llama.cpp server bounds the concurrency)
      -> LimitedModel                  client-side request / token rates (shared between processes)
      -> CachedModel                   on-disk reply cache: a cached answer waits for no budget
      -> InstrumentedModel             a UsageRecord per call, into the run's UsageTracker
      -> CircuitBreakerModel           an endpoint that keeps failing is refused at once
      -> DeadlineModel                 the run's wall-clock budget for all model requests

beside it, a :class:`~scenemosaic.models.QualityBreaker` the agents report their replies to (a
kind of answer the model keeps getting wrong is no longer asked for).

It is entered once around the whole run, so the breaker, the deadline and the usage are the
run's: a breaker that tripped during structuring stays open for evolution. The tracker holds
every call of the run; a stage reads its own agents' usage from its agent log (the agents layer's
``AgentLog``, in the same :func:`usage_summary` shape), and the calls since a
:meth:`RunModel.mark` reading otherwise. The offline ``rules`` model gets only the
instrumentation (it makes no requests).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

from scenemosaic.models._base import Model, ModelSettings, Usage
from scenemosaic.models._cache import CachedModel
from scenemosaic.models._circuit import CircuitBreakerModel
from scenemosaic.models._deadline import DeadlineModel
from scenemosaic.models._http import CallClock
from scenemosaic.models._instrument import InstrumentedModel
from scenemosaic.models._limit import LimitedModel, RateLimiter
from scenemosaic.models._openai import OpenAIChatModel
from scenemosaic.models._parse import parse_model
from scenemosaic.models._quality import DEFAULT_UNUSABLE_REPLIES, QualityBreaker
from scenemosaic.models._usage import UsageRecord, UsageTracker

__all__ = ["RunModel", "RunModelSettings", "open_run_model", "server_slots", "usage_summary"]


@dataclass(frozen=True)
class RunModelSettings:
    """What a run says about its model; each field mirrors the ``GenerateConfig`` field of the same name."""

    vision: bool | None = None
    """Force the model's vision setting; ``None`` keeps its default."""
    max_concurrency: int | None = None
    """Most requests in flight; ``None``: the server's slot count when it reports one."""
    request_timeout_s: float | None = None
    """Time-out of one request; ``None`` keeps the model's own."""
    deadline_s: float | None = None
    """Wall-clock budget for all the run's requests, counted from ``started``."""
    requests_per_minute: float | None = None
    """Client-side request rate."""
    tokens_per_minute: float | None = None
    """Client-side token rate."""
    rate_limit_dir: Path | None = None
    """Folder the rates are shared through (a batch's workers)."""
    reply_cache: Path | None = None
    """Folder of the on-disk reply cache."""
    unusable_replies: int = DEFAULT_UNUSABLE_REPLIES
    """Unusable replies of one agent kind in a row after which the run stops asking the model for
    it (:class:`~scenemosaic.models.QualityBreaker`); 0: keep asking (the replies are still counted)."""


@dataclass
class RunModel:
    """The run's model stack (see the module docstring); an async context manager that closes
    the model it opened (a caller's model instance stays the caller's to close)."""

    model: Model
    """What the agents ask: the whole stack."""
    tracker: UsageTracker
    """Every call of the run."""
    settings: ModelSettings | None
    """Per-request settings every agent passes (the request time-out), or ``None``."""
    detail: dict[str, Any] = field(default_factory=dict)
    """How the stack was built, for the report: model name, concurrency, rate limits, reply cache."""
    clock: CallClock = field(default_factory=CallClock)
    """The run's one clock for every outbound call (the request time-out and the deadline): the
    model stack and the perception backends' HTTP clients read it."""
    quality: QualityBreaker | None = None
    """The run's judge of the model's replies per agent kind, and its account of them (``None``: the
    rules model); the agents report to it through their policy."""
    _opened: Model | None = None

    @property
    def uses_rule_solvers(self) -> bool:
        """Whether the run's model is the offline rules model."""
        return self.model.uses_rule_solvers

    def account(self) -> dict[str, Any] | None:
        """The model's work over the whole run, per agent kind (``report.json``'s ``model``): its
        requests, tokens and seconds (every call), its replies' verdicts and the agent runs by how
        they were answered (:meth:`QualityBreaker.summary`); the kinds given up; one line of words.
        ``None`` for the rules model."""
        if self.quality is None:
            return None
        summary = self.quality.summary()
        spent: dict[str, dict[str, float]] = {}
        for c in self.tracker.calls:
            row = spent.setdefault(c.agent, {"input_tokens": 0, "output_tokens": 0, "seconds": 0.0})
            row["input_tokens"] += c.usage.input_tokens
            row["output_tokens"] += c.usage.output_tokens
            row["seconds"] += c.latency_s
        kinds: dict[str, dict[str, Any]] = {}
        for kind in sorted(set(summary["kinds"]) | set(spent)):
            row = dict(summary["kinds"].get(kind, {}))
            used = spent.get(kind, {})
            row["input_tokens"] = int(used.get("input_tokens", 0))
            row["output_tokens"] = int(used.get("output_tokens", 0))
            row["seconds"] = round(used.get("seconds", 0.0), 3)
            kinds[kind] = row
        asked = [k for k, r in kinds.items() if {"model", "repaired", "solver_fallback"} & set(r.get("answers", {}))]
        solver = {
            k: "given up" if kinds[k].get("given_up") else "deadline" if kinds[k].get("after_deadline") else "fell back"
            for k in asked
            if kinds[k].get("answers", {}).get("solver_fallback")
        }
        line = f"{len(asked) - len(solver)} of {len(asked)} agent kinds usable"
        if solver:
            line += "; solver for " + ", ".join(f"{k} ({why})" for k, why in solver.items())
        return {
            "model": self.detail.get("model"),
            "unusable_replies": summary["threshold"] or 0,
            **{k: self.detail[k] for k in ("deadline_s", "deadline") if k in self.detail},
            "summary": line,
            "kinds": kinds,
            "given_up": summary["given_up"],
            "stopped": summary["stopped"],
        }

    def mark(self) -> int:
        """A reading of the usage so far; :meth:`usage_since` takes it."""
        return len(self.tracker.calls)

    def calls_since(self, mark: int) -> list[UsageRecord]:
        """The calls made after ``mark``."""
        return self.tracker.calls[mark:]

    def usage_since(self, mark: int) -> dict[str, Any]:
        """Requests, tokens and latencies of the calls made after ``mark``, in total and per agent."""
        return usage_summary(self.calls_since(mark))

    async def aclose(self) -> None:
        """Close the model this stack opened (none when the caller gave an instance)."""
        if self._opened is not None:
            opened, self._opened = self._opened, None
            await opened.aclose()

    async def __aenter__(self) -> RunModel:
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.aclose()


def usage_summary(calls: list[UsageRecord]) -> dict[str, Any]:
    """Requests, tokens and latencies of ``calls``, in total and per agent (``report.json``)."""
    total = Usage()
    by_agent: dict[str, Usage] = {}
    for c in calls:
        total = total + c.usage
        by_agent[c.agent] = by_agent.get(c.agent, Usage()) + c.usage
    latencies = sorted(c.latency_s for c in calls)
    return {
        "requests": total.requests,
        "cached": total.cached,
        "input_tokens": total.input_tokens,
        "output_tokens": total.output_tokens,
        "image_tokens": total.image_tokens,
        "failed_calls": sum(1 for c in calls if not c.ok),
        "latency_s": {
            "mean": round(sum(latencies) / len(latencies), 4) if latencies else 0.0,
            "max": round(latencies[-1], 4) if latencies else 0.0,
        },
        "by_agent": {
            agent: {"requests": u.requests, "input_tokens": u.input_tokens, "output_tokens": u.output_tokens}
            for agent, u in sorted(by_agent.items())
        },
    }


async def server_slots(spec: str, vision: bool | None) -> int | None:
    """The slot count the OpenAI-compatible server behind ``spec`` reports, if it reports one."""
    if spec == "rules" or spec.startswith("replay:"):
        return None
    probe = parse_model(spec, vision=vision)
    inner: Any = probe
    while not isinstance(inner, OpenAIChatModel) and getattr(inner, "wrapped", None) is not None:
        inner = inner.wrapped
    try:
        return await inner.server_slots() if isinstance(inner, OpenAIChatModel) else None
    finally:
        await probe.aclose()


async def open_run_model(
    spec: str | Model, settings: RunModelSettings | None = None, *, started: float | None = None
) -> RunModel:
    """Open the run's model stack for ``spec`` (a model string, opened and later closed here, or a
    :class:`Model` instance, which stays the caller's). ``started`` (``time.monotonic()``) is when
    the run began: its deadline counts from there (default: now)."""
    cfg = settings or RunModelSettings()
    detail: dict[str, Any] = {}
    opened: Model | None = None
    if isinstance(spec, str):
        limit = cfg.max_concurrency or await server_slots(spec, cfg.vision)
        extra: dict[str, Any] = {"max_concurrency": limit} if limit else {}
        if cfg.request_timeout_s and spec.startswith("openai:"):
            extra["timeout_s"] = cfg.request_timeout_s  # the images endpoint's attempts too
        base = parse_model(spec, vision=cfg.vision, **extra)
        opened = base
        if limit:
            detail["max_concurrency"] = limit
    else:
        base = spec
    detail["model"] = base.name
    tracker = UsageTracker()
    model = base
    if not base.uses_rule_solvers:
        if cfg.requests_per_minute or cfg.tokens_per_minute:
            limiter = RateLimiter(
                requests_per_minute=cfg.requests_per_minute,
                tokens_per_minute=cfg.tokens_per_minute,
                shared_dir=cfg.rate_limit_dir,
                key=base.name,
            )
            model = LimitedModel(model, limiter)
            detail["rate_limits"] = {
                "requests_per_minute": cfg.requests_per_minute,
                "tokens_per_minute": cfg.tokens_per_minute,
                "shared": str(cfg.rate_limit_dir) if cfg.rate_limit_dir else None,
            }
        if cfg.reply_cache is not None:
            detail["reply_cache"] = str(cfg.reply_cache)
            model = CachedModel(model, cfg.reply_cache)
    model = InstrumentedModel(model, on_call=tracker.on_call)
    clock = CallClock.starting(cfg.request_timeout_s, cfg.deadline_s, started)
    if not base.uses_rule_solvers:
        model = CircuitBreakerModel(model)
        if cfg.deadline_s is not None:  # the run's budget: what was spent before opening is gone
            elapsed = time.monotonic() - started if started is not None else 0.0
            model = DeadlineModel(model, max(cfg.deadline_s - elapsed, 0.001), shown_s=cfg.deadline_s)
    request = ModelSettings(timeout_s=cfg.request_timeout_s) if cfg.request_timeout_s else None
    quality = None
    if not base.uses_rule_solvers:
        quality = QualityBreaker(cfg.unusable_replies or None)
        detail["unusable_replies"] = cfg.unusable_replies
    return RunModel(
        model=model, tracker=tracker, settings=request, detail=detail, clock=clock, quality=quality, _opened=opened
    )

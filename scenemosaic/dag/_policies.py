"""Per-node policies: retry, timeout, cache. Small frozen dataclasses, graph-wide defaults.

A :class:`NodePolicy` bundles the three. A field left at ``None`` means "use the graph-wide
default" (the ``defaults`` a :class:`~scenemosaic.dag.Runner` is given), and the built-in
default when that is ``None`` too: one attempt, no timeout, caching on.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["CachePolicy", "NodePolicy", "RetryPolicy", "TimeoutPolicy"]


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How often and how patiently a failing node is tried again.

    The delay before retry ``k`` (``k = 1`` after the first failure) is
    ``min(max_backoff_s, initial_backoff_s * multiplier ** (k - 1))``, then spread by ``jitter``.
    """

    attempts: int = 1
    """Total tries including the first; ``1`` means no retry."""
    initial_backoff_s: float = 0.5
    """Delay in seconds before the first retry."""
    max_backoff_s: float = 30.0
    """Upper bound in seconds on any single delay (before jitter)."""
    multiplier: float = 2.0
    """Factor applied to the delay after each failed retry (exponential backoff)."""
    jitter: float = 0.1
    """Relative spread: each delay is multiplied by a factor drawn uniformly from
    ``[1 - jitter, 1 + jitter]`` with the node's seed, so reruns wait the same."""
    retry_on: tuple[type[BaseException], ...] = (Exception,)
    """Exception types worth another try; anything else fails the node at once.
    :class:`~scenemosaic.exceptions.NodeTimeoutError` counts as a ``TimeoutError``.
    A :class:`~scenemosaic.exceptions.UsageLimitExceeded` is never retried."""

    def __post_init__(self) -> None:
        if self.attempts < 1:
            raise ValueError(f"RetryPolicy.attempts must be >= 1, got {self.attempts}")
        if self.initial_backoff_s < 0 or self.max_backoff_s < 0 or self.multiplier < 0:
            raise ValueError("RetryPolicy backoff values must be non-negative")
        if not 0.0 <= self.jitter <= 1.0:
            raise ValueError(f"RetryPolicy.jitter must lie in [0, 1], got {self.jitter}")

    def delay_s(self, retry: int, rng: random.Random) -> float:
        """Seconds to wait before retry number ``retry`` (1-based)."""
        base = min(self.max_backoff_s, self.initial_backoff_s * self.multiplier ** (retry - 1))
        if self.jitter:
            base *= 1.0 + rng.uniform(-self.jitter, self.jitter)
        return max(0.0, base)


@dataclass(frozen=True, slots=True)
class TimeoutPolicy:
    """A wall-clock limit on one attempt of a node."""

    timeout_s: float | None = None
    """Seconds one attempt may run before it is cancelled and counts as a
    :class:`~scenemosaic.exceptions.NodeTimeoutError`; ``None`` waits forever."""


@dataclass(frozen=True, slots=True)
class CachePolicy:
    """Whether a node's output is looked up in and written to the run store."""

    enabled: bool = True
    """Skip the node when the store already holds an output for its input hash."""
    key_fn: Callable[[Mapping[str, Any]], str] | None = None
    """Extra cache key from the node's dependency outputs (by name), mixed into the input hash.
    Use it for inputs a node reads from outside the graph (a file's content hash, an env value),
    so the stored output is not reused when they change."""


@dataclass(frozen=True, slots=True)
class NodePolicy:
    """The policies of one node; ``None`` fields fall back to the graph-wide defaults."""

    retry: RetryPolicy | None = None
    """Retry policy; default: one attempt."""
    timeout: TimeoutPolicy | None = None
    """Timeout per attempt; default: none."""
    cache: CachePolicy | None = None
    """Run-store caching; default: enabled (it only matters when the run has a store)."""

    def merged_over(self, defaults: NodePolicy) -> NodePolicy:
        """This policy with its ``None`` fields taken from ``defaults``."""
        return NodePolicy(
            retry=self.retry if self.retry is not None else defaults.retry,
            timeout=self.timeout if self.timeout is not None else defaults.timeout,
            cache=self.cache if self.cache is not None else defaults.cache,
        )


DEFAULT_RETRY = RetryPolicy()
DEFAULT_TIMEOUT = TimeoutPolicy()
DEFAULT_CACHE = CachePolicy()

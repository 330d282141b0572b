"""A bounded, thread-safe, in-process memo: the one way the package keeps values it derived from a key.

Collision shapes, hull meshes and exported mesh files are pure functions of a content key (a hash
of the vertices, an asset's fingerprint); a house run asks for the same ones in every stage and
every variant. :class:`Memo` keeps them for the life of the process, dropping the oldest entry
when it holds ``limit`` of them, or until :func:`forget_memos` (a house run's worker, kept for the
next run, forgets what this one derived). What it hands out is shared: callers never modify it.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar

__all__ = ["Memo", "forget_memos"]

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class Memo(Generic[K, V]):
    """Values by key, made at most once each while they stay in (two threads asking for a missing
    key at once may both make it; the first stored wins, and both are equal by construction)."""

    def __init__(self, limit: int) -> None:
        if limit < 1:
            raise ValueError(f"a memo holds at least one value, not {limit}")
        self.limit = limit
        """Most values held; the oldest goes first."""
        self._values: dict[K, V] = {}
        self._lock = threading.Lock()
        _MEMOS.add(self)

    def get(self, key: K, make: Callable[[], V]) -> V:
        """The value kept for ``key``, made by ``make()`` (outside the lock) when missing."""
        with self._lock:
            if key in self._values:
                return self._values[key]
        value = make()
        with self._lock:
            if key in self._values:
                return self._values[key]
            if len(self._values) >= self.limit:
                self._values.pop(next(iter(self._values)))
            self._values[key] = value
        return value

    def __len__(self) -> int:
        with self._lock:
            return len(self._values)

    def clear(self) -> None:
        """Forget every value."""
        with self._lock:
            self._values.clear()


_MEMOS: weakref.WeakSet[Memo[Any, Any]] = weakref.WeakSet()
"""Every memo of the process (weakly: a memo of a finished object goes with it)."""


def forget_memos() -> int:
    """Empty every :class:`Memo` of this process; returns how many values were dropped."""
    dropped = 0
    for memo in list(_MEMOS):
        dropped += len(memo)
        memo.clear()
    return dropped

"""Client-side rate limits shared by every agent that uses one model.

A :class:`RateLimiter` combines a cap on requests in flight (a semaphore) with
requests-per-minute and tokens-per-minute token buckets. :class:`LimitedModel` wraps a
model with one; every agent holding the same ``LimitedModel`` (or models built with the
same limiter) shares its budget, so a batch stays under a provider's limits instead of
collecting 429s. Waiting is a computed ``sleep``, never a polling loop.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path

from scenemosaic.exceptions import ModelConfigError, ModelError
from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._tokens import estimate_tokens
from scenemosaic.models._wrapper import WrapperModel

__all__ = ["FileTokenBucket", "LimitedModel", "RateLimiter", "TokenBucket", "estimate_tokens"]

Clock = Callable[[], float]
Sleep = Callable[[float], Awaitable[None]]


class TokenBucket:
    """A token bucket refilled continuously at ``rate_per_s`` up to ``capacity``.

    ``acquire(n)`` waits (FIFO, by sleeping exactly until enough tokens exist) and takes
    ``n``; a request for more than ``capacity`` takes a full bucket. ``adjust(delta)``
    books a correction afterwards and may drive the level below zero, which later
    acquirers wait out.
    """

    def __init__(
        self, rate_per_s: float, capacity: float, *, clock: Clock = time.monotonic, sleep: Sleep | None = None
    ):
        if rate_per_s <= 0 or capacity <= 0:
            raise ModelConfigError(
                f"token bucket needs a positive rate and capacity, got {rate_per_s}, {capacity}"
            )
        self.rate_per_s = rate_per_s
        self.capacity = capacity
        self._clock = clock
        self._sleep: Sleep = sleep or asyncio.sleep
        self._level = capacity
        self._updated = clock()
        self._lock: asyncio.Lock | None = None
        self._lock_loop: asyncio.AbstractEventLoop | None = None

    def _refill(self) -> None:
        now = self._clock()
        self._level = min(self.capacity, self._level + (now - self._updated) * self.rate_per_s)
        self._updated = now

    @property
    def level(self) -> float:
        """Tokens available now (negative while an overdraft is being paid back)."""
        self._refill()
        return self._level

    def _get_lock(self) -> asyncio.Lock:
        loop = asyncio.get_running_loop()
        if self._lock is None or self._lock_loop is not loop:
            self._lock, self._lock_loop = asyncio.Lock(), loop
        return self._lock

    async def acquire(self, amount: float = 1.0) -> None:
        """Wait until ``amount`` tokens (at most ``capacity``) are there, then take them."""
        amount = min(amount, self.capacity)
        async with self._get_lock():
            self._refill()
            # The slack absorbs float rounding: after sleeping exactly the deficit the refill
            # may land a hair short, and with a large clock value the next tiny deficit can be
            # smaller than the clock's resolution, so waiting for it would never end.
            slack = 1e-9 * max(1.0, amount)
            while self._level < amount - slack:
                await self._sleep((amount - self._level) / self.rate_per_s)
                self._refill()
            self._level -= amount

    def adjust(self, delta: float) -> None:
        """Take ``delta`` more tokens (give back when negative) without waiting."""
        self._refill()
        self._level = min(self.capacity, self._level - delta)


class FileTokenBucket:
    """A token bucket whose state lives in a small JSON file, shared by every process (and every
    machine on a file system with working POSIX locks) that opens the same ``path``.

    The same contract as :class:`TokenBucket`: ``acquire(n)`` waits until ``n`` tokens are
    there and takes them, ``adjust(delta)`` books a correction. Each operation holds an
    exclusive ``flock`` on the file for the read-refill-write only; a waiter sleeps the computed
    deficit without the lock, then tries again (no FIFO order between processes). Time is wall
    clock (``time.time``), the one clock processes share.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        rate_per_s: float,
        capacity: float,
        *,
        clock: Clock = time.time,
        sleep: Sleep | None = None,
    ) -> None:
        if rate_per_s <= 0 or capacity <= 0:
            raise ModelConfigError(f"token bucket needs a positive rate and capacity, got {rate_per_s}, {capacity}")
        self.path = Path(path)
        self.rate_per_s = rate_per_s
        self.capacity = capacity
        self._clock = clock
        self._sleep: Sleep = sleep or asyncio.sleep

    def _update(self, amount: float, *, force: bool) -> float:
        """Refill, then take ``amount`` (``force``: even into debt); returns the seconds to wait
        before ``amount`` would be there (0.0: taken)."""
        import fcntl

        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "a+", encoding="utf-8") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            fh.seek(0)
            try:
                state = json.loads(fh.read() or "{}")
                level, updated = float(state["level"]), float(state["updated"])
            except (ValueError, KeyError, TypeError):  # new, or torn by a crash: start full
                level, updated = self.capacity, self._clock()
            now = self._clock()
            level = min(self.capacity, level + max(0.0, now - updated) * self.rate_per_s)
            wait = 0.0
            if force or level >= amount - 1e-9 * max(1.0, amount):
                level = min(self.capacity, level - amount)
            else:
                wait = (amount - level) / self.rate_per_s
            fh.seek(0)
            fh.truncate()
            fh.write(json.dumps({"level": level, "updated": now}))
            fh.flush()
            return wait

    @property
    def level(self) -> float:
        """Tokens available now (negative while an overdraft is being paid back)."""
        self._update(0.0, force=True)
        state = json.loads(self.path.read_text(encoding="utf-8"))
        return float(state["level"])

    async def acquire(self, amount: float = 1.0) -> None:
        """Wait until ``amount`` tokens (at most ``capacity``) are there, then take them."""
        amount = min(amount, self.capacity)
        while True:
            wait = await asyncio.to_thread(self._update, amount, force=False)
            if wait <= 0.0:
                return
            await self._sleep(wait)

    def adjust(self, delta: float) -> None:
        """Take ``delta`` more tokens (give back when negative) without waiting."""
        self._update(delta, force=True)


class RateLimiter:
    """Concurrency cap plus request and token rates, for one model (or one provider account).

    * ``max_concurrency`` — requests in flight at once (``None``: unlimited).
    * ``requests_per_minute`` — request rate; with ``request_burst=1`` (default) requests
      are spaced evenly, ``60 / requests_per_minute`` seconds apart.
    * ``tokens_per_minute`` — token rate; the bucket holds one minute of tokens.
    * ``shared_dir`` — keep the two rate buckets in files there (:class:`FileTokenBucket`,
      ``<key>.requests.json`` and ``<key>.tokens.json``), so every process using the same folder
      and ``key`` shares the rates (the workers of a batch); the concurrency cap stays per process.
    * ``clock`` / ``sleep`` — injectable for tests (a fake clock advanced by the fake sleep).
    """

    def __init__(
        self,
        *,
        max_concurrency: int | None = None,
        requests_per_minute: float | None = None,
        tokens_per_minute: float | None = None,
        request_burst: int = 1,
        shared_dir: str | os.PathLike[str] | None = None,
        key: str = "model",
        clock: Clock | None = None,
        sleep: Sleep | None = None,
    ) -> None:
        if max_concurrency is not None and max_concurrency < 1:
            raise ModelConfigError(f"max_concurrency must be at least 1, got {max_concurrency}")
        self.max_concurrency = max_concurrency

        def bucket(kind: str, rate_per_s: float, capacity: float) -> TokenBucket | FileTokenBucket:
            if shared_dir is None:
                return TokenBucket(rate_per_s, capacity, clock=clock or time.monotonic, sleep=sleep)
            name = re.sub(r"[^A-Za-z0-9_.-]", "_", key)[:80]
            return FileTokenBucket(Path(shared_dir) / f"{name}.{kind}.json", rate_per_s, capacity, clock=clock or time.time, sleep=sleep)

        self.requests = bucket("requests", requests_per_minute / 60.0, max(1, request_burst)) if requests_per_minute else None
        self.tokens = bucket("tokens", tokens_per_minute / 60.0, tokens_per_minute) if tokens_per_minute else None
        self._semaphore: asyncio.Semaphore | None = None
        self._semaphore_loop: asyncio.AbstractEventLoop | None = None
        self.in_flight = 0
        """Requests holding a slot right now."""
        self.max_in_flight = 0
        """The most requests that held a slot at once so far."""

    def _get_semaphore(self) -> asyncio.Semaphore | None:
        if self.max_concurrency is None:
            return None
        loop = asyncio.get_running_loop()
        if self._semaphore is None or self._semaphore_loop is not loop:
            self._semaphore, self._semaphore_loop = asyncio.Semaphore(self.max_concurrency), loop
        return self._semaphore

    @asynccontextmanager
    async def slot(self, estimated_tokens: int = 0) -> AsyncIterator[Callable[[Usage], None]]:
        """Hold a slot for one request; yields ``settle(usage)`` to correct the token booking."""
        semaphore = self._get_semaphore()
        if semaphore is not None:
            await semaphore.acquire()
        try:
            # Rates are taken after the slot so that the moment a bucket grants is the
            # moment the request leaves; waiting for a slot does not bank request credit.
            if self.requests is not None:
                await self.requests.acquire(1)
            booked = 0.0
            if self.tokens is not None and estimated_tokens > 0:
                booked = min(float(estimated_tokens), self.tokens.capacity)
                await self.tokens.acquire(booked)
            self.in_flight += 1
            self.max_in_flight = max(self.max_in_flight, self.in_flight)

            def settle(usage: Usage) -> None:
                # A wrapped model may have sent several HTTP requests (retried 429s and
                # 5xx, a re-send after truncation): the extra ones are charged to the
                # request bucket, since the provider counted them too.
                if self.requests is not None and usage.requests > 1:
                    self.requests.adjust(usage.requests - 1)
                if self.tokens is not None:
                    self.tokens.adjust(usage.total_tokens - booked)

            try:
                yield settle
            finally:
                self.in_flight -= 1
        finally:
            if semaphore is not None:
                semaphore.release()


class LimitedModel(WrapperModel):
    """A model whose requests go through a shared :class:`RateLimiter`.

    Pass ``limiter`` to share one budget across several models (one provider account),
    or the limiter's keyword arguments to make a new one.
    """

    def __init__(
        self,
        wrapped: Model,
        limiter: RateLimiter | None = None,
        *,
        max_concurrency: int | None = None,
        requests_per_minute: float | None = None,
        tokens_per_minute: float | None = None,
    ) -> None:
        super().__init__(wrapped)
        self.limiter = limiter or RateLimiter(
            max_concurrency=max_concurrency,
            requests_per_minute=requests_per_minute,
            tokens_per_minute=tokens_per_minute,
        )

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """Wait for a slot and the rate budgets, then forward the request."""
        estimate = estimate_tokens(messages, settings) if self.limiter.tokens is not None else 0
        async with self.limiter.slot(estimate) as settle:
            try:
                output, usage = await self.wrapped.request(messages, output_type, settings, context=context)
            except ModelError as exc:
                # A failed call may still have cost requests and tokens (a reply that did
                # not validate, retried 429s): the provider counted them, so the buckets do.
                spent = getattr(exc, "usage", None)
                if isinstance(spent, Usage):
                    settle(spent)
                raise
            settle(usage)
        return output, usage

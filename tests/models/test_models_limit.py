"""RateLimiter / LimitedModel: concurrency bound under load, evenly spaced rates on a fake clock."""

from __future__ import annotations

import asyncio

import httpx
import pytest
from llm_fakes import VALID, Verdict, user_messages

from scenemosaic.exceptions import ModelConfigError
from scenemosaic.models import (
    FunctionModel,
    LimitedModel,
    Message,
    ModelSettings,
    RateLimiter,
    RequestContext,
    TokenBucket,
    Usage,
)
from scenemosaic.models._limit import estimate_tokens


class FakeClock:
    """A clock that only moves when someone sleeps on it."""

    def __init__(self) -> None:
        self.now = 0.0
        self.sleeps: list[float] = []

    def __call__(self) -> float:
        return self.now

    async def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds
        await asyncio.sleep(0)


class InFlight:
    """An async model function that measures how many calls overlap."""

    def __init__(self, clock: FakeClock | None = None) -> None:
        self.current = 0
        self.peak = 0
        self.calls = 0
        self.started_at: list[float] = []
        self.clock = clock

    async def __call__(self, messages: list[Message], context: RequestContext | None) -> dict[str, object]:
        self.current += 1
        self.calls += 1
        self.peak = max(self.peak, self.current)
        if self.clock is not None:
            self.started_at.append(self.clock())
        for _ in range(3):  # stay in flight across several loop turns
            await asyncio.sleep(0)
        self.current -= 1
        return VALID


async def test_concurrency_never_exceeds_its_bound_under_100_requests() -> None:
    fn = InFlight()
    model = LimitedModel(FunctionModel(fn), max_concurrency=5)
    results = await asyncio.gather(*[model.request(user_messages(), Verdict) for _ in range(100)])
    assert len(results) == 100 and fn.calls == 100
    assert fn.peak == 5  # reached, never exceeded
    assert model.limiter.max_in_flight == 5
    assert model.limiter.in_flight == 0


async def test_models_sharing_a_limiter_share_the_bound() -> None:
    fn = InFlight()
    limiter = RateLimiter(max_concurrency=3)
    a = LimitedModel(FunctionModel(fn, name="a"), limiter)
    b = LimitedModel(FunctionModel(fn, name="b"), limiter)
    await asyncio.gather(*[(a if i % 2 else b).request(user_messages(), Verdict) for i in range(40)])
    assert fn.peak == 3
    assert (a.name, b.name) == ("a", "b")


async def test_requests_per_minute_are_evenly_spaced() -> None:
    clock = FakeClock()
    fn = InFlight(clock)
    limiter = RateLimiter(requests_per_minute=120, clock=clock, sleep=clock.sleep)
    model = LimitedModel(FunctionModel(fn), limiter)
    await asyncio.gather(*[model.request(user_messages(), Verdict) for _ in range(6)])
    starts = sorted(fn.started_at)
    assert starts == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0, 2.5])
    # Waiting is computed, not polled: one sleep per waiting request.
    assert len(clock.sleeps) == 5


async def test_request_burst_lets_a_few_through_at_once() -> None:
    clock = FakeClock()
    fn = InFlight(clock)
    limiter = RateLimiter(requests_per_minute=60, request_burst=3, clock=clock, sleep=clock.sleep)
    model = LimitedModel(FunctionModel(fn), limiter)
    await asyncio.gather(*[model.request(user_messages(), Verdict) for _ in range(5)])
    assert sorted(fn.started_at) == pytest.approx([0.0, 0.0, 0.0, 1.0, 2.0])


async def test_tokens_per_minute_books_estimates_and_settles_actual_usage() -> None:
    clock = FakeClock()
    bucket = TokenBucket(rate_per_s=10.0, capacity=100.0, clock=clock, sleep=clock.sleep)
    await bucket.acquire(100)
    assert clock.now == 0.0
    await bucket.acquire(30)  # 30 tokens at 10/s
    assert clock.now == pytest.approx(3.0)
    bucket.adjust(20)  # the reply used 20 more than booked: an overdraft
    assert bucket.level == pytest.approx(-20.0)
    await bucket.acquire(10)
    assert clock.now == pytest.approx(6.0)
    bucket.adjust(-1000)  # a refund never fills past capacity
    assert bucket.level == pytest.approx(100.0)


async def test_limited_model_charges_token_usage_to_the_bucket() -> None:
    clock = FakeClock()

    class Costly(FunctionModel):
        async def request(self, messages, output_type, settings=None, *, context=None):  # type: ignore[no-untyped-def]
            out, _ = await super().request(messages, output_type, settings, context=context)
            return out, Usage(requests=1, input_tokens=500, output_tokens=100)

    limiter = RateLimiter(tokens_per_minute=6000, clock=clock, sleep=clock.sleep)  # 100 tokens/s
    model = LimitedModel(Costly(lambda m, c: VALID), limiter)
    settings = ModelSettings(max_tokens=1000)
    await model.request(user_messages(), Verdict, settings)
    assert clock.now == 0.0
    assert limiter.tokens is not None
    assert limiter.tokens.level == pytest.approx(6000 - 600)  # booked ~1000+prompt, settled to 600


def test_bad_limits_are_config_errors() -> None:
    with pytest.raises(ModelConfigError):
        RateLimiter(max_concurrency=0)
    with pytest.raises(ModelConfigError):
        TokenBucket(rate_per_s=0.0, capacity=1.0)


async def test_all_bounds_hold_together_under_100_concurrent_requests() -> None:
    """In flight, requests per minute and tokens per minute, measured on what reached the model."""
    clock = FakeClock()
    fn = InFlight(clock)
    settings = ModelSettings(max_tokens=400)
    prompt_tokens = estimate_tokens(user_messages(), None)
    tokens_per_call = prompt_tokens + 400  # what a provider charges: the prompt and the output cap

    class Costly(FunctionModel):
        async def request(self, messages, output_type, settings=None, *, context=None):  # type: ignore[no-untyped-def]
            out, _ = await super().request(messages, output_type, settings, context=context)
            return out, Usage(requests=1, input_tokens=prompt_tokens, output_tokens=400)

    rpm, burst, tpm, concurrency = 30, 4, 4_000, 6
    limiter = RateLimiter(
        max_concurrency=concurrency,
        requests_per_minute=rpm,
        request_burst=burst,
        tokens_per_minute=tpm,
        clock=clock,
        sleep=clock.sleep,
    )
    model = LimitedModel(Costly(fn), limiter)
    await asyncio.gather(*[model.request(user_messages(), Verdict, settings) for _ in range(100)])
    assert fn.calls == 100
    assert fn.peak <= concurrency and limiter.max_in_flight <= concurrency
    starts = sorted(fn.started_at)
    for i, t in enumerate(starts):
        in_window = sum(1 for s in starts[i:] if s < t + 60.0)
        # a token bucket lets through its burst plus the rate over any 60 s window
        assert in_window <= burst + rpm, (t, in_window)
        # tokens: a full bucket (one minute's worth) plus one minute of refill
        assert in_window * tokens_per_call <= 2 * tpm, (t, in_window)
    # the tighter of the two rates sets the pace (here tokens: about 9.8 calls a minute)
    pace = (len(starts) - 1) / ((starts[-1] - starts[0]) / 60.0)
    assert pace <= tpm / tokens_per_call * 1.1 and pace < rpm
    assert limiter.in_flight == 0


async def test_bucket_waits_end_with_a_large_clock_value() -> None:
    """Float rounding must not turn a wait into an endless loop of zero-length sleeps.

    ``time.monotonic()`` is large on a machine that has been up for weeks; the deficit left after
    sleeping exactly the computed wait can then be smaller than the clock's resolution.
    """
    clock = FakeClock()
    clock.now = 2_000_000.123456789
    bucket = TokenBucket(rate_per_s=0.5, capacity=4.0, clock=clock, sleep=clock.sleep)
    for _ in range(4):
        await bucket.acquire(1)

    async def drain() -> None:
        for _ in range(200):
            await bucket.acquire(1)

    await asyncio.wait_for(drain(), 10.0)
    assert len(clock.sleeps) <= 200 * 2  # one computed sleep per acquire, give or take a rounding retry
    assert clock.now - 2_000_000.123456789 == pytest.approx(400.0, abs=0.01)


# -- one server slot: the queue is the client's, the time-out the server's ---------------------
async def test_with_the_servers_slot_count_a_queued_request_does_not_time_out() -> None:
    """A one-slot server works 0.3 s per request; the time-out is 0.45 s. Sent together, the second
    request waits 0.3 s for the slot: counted in its time-out it would fail, queued in the client
    (``max_concurrency`` = the server's slots) it does not."""
    import httpx
    from llm_fakes import FakeServer, chat_reply

    from scenemosaic.exceptions import ModelError
    from scenemosaic.models import HTTPRetryPolicy

    slot = asyncio.Lock()

    async def one_slot(request: httpx.Request) -> httpx.Response:
        if request.url.path == "/props":
            return httpx.Response(200, json={"total_slots": 1})
        async with slot:
            await asyncio.sleep(0.3)
        return chat_reply(VALID)

    server = FakeServer(default=one_slot)
    no_retry = HTTPRetryPolicy(max_attempts=1)
    model, _ = server.model(timeout_s=0.45, retry=no_retry)
    assert await model.server_slots() == 1
    limited = LimitedModel(model, max_concurrency=1)
    both = await asyncio.gather(*(limited.request(user_messages(), Verdict) for _ in range(2)))
    assert [out.score for out, _ in both] == [70, 70]

    unlimited, _ = server.model(timeout_s=0.45, retry=no_retry)
    results = await asyncio.gather(
        *(unlimited.request(user_messages(), Verdict) for _ in range(2)), return_exceptions=True
    )
    assert sum(isinstance(r, ModelError) for r in results) == 1  # the queued one timed out


async def test_server_slots_is_none_when_the_server_does_not_say() -> None:
    import httpx
    from llm_fakes import FakeServer

    for reply in (httpx.Response(404, text="not found"), httpx.Response(200, json={"slots": "?"}),
                  httpx.Response(200, text="<html>"), httpx.ConnectError("refused")):
        model, _ = FakeServer(reply).model()
        assert await model.server_slots() is None


class _Trickle(httpx.AsyncByteStream):
    """A body that never ends: ``chunk`` every ``pause`` seconds."""

    def __init__(self, chunk: bytes, pause: float) -> None:
        self.chunk, self.pause, self.sent = chunk, pause, 0

    async def __aiter__(self):  # type: ignore[no-untyped-def]
        while True:
            self.sent += len(self.chunk)
            yield self.chunk
            await asyncio.sleep(self.pause)


@pytest.mark.parametrize(("chunk", "pause"), [(b"{", 0.2), (b"x" * 65536, 0.0)], ids=["trickling", "endless"])
async def test_the_server_probe_is_bounded_in_time_and_bytes(chunk: bytes, pause: float) -> None:
    """A /props reply that trickles a byte at a time, or streams without end, gives up within the
    probe's time-out and reads no more than its byte cap (the run then goes on without slots)."""
    import time

    from llm_fakes import FakeServer

    from scenemosaic.models._openai import PROBE_MAX_BYTES

    body = _Trickle(chunk, pause)
    model, _ = FakeServer(httpx.Response(200, stream=body)).model()
    started = time.monotonic()
    assert await model.server_slots(timeout_s=1.0) is None
    assert time.monotonic() - started < 2.0
    assert body.sent <= PROBE_MAX_BYTES + len(chunk)

"""The one HTTP policy of every outbound call: the run's clock, total time-outs, cancellation, set-up errors."""

from __future__ import annotations

import asyncio
import time

import httpx
import pytest
from llm_fakes import Verdict, user_messages

from scenemosaic.exceptions import ModelDeadlineExceeded
from scenemosaic.models import (
    CallClock,
    DeadlineModel,
    FunctionModel,
    GiveUp,
    HTTPRetryPolicy,
    RequestContext,
    send_with_retries,
    unreachable_words,
)

FAST = HTTPRetryPolicy(max_attempts=3, initial_backoff_s=0.01, jitter_s=0.0)


async def _hang(limit: float) -> str:
    await asyncio.sleep(3600)
    return "unreachable"


def test_the_request_time_out_wins_over_a_clients_own_and_the_deadline_over_both() -> None:
    assert CallClock().call_timeout(60.0) == 60.0
    assert CallClock(timeout_s=5.0).call_timeout(60.0) == 5.0
    soon = CallClock.starting(5.0, 1.0)
    assert 0.5 < soon.call_timeout(60.0) <= 1.0
    assert CallClock.starting(None, 30.0).deadline_words() == "the run's 30 s deadline"


async def test_the_deadline_cuts_a_hung_call_and_its_retries() -> None:
    started = time.perf_counter()
    with pytest.raises(GiveUp) as info:
        await send_with_retries(_hang, timeout_s=60.0, policy=FAST, clock=CallClock.starting(None, 0.3))
    assert info.value.timed_out
    assert time.perf_counter() - started < 1.5


async def test_nothing_is_sent_once_the_deadline_has_passed() -> None:
    sent: list[float] = []

    async def attempt(limit: float) -> str:
        sent.append(limit)
        return "ok"

    with pytest.raises(GiveUp, match="deadline had passed") as info:
        await send_with_retries(attempt, timeout_s=5.0, policy=FAST, clock=CallClock.starting(None, 0.0))
    assert (sent, info.value.attempts) == ([], 0)


async def test_a_trickle_is_cut_by_the_total_time_out_of_each_attempt() -> None:
    reads = 0

    async def trickle(limit: float) -> str:
        nonlocal reads
        while True:  # every read is quick: only a total time-out ends this
            await asyncio.sleep(0.01)
            reads += 1

    started = time.perf_counter()
    with pytest.raises(GiveUp) as info:
        await send_with_retries(trickle, timeout_s=0.1, policy=FAST)
    # one attempt of 0.1 s, one more of 0.2 s, then given up
    assert info.value.attempts == 2 and info.value.timed_out
    assert 0.3 <= time.perf_counter() - started < 1.5 and reads > 10


async def test_a_cancel_interrupts_a_waiting_call_at_once() -> None:
    task = asyncio.create_task(send_with_retries(_hang, timeout_s=60.0, policy=FAST))
    await asyncio.sleep(0.05)
    started = time.perf_counter()
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert time.perf_counter() - started < 0.1


async def test_a_refused_connection_is_not_retried() -> None:
    tries = 0

    async def refused(limit: float) -> str:
        nonlocal tries
        tries += 1
        raise httpx.ConnectError("All connection attempts failed")

    with pytest.raises(httpx.ConnectError):
        await send_with_retries(refused, timeout_s=1.0, policy=FAST)
    assert tries == 1


def test_unreachable_words_tell_an_unknown_host_from_a_missing_server() -> None:
    gone = httpx.ConnectError("[Errno -2] Name or service not known")
    assert unreachable_words(gone, "http://no-such-host:8000/v1", "model server") == (
        "unknown host 'no-such-host' in the model server URL http://no-such-host:8000/v1"
    )
    refused = httpx.ConnectError("All connection attempts failed")
    assert unreachable_words(refused, "http://127.0.0.1:9/v1", "segmenter server") == "no segmenter server at http://127.0.0.1:9/v1"


async def test_deadline_messages_name_the_deadline_not_the_time_left() -> None:
    model = DeadlineModel(FunctionModel(lambda m, c: {"score": 1}), 0.0, shown_s=30.0)
    with pytest.raises(ModelDeadlineExceeded, match="the run's 30 s deadline"):
        await model.request(user_messages(), Verdict, context=RequestContext(agent="critic"))
    with pytest.raises(ModelDeadlineExceeded, match="the run's 30 s deadline"):
        await model.generate_image("a room")

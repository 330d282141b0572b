"""The HTTP retry policy: which failures are retried, capped waits, per-attempt and total time limits, time-out precedence."""

from __future__ import annotations

import asyncio
import time
from datetime import UTC, datetime, timedelta
from email.utils import format_datetime

import httpx
import pytest
from llm_fakes import VALID, FakeClock, FakeServer, Verdict, chat_reply, user_messages

from scenemosaic.exceptions import ModelConfigError, ModelError, ModelHTTPError
from scenemosaic.models import (
    DEFAULT_TIMEOUT_S,
    HTTPRetryPolicy,
    ModelSettings,
    OpenAIChatModel,
    RequestContext,
)

CTX = RequestContext(agent="critic")


def read_timeouts(server: FakeServer) -> list[float]:
    return [r.extensions["timeout"]["read"] for r in server.requests]


@pytest.mark.parametrize(
    "failure",
    [
        httpx.ReadError("[Errno 104] Connection reset by peer"),
        httpx.WriteError("broken pipe"),
        httpx.ConnectTimeout("connect timed out"),
        httpx.ReadTimeout("read timed out"),
        httpx.WriteTimeout("write timed out"),
        httpx.PoolTimeout("no free connection"),
        httpx.CloseError("close failed"),
    ],
    ids=lambda e: type(e).__name__,
)
async def test_transport_failures_are_retried_with_backoff(failure: Exception) -> None:
    server = FakeServer(failure, chat_reply(VALID))
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3, initial_backoff_s=1.0, jitter_s=0.0))
    out, usage = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert len(server.requests) == 2 and sleeps == [1.0]
    assert usage.requests == 1  # the failed attempt got no response


async def test_a_reset_connection_on_every_attempt_ends_in_a_model_error() -> None:
    server = FakeServer(default=httpx.ReadError("[Errno 104] Connection reset by peer"))
    model, sleeps = server.model(retry=HTTPRetryPolicy(max_attempts=3, initial_backoff_s=1.0, jitter_s=0.0))
    with pytest.raises(ModelError, match="failed after 3 attempts: ReadError") as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert not isinstance(info.value, ModelHTTPError)
    assert isinstance(info.value.__cause__, httpx.ReadError)
    assert (len(server.requests), sleeps) == (3, [1.0, 2.0])


@pytest.mark.parametrize(
    ("failure", "raised"),
    [
        (httpx.UnsupportedProtocol("ftp is not http"), ModelConfigError),
        (httpx.LocalProtocolError("bad header"), ModelError),
    ],
    ids=["UnsupportedProtocol", "LocalProtocolError"],
)
async def test_failures_of_our_own_request_are_not_retried(
    failure: Exception, raised: type[Exception]
) -> None:
    server = FakeServer(failure)
    model, sleeps = server.model()
    with pytest.raises(raised) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.__cause__ is failure
    assert (len(server.requests), sleeps) == (1, [])


async def test_a_huge_retry_after_is_capped_at_30_s_by_default() -> None:
    assert HTTPRetryPolicy().max_retry_after_s == 30.0
    when = datetime.now(UTC) + timedelta(days=2)
    server = FakeServer(
        httpx.Response(429, headers={"Retry-After": "100000"}, json={"error": {"message": "slow down"}}),
        httpx.Response(503, headers={"Retry-After": format_datetime(when, usegmt=True)}, text="later"),
        httpx.Response(503, headers={"Retry-After": "inf"}, text="later"),
        chat_reply(VALID),
    )
    model, sleeps = server.model(retry=HTTPRetryPolicy(jitter_s=0.0))
    await model.request(user_messages(), Verdict, context=CTX)
    # The two capped hints wait 30 s each; an unusable hint ("inf") falls back to the backoff (4 s).
    assert sleeps == [30.0, 30.0, 4.0]


async def test_a_hung_server_costs_one_timeout_and_one_doubled_retry() -> None:
    async def hang(request: httpx.Request) -> httpx.Response:
        await asyncio.sleep(3600)
        raise AssertionError("unreachable")

    server = FakeServer(default=hang)
    model, sleeps = server.model(timeout_s=0.05, retry=HTTPRetryPolicy(max_attempts=3, jitter_s=0.0))
    started = time.perf_counter()
    with pytest.raises(ModelError, match=r"timed out \(0.05 s, then 0.1 s\) after 2 attempts"):
        await model.request(user_messages(), Verdict, context=CTX)
    elapsed = time.perf_counter() - started
    # not re-sent unchanged until the attempts run out: once more with twice the time, then given up
    assert len(server.requests) == 2 and sleeps == [1.0]  # the back-off (faked) between them
    assert 0.15 <= elapsed < 2.0  # 0.05 s + 0.1 s, plus scheduling slack


async def test_a_server_trickling_bytes_is_cut_by_the_attempt_time_out() -> None:
    class Trickle(httpx.AsyncByteStream):
        async def __aiter__(self):  # type: ignore[no-untyped-def]
            while True:  # every read is quick, so httpx's read time-out never fires
                await asyncio.sleep(0.005)
                yield b" "

    server = FakeServer(default=lambda request: httpx.Response(200, stream=Trickle()))
    model, _ = server.model(timeout_s=0.1, retry=HTTPRetryPolicy(max_attempts=2, jitter_s=0.0))
    started = time.perf_counter()
    with pytest.raises(ModelError, match="timed out"):
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 2 and time.perf_counter() - started < 2.0


async def test_no_attempt_starts_after_the_total_budget() -> None:
    clock = FakeClock()
    server = FakeServer(default=httpx.Response(503, json={"error": {"message": "busy"}}))
    policy = HTTPRetryPolicy(
        max_attempts=10, initial_backoff_s=10.0, max_backoff_s=1000.0, jitter_s=0.0, max_total_s=35.0
    )
    model, sleeps = server.model(retry=policy, clock=clock)
    with pytest.raises(ModelHTTPError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert info.value.status_code == 503
    # Waits of 10 and 20 s fit in 35 s; the next (40 s) would end past it, so none is begun.
    assert sleeps == [10.0, 20.0] and len(server.requests) == 3


async def test_no_attempt_runs_past_the_total_budget() -> None:
    clock = FakeClock()
    server = FakeServer(default=httpx.Response(503, json={"error": {"message": "busy"}}))
    policy = HTTPRetryPolicy(max_attempts=5, initial_backoff_s=10.0, jitter_s=0.0, max_total_s=10.5)
    model, _ = server.model(retry=policy, clock=clock, timeout_s=10.0)
    with pytest.raises(ModelHTTPError):
        await model.request(user_messages(), Verdict, context=CTX)
    # The second attempt starts 10 s in: only 0.5 s of the budget is left for it.
    assert read_timeouts(server) == [10.0, pytest.approx(0.5)]


def test_a_nonsense_policy_is_a_config_error() -> None:
    with pytest.raises(ModelConfigError):
        HTTPRetryPolicy(max_attempts=0)
    with pytest.raises(ModelConfigError):
        HTTPRetryPolicy(max_total_s=0)
    with pytest.raises(ModelConfigError):
        OpenAIChatModel("m", base_url="http://llm.test/v1", timeout_s=0)


# -- which time-out applies ---------------------------------------------------------------------


async def test_the_model_time_out_applies_when_the_call_sets_none() -> None:
    assert ModelSettings().timeout_s is None
    server = FakeServer(chat_reply(VALID), chat_reply(VALID), chat_reply(VALID))
    model, _ = server.model(timeout_s=7.0)
    assert model.default_timeout_s == 7.0
    await model.request(user_messages(), Verdict, context=CTX)  # no settings at all
    await model.request(user_messages(), Verdict, ModelSettings(max_tokens=100), context=CTX)
    await model.request(user_messages(), Verdict, ModelSettings(timeout_s=3.0), context=CTX)  # the call wins
    assert read_timeouts(server) == [7.0, 7.0, 3.0]


async def test_without_either_the_default_applies() -> None:
    server = FakeServer(chat_reply(VALID))
    model, _ = server.model()
    await model.request(user_messages(), Verdict, context=CTX)
    assert read_timeouts(server) == [DEFAULT_TIMEOUT_S] == [120.0]

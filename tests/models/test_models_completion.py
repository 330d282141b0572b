"""CompletionModel: large replies are validated off the event loop; errors stay short enough to send back."""

from __future__ import annotations

import asyncio
import json
import threading

import pytest
from pydantic import BaseModel, field_validator

from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models import FunctionModel, RequestContext
from scenemosaic.models._completion import OFFLOAD_REPLY_CHARS

CTX = RequestContext(agent="critic")
VALIDATED_IN: list[str] = []


class Blob(BaseModel):
    blob: str

    @field_validator("blob")
    @classmethod
    def _where(cls, value: str) -> str:
        VALIDATED_IN.append(threading.current_thread().name)
        return value


async def test_large_replies_are_validated_in_a_worker_thread_small_ones_inline() -> None:
    VALIDATED_IN.clear()
    small = FunctionModel(lambda m, c: json.dumps({"blob": "x" * 100}))
    large = FunctionModel(lambda m, c: json.dumps({"blob": "x" * OFFLOAD_REPLY_CHARS}))
    await small.request([], Blob, context=CTX)
    await large.request([], Blob, context=CTX)
    main = threading.current_thread().name
    assert VALIDATED_IN[0] == main and VALIDATED_IN[1] != main


async def test_a_pathological_reply_does_not_stall_the_event_loop() -> None:
    ticks = 0

    async def ticker() -> None:
        nonlocal ticks
        while True:
            await asyncio.sleep(0.005)
            ticks += 1

    task = asyncio.create_task(ticker())
    await asyncio.sleep(0)
    try:
        with pytest.raises(OutputValidationError) as info:
            await FunctionModel(lambda m, c: "{" * 2_000_000).request([], Blob, context=CTX)
    finally:
        task.cancel()
    assert ticks >= 2  # the loop kept running while the reply was parsed
    assert len(info.value.raw_reply) < 8_100  # an excerpt, not 2 MB to send back in a repair


async def test_a_reply_with_thousands_of_errors_lists_a_few() -> None:
    class Many(BaseModel):
        values: list[int]

    reply = json.dumps({"values": ["not a number"] * 5000})
    with pytest.raises(OutputValidationError) as info:
        await FunctionModel(lambda m, c: reply).request([], Many, context=CTX)
    errors = info.value.errors
    assert len(errors) == 21 and errors[-1] == "... and 4980 more errors like these"

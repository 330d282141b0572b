"""Offline stand-ins for an OpenAI-compatible server (httpx.MockTransport) and shared test types."""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable
from typing import Any

import httpx
from pydantic import BaseModel, Field

from scenemosaic.models import HTTPRetryPolicy, ImagePart, Message, OpenAIChatModel, TextPart

# 1x1 transparent PNG: a real image file, small enough to inline.
PNG_1PX = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360000002000100e221bc330000000049454e44ae426082"
)


class Verdict(BaseModel):
    """A small critic-like output type."""

    should_modify: bool
    notes: list[str]
    score: int = Field(ge=0, le=100)


VALID = {"should_modify": True, "notes": ["move (chair_1) left"], "score": 70}


def chat_reply(
    content: str | dict[str, Any],
    *,
    finish: str = "stop",
    prompt_tokens: int = 11,
    completion_tokens: int = 7,
) -> httpx.Response:
    """A 200 Chat Completions reply with ``content`` (a dict is sent as its JSON text)."""
    text = content if isinstance(content, str) else json.dumps(content)
    return httpx.Response(
        200,
        json={
            "id": "chatcmpl-test",
            "object": "chat.completion",
            "model": "test-model",
            "choices": [
                {"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": finish}
            ],
            "usage": {
                "prompt_tokens": prompt_tokens,
                "completion_tokens": completion_tokens,
                "total_tokens": prompt_tokens + completion_tokens,
            },
        },
    )


Reply = (
    httpx.Response
    | Exception
    | Callable[[httpx.Request], httpx.Response]
    | Callable[[httpx.Request], Awaitable[httpx.Response]]
)
"""A scripted answer: a response, an exception to raise, or a function of the request (an
async one lets a test hang the reply: ``httpx.MockTransport`` awaits it)."""


class FakeServer:
    """Answers each request with the next scripted reply and keeps every request it saw.

    ``default`` answers every request after the scripted ones (a server that always says
    the same thing); without it, a request beyond the script fails the test.
    """

    def __init__(self, *replies: Reply, default: Reply | None = None) -> None:
        self.replies = list(replies)
        self.default = default
        self.requests: list[httpx.Request] = []

    def handler(self, request: httpx.Request) -> Any:
        self.requests.append(request)
        if not self.replies and self.default is not None:
            reply = self.default
            if isinstance(reply, httpx.Response):  # a response is consumed once it is read
                reply = httpx.Response(reply.status_code, headers=reply.headers, content=reply.content)
        else:
            assert self.replies, f"unexpected request #{len(self.requests)}"
            reply = self.replies.pop(0)
        if isinstance(reply, Exception):
            if isinstance(reply, httpx.RequestError):
                reply.request = request  # httpx wants the failing request attached
            raise reply
        if callable(reply):
            return reply(request)
        return reply

    @property
    def bodies(self) -> list[dict[str, Any]]:
        """The JSON bodies of the requests so far."""
        return [json.loads(r.content) for r in self.requests]

    def model(self, **kw: Any) -> tuple[OpenAIChatModel, list[float]]:
        """An ``OpenAIChatModel`` wired to this server, and the list its retry sleeps go to.

        Its sleeps return at once; with ``clock=FakeClock()`` they advance that clock too.
        """
        clock = kw.get("clock")
        sleeps: list[float] = clock.sleeps if isinstance(clock, FakeClock) else []

        async def fake_sleep(seconds: float) -> None:
            if isinstance(clock, FakeClock):
                clock.now += seconds
            sleeps.append(seconds)

        kw.setdefault("base_url", "http://llm.test/v1")
        kw.setdefault("api_key", "sk-test")
        kw.setdefault("retry", HTTPRetryPolicy(max_attempts=4, initial_backoff_s=1.0, jitter_s=0.5))
        model = OpenAIChatModel(
            "test-model", transport=httpx.MockTransport(self.handler), sleep=fake_sleep, **kw
        )
        return model, sleeps


class FakeClock:
    """A monotonic clock that moves only when told to (or when a fake sleep advances it)."""

    def __init__(self, start: float = 1000.0) -> None:
        self.now = start
        self.sleeps: list[float] = []

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` pass."""
        self.now += seconds

    async def sleep(self, seconds: float) -> None:
        """A sleep that returns at once, having moved the clock."""
        self.sleeps.append(seconds)
        self.now += seconds


def user_messages(text: str = "Evidence: three chairs.", *, image: bool = False) -> list[Message]:
    """A system prompt and one user message, optionally with the test PNG."""
    parts: list[TextPart | ImagePart] = [TextPart(text)]
    if image:
        parts.append(ImagePart(PNG_1PX, label="top-down view"))
    return [
        Message.text("system", "You are a layout critic. Reply in JSON."),
        Message(role="user", parts=tuple(parts)),
    ]

"""A model behind an OpenAI-compatible Chat Completions endpoint (OpenAI, vLLM, llama.cpp...).

The wire format is the plain ``POST {base_url}/chat/completions`` JSON; images travel as
``image_url`` parts holding ``data:image/png;base64,...`` URLs.

Transient failures (429, 408/409/425, 5xx, time-outs, reset or dropped connections, read and
write errors) are retried by the one HTTP policy of every outbound call
(:func:`~scenemosaic.models._http.send_with_retries`: bounded attempts, each under a total
time-out, waits honouring a capped ``Retry-After``, a total budget after which no attempt
starts). A server that cannot serve the run — nothing listening, an unknown host, a refused key
(401/403), no such model or path (404) — raises :class:`ModelEndpointError` at once, with the
fix in one line. A prompt over the context window raises
:class:`ModelContextLengthError`; any other non-200 reply a :class:`ModelHTTPError` with the
status and the body. A 200 reply that is not a usable completion (an HTML page, no
choices, no content, a body over ``max_reply_bytes``) is an ordinary invalid reply: an
:class:`OutputValidationError` the asking agent repairs or falls back from.
"""

from __future__ import annotations

import asyncio
import base64
import io
import json
import math
import os
import random
import re
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import httpx
import structlog
from pydantic import BaseModel

from scenemosaic.exceptions import (
    ModelConfigError,
    ModelContextLengthError,
    ModelEndpointError,
    ModelError,
    ModelHTTPError,
)
from scenemosaic.models._base import ImagePart, Message, ModelSettings, RequestContext, TextPart, Usage
from scenemosaic.models._completion import Completion, CompletionModel
from scenemosaic.models._http import (
    GiveUp,
    HTTPRetryPolicy,
    is_unreachable,
    read_capped,
    send_with_retries,
    transient_status_error,
    unreachable_words,
)
from scenemosaic.models._schema import SchemaBounds, strict_json_schema
from scenemosaic.models._tokens import estimate_tokens

__all__ = [
    "CONTEXT_ESTIMATE_SLACK",
    "DEFAULT_MAX_REPLY_BYTES",
    "DEFAULT_OPENAI_BASE_URL",
    "DEFAULT_TIMEOUT_S",
    "OpenAIChatModel",
    "StructuredMode",
]

log = structlog.get_logger(__name__)

DEFAULT_OPENAI_BASE_URL = "https://api.openai.com/v1"
"""Where ``OpenAIChatModel`` sends requests unless told otherwise."""

DEFAULT_TIMEOUT_S = 120.0
"""Time-out of each HTTP attempt when neither the request's settings nor the model set one."""

DEFAULT_MAX_REPLY_BYTES = 1_000_000
MAX_IMAGE_REPLY_BYTES = 64_000_000
"""Largest reply read from an images endpoint (a base64 PNG)."""
"""Largest reply body read; a larger 200 reply is an invalid reply (no agent output is near 1 MB)."""

CONTEXT_ESTIMATE_SLACK = 1.1
"""A prompt is refused before sending only when its estimated size exceeds ``context_tokens``
by this factor: the estimate can be off by about that much either way."""

StructuredMode = Literal["json_schema", "json_object", "none"]
"""How a reply is constrained: a strict JSON schema, any JSON object, or free text."""

_IMAGE_REJECTED = re.compile(
    r"image input is not supported|mmproj|image_url is only supported|does not support (image|vision)"
    r"|(image|vision)[^.]{0,40}(not supported|unsupported)",
    re.IGNORECASE,
)
_CONTEXT_CODES = frozenset(
    {"context_length_exceeded", "exceed_context_size_error", "context_window_exceeded"}
)
_CONTEXT_WORDS = re.compile(
    r"(exceed|longer than|too long|too large|greater than|more than)[^.]{0,80}context"
    r"|maximum context length|context (length|size|window) (is )?exceeded|prompt is too long",
    re.IGNORECASE,
)
_CONTEXT_SIZE = re.compile(
    r"maximum context length is (\d+)|(\d+) maximum|context (?:size|window) of (\d+)", re.I
)
_PROMPT_SIZE = re.compile(
    r"\((\d+) in the messages|messages resulted in (\d+) tokens|prompt is too long: (\d+) tokens", re.I
)
_EXCERPT_BYTES = 2000
PROBE_MAX_BYTES = 1 << 20
"""Largest ``GET /props`` reply read (bytes): llama.cpp's is a few kilobytes."""


class _UnusableReply(Exception):
    """A 200 reply that is no completion: becomes an invalid reply, not a transport error."""

    def __init__(self, text: str, problem: str) -> None:
        super().__init__(problem)
        self.text = text
        self.problem = problem


def _json_or_none(raw: bytes) -> Any:
    try:
        return json.loads(raw)
    except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError
        return None


def _error_message(data: Any, text: str) -> str:
    if isinstance(data, dict):
        err = data.get("error")
        if isinstance(err, dict) and err.get("message"):
            return str(err["message"])
        if isinstance(err, str) and err:
            return err
        if data.get("message"):
            return str(data["message"])
    return text.strip()[:500] or "(empty body)"


def _count(value: Any) -> int:
    """A token count from a usage field: a non-negative number, anything else counts 0."""
    if isinstance(value, bool):
        return 0
    if isinstance(value, int):
        return max(0, value)
    if isinstance(value, float) and math.isfinite(value):
        return max(0, int(value))
    if isinstance(value, str) and value.strip().isdigit():
        return int(value.strip())
    return 0


def _first_int(pattern: re.Pattern[str], text: str) -> int | None:
    match = pattern.search(text)
    if match is None:
        return None
    return next(int(g) for g in match.groups() if g is not None)


def _context_length_error(status: int, data: Any, message: str, body: str) -> ModelContextLengthError | None:
    """The reply as a :class:`ModelContextLengthError` when it says the prompt is too long."""
    if status == 429:  # "too many tokens per minute" is a rate limit, not the window
        return None
    err = data.get("error") if isinstance(data, dict) else None
    fields: dict[str, Any] = err if isinstance(err, dict) else (data if isinstance(data, dict) else {})
    codes = {str(fields.get("code") or ""), str(fields.get("type") or "")}
    if not codes & _CONTEXT_CODES and not _CONTEXT_WORDS.search(message):
        return None
    prompt = _count(fields.get("n_prompt_tokens")) or _first_int(_PROMPT_SIZE, message)
    context = _count(fields.get("n_ctx")) or _first_int(_CONTEXT_SIZE, message)
    return ModelContextLengthError(
        message, status_code=status, body=body, prompt_tokens=prompt or None, context_tokens=context or None
    )


def _png_data_url(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


@dataclass
class _Spent:
    """What one request has cost so far, over all its attempts."""

    images: int
    usage: Usage = field(default_factory=Usage)

    def count(self, data: Any) -> None:
        """One attempt got a response: count it, with the tokens its body reports."""
        raw = data.get("usage") if isinstance(data, dict) else None
        raw = raw if isinstance(raw, dict) else {}
        self.usage = self.usage + Usage(
            requests=1,
            input_tokens=_count(raw.get("prompt_tokens", raw.get("input_tokens"))),
            output_tokens=_count(raw.get("completion_tokens", raw.get("output_tokens"))),
            images=self.images,
        )


class OpenAIChatModel(CompletionModel):
    """A chat model behind an OpenAI-compatible ``/chat/completions`` endpoint.

    Replies are validated as the requested pydantic type (see :class:`CompletionModel`;
    the asking agent repairs a bad one). ``vision=False`` drops image parts before sending:
    the agents already put a text rendering of the same facts in the messages.
    """

    def __init__(
        self,
        model: str,
        *,
        base_url: str = DEFAULT_OPENAI_BASE_URL,
        api_key: str | None = None,
        api_key_env: str = "OPENAI_API_KEY",
        vision: bool = True,
        structured: StructuredMode = "json_schema",
        timeout_s: float | None = None,
        retry: HTTPRetryPolicy | None = None,
        schema_bounds: SchemaBounds | None = None,
        max_tokens_field: str = "max_tokens",
        context_tokens: int | None = None,
        max_reply_bytes: int = DEFAULT_MAX_REPLY_BYTES,
        client: httpx.AsyncClient | None = None,
        transport: httpx.AsyncBaseTransport | None = None,
        sleep: Callable[[float], Awaitable[None]] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """Configure the endpoint; no connection is opened until the first request.

        * ``model`` — the server's model name (``"gpt-4o-mini"``, ``"qwen2.5-coder-0.5b-instruct"``).
        * ``base_url`` — everything before ``/chat/completions``.
        * ``api_key`` / ``api_key_env`` — the key, or the environment variable holding it
          (``OPENAI_API_KEY`` by default). Without one no ``Authorization`` header is sent,
          which local servers accept; api.openai.com without a key is a :class:`ModelConfigError`.
        * ``vision`` — whether image parts are sent.
        * ``structured`` — ``"json_schema"`` (strict schema, constrained decoding),
          ``"json_object"`` (any JSON object) or ``"none"`` (free text; JSON is extracted).
        * ``timeout_s`` — time-out of each HTTP attempt (seconds), used when the request's
          ``ModelSettings.timeout_s`` is ``None``; ``None`` here means :data:`DEFAULT_TIMEOUT_S` (120 s).
        * ``retry`` — the transient-failure policy (attempts, waits, total budget).
        * ``schema_bounds`` — bounds added to unbounded arrays in the sent schema.
        * ``max_tokens_field`` — ``"max_tokens"``, or ``"max_completion_tokens"`` for newer OpenAI models.
        * ``context_tokens`` — the server's context window, when known: a prompt whose
          estimate (:func:`~scenemosaic.models.estimate_tokens`) is over it by more than
          :data:`CONTEXT_ESTIMATE_SLACK` raises :class:`ModelContextLengthError` unsent.
        * ``max_reply_bytes`` — the most reply bytes read; a larger 200 reply is an invalid reply.
        * ``client`` / ``transport`` — an ``httpx.AsyncClient`` or transport to use (tests pass
          ``httpx.MockTransport``); a client passed in is not closed by :meth:`aclose`.
        * ``sleep`` / ``clock`` — how to wait between retries and read the time for the
          retry budget (tests replace both; a fake ``sleep`` can advance a fake ``clock``).
        """
        if structured not in ("json_schema", "json_object", "none"):
            raise ModelConfigError(
                f"structured must be 'json_schema', 'json_object' or 'none', not {structured!r}"
            )
        self.model = model
        self.name = f"openai:{model}"
        self.base_url = base_url.rstrip("/")
        self.vision = vision
        self.structured: StructuredMode = structured
        if timeout_s is not None and timeout_s <= 0:
            raise ModelConfigError(f"timeout_s must be positive, got {timeout_s}")
        if context_tokens is not None and context_tokens < 1:
            raise ModelConfigError(f"context_tokens must be positive, got {context_tokens}")
        if max_reply_bytes < 1:
            raise ModelConfigError(f"max_reply_bytes must be positive, got {max_reply_bytes}")
        self.timeout_s: float = timeout_s if timeout_s is not None else DEFAULT_TIMEOUT_S
        self._timeout_set = timeout_s is not None
        self.context_tokens = context_tokens
        self.max_reply_bytes = max_reply_bytes
        self.retry = retry or HTTPRetryPolicy()
        self.schema_bounds = schema_bounds or SchemaBounds()
        self.max_tokens_field = max_tokens_field
        key = api_key if api_key is not None else os.environ.get(api_key_env)
        if not key and httpx.URL(self.base_url).host == "api.openai.com":
            raise ModelConfigError(
                f"no API key for {self.base_url}: set the environment variable {api_key_env}"
            )
        self._api_key = key or None
        self._api_key_env = api_key_env
        self._client = client
        self._owns_client = client is None
        self._client_loop: asyncio.AbstractEventLoop | None = None
        self._transport = transport
        self._sleep: Callable[[float], Awaitable[None]] = sleep or asyncio.sleep
        self._clock = clock
        self._rng = random.Random()
        self._schemas: dict[type[BaseModel], dict[str, Any]] = {}

    def __repr__(self) -> str:
        return f"OpenAIChatModel({self.model!r}, base_url={self.base_url!r}, vision={self.vision})"

    @property
    def default_timeout_s(self) -> float:
        """This model's own per-attempt time-out (``timeout_s``)."""
        return self.timeout_s

    # -- connection ------------------------------------------------------------------------
    def _http(self) -> httpx.AsyncClient:
        if not self._owns_client:
            assert self._client is not None
            return self._client
        loop = asyncio.get_running_loop()
        if self._client is None or self._client_loop is not loop:
            # A pooled client belongs to one event loop; a new loop (a new asyncio.run) gets its own.
            self._client = httpx.AsyncClient(transport=self._transport)
            self._client_loop = loop
        return self._client

    async def server_slots(self, timeout_s: float = 3.0) -> int | None:
        """How many requests the server says it works on at once, when it says (llama.cpp's
        ``GET /props`` ``total_slots``); ``None`` for servers that do not (no retries, no error).

        The probe is bounded as a whole, like every reply: ``timeout_s`` for connect, send and the
        whole body (a server that trickles bytes is cut), and :data:`PROBE_MAX_BYTES` of body (an
        endless one is cut)."""
        root = self.base_url[: -len("/v1")] if self.base_url.endswith("/v1") else self.base_url
        try:
            async with asyncio.timeout(timeout_s):
                async with self._http().stream("GET", f"{root}/props", timeout=timeout_s) as response:
                    raw, whole = await read_capped(response, PROBE_MAX_BYTES)
            data = json.loads(raw) if response.status_code == 200 and whole else None
            slots = data.get("total_slots") if isinstance(data, dict) else None
        except (httpx.HTTPError, TimeoutError, ValueError, RecursionError):
            return None
        return slots if isinstance(slots, int) and not isinstance(slots, bool) and slots > 0 else None

    async def aclose(self) -> None:
        """Close the HTTP client this model created (a client passed in stays open)."""
        if self._owns_client and self._client is not None:
            await self._client.aclose()
            self._client = None

    # -- wire format -----------------------------------------------------------------------
    def wire_messages(self, messages: list[Message]) -> tuple[list[dict[str, Any]], int]:
        """Messages in the Chat Completions format, and how many images they carry.

        Text-only messages are sent as one string (the widest-supported form); messages
        with images as a list of ``text`` and ``image_url`` parts. Without ``vision``
        image parts are dropped.
        """
        out: list[dict[str, Any]] = []
        images = 0
        for message in messages:
            keep_images = self.vision and message.role == "user"
            parts = [p for p in message.parts if isinstance(p, TextPart) or keep_images]
            if not parts:
                continue
            if not any(isinstance(p, ImagePart) for p in parts):
                text = "\n\n".join(p.text for p in parts if isinstance(p, TextPart))
                out.append({"role": message.role, "content": text})
                continue
            content: list[dict[str, Any]] = []
            for part in parts:
                if isinstance(part, TextPart):
                    content.append({"type": "text", "text": part.text})
                else:
                    if part.label:
                        content.append({"type": "text", "text": f"[image: {part.label}]"})
                    content.append({"type": "image_url", "image_url": {"url": _png_data_url(part.png)}})
                    images += 1
            out.append({"role": message.role, "content": content})
        return out, images

    def response_format(self, output_type: type[BaseModel]) -> dict[str, Any] | None:
        """The ``response_format`` field for ``output_type`` under this model's ``structured`` mode."""
        if self.structured == "none":
            return None
        if self.structured == "json_object":
            return {"type": "json_object"}
        name = re.sub(r"[^A-Za-z0-9_-]", "_", output_type.__name__)[:64]
        return {
            "type": "json_schema",
            "json_schema": {
                "name": name,
                "schema": self._strict_schema(output_type),
                "strict": True,
            },
        }

    def _with_schema_text(self, wire: list[dict[str, Any]], output_type: type[BaseModel]) -> list[dict[str, Any]]:
        """Without a strict ``response_format`` the server never sees the schema: state the same
        strict schema (compact JSON) at the end of the system message instead."""
        note = "The JSON object must match this JSON schema: " + json.dumps(
            self._strict_schema(output_type), separators=(",", ":"), sort_keys=True
        )
        out = [dict(m) for m in wire]
        for m in out:
            if m["role"] == "system" and isinstance(m["content"], str):
                m["content"] = m["content"] + "\n\n" + note
                return out
        return [{"role": "system", "content": note}, *out]

    def _strict_schema(self, output_type: type[BaseModel]) -> dict[str, Any]:
        # Schemas are built once per output type; the body only reads them.
        schema = self._schemas.get(output_type)
        if schema is None:
            schema = self._schemas[output_type] = strict_json_schema(output_type, self.schema_bounds)
        return schema

    def payload(
        self, messages: list[Message], output_type: type[BaseModel], settings: ModelSettings
    ) -> tuple[dict[str, Any], int]:
        """The request body for one completion, and the number of images in it."""
        wire, images = self.wire_messages(messages)
        if self.structured != "json_schema":
            wire = self._with_schema_text(wire, output_type)
        body: dict[str, Any] = {"model": self.model, "messages": wire, "stream": False}
        if settings.temperature is not None:
            body["temperature"] = settings.temperature
        if settings.max_tokens is not None:
            body[self.max_tokens_field] = settings.max_tokens
        if settings.seed is not None:
            body["seed"] = settings.seed
        fmt = self.response_format(output_type)
        if fmt is not None:
            body["response_format"] = fmt
        return body, images

    # -- the request path ------------------------------------------------------------------
    async def complete(
        self,
        messages: list[Message],
        output_type: type[BaseModel],
        settings: ModelSettings,
        context: RequestContext | None,
    ) -> Completion:
        """One completion; a reply cut at ``max_tokens`` is sent again once with twice the cap.

        The time-out of each attempt is ``settings.timeout_s`` when set, else the model's
        ``timeout_s``. A :class:`ModelError` raised here carries ``usage`` (what the attempts
        that got a response cost), like :class:`OutputValidationError` does.
        """
        self._refuse_if_too_long(messages)
        body, images = self.payload(messages, output_type, settings)
        timeout = settings.timeout_s if settings.timeout_s is not None else self.timeout_s
        give_up_at = self._clock() + self.retry.max_total_s
        agent = context.agent if context else None
        spent = _Spent(images=images)
        doubled = False
        try:
            while True:
                started = time.perf_counter()
                data = await self._post(body, timeout_s=timeout, give_up_at=give_up_at, spent=spent)
                latency = time.perf_counter() - started
                text, finish = self._read_choice(data)
                log.debug(
                    "chat completion",
                    model=self.model,
                    agent=agent,
                    latency_s=round(latency, 3),
                    finish=finish,
                )
                if finish != "length":
                    return Completion(text=text, usage=spent.usage)
                cap = body.get(self.max_tokens_field)
                if cap is None or doubled or not settings.retry_truncated:
                    return Completion(text=text, usage=spent.usage, truncated=True)
                log.info(
                    "reply truncated; retrying with a doubled token cap",
                    model=self.model,
                    agent=agent,
                    max_tokens=cap,
                )
                body = {**body, self.max_tokens_field: int(cap) * 2}
                doubled = True
        except _UnusableReply as bad:
            return Completion(text=bad.text, usage=spent.usage, problems=[bad.problem])
        except ModelError as exc:
            # The exception types of the tree carry no usage field but OutputValidationError's;
            # the instrumented model and the rate limiter read this one when it is there.
            exc.usage = spent.usage  # type: ignore[attr-defined]
            raise

    async def generate_image(self, prompt: str, *, size: str = "1024x1024", model: str | None = None) -> tuple[bytes, Usage]:
        """``POST /images/generations`` (``n`` = 1, ``response_format`` ``b64_json``) under the same
        retries, time-outs and reply-size cap as chat requests; the PNG bytes and the usage
        (requests, and tokens when the server reports them). A reply that is no image raises
        :class:`~scenemosaic.exceptions.ModelError` naming what came back."""
        if not prompt.strip():
            raise ModelConfigError("the image prompt is empty")
        body: dict[str, Any] = {"model": model or self.model, "prompt": prompt, "n": 1, "size": size, "response_format": "b64_json"}
        spent = _Spent(images=0)
        give_up_at = self._clock() + self.retry.max_total_s
        try:
            data = await self._post(
                body,
                # drawing takes longer than answering: 180 s unless a time-out was set (--request-timeout)
                timeout_s=self.timeout_s if self._timeout_set else max(self.timeout_s, 180.0),
                give_up_at=give_up_at,
                spent=spent,
                path="/images/generations",
                max_bytes=MAX_IMAGE_REPLY_BYTES,
            )
        except _UnusableReply as bad:
            raise ModelError(f"{self.name}: the images endpoint at {self.base_url} gave no image: {bad.problem}") from bad
        items = data.get("data")
        first = items[0] if isinstance(items, list) and items and isinstance(items[0], dict) else {}
        encoded = first.get("b64_json")
        if not isinstance(encoded, str):
            what = "a URL instead of b64_json" if "url" in first else f"keys {sorted(data)[:8]}"
            raise ModelError(f"{self.name}: the images endpoint at {self.base_url} answered {what}; expected data[0].b64_json")
        try:
            png = base64.b64decode(encoded, validate=True)
            from PIL import Image

            with Image.open(io.BytesIO(png)) as img:
                img.verify()
        except Exception as exc:
            raise ModelError(f"{self.name}: data[0].b64_json from {self.base_url} is not an image ({exc})") from exc
        return png, spent.usage

    def _refuse_if_too_long(self, messages: list[Message]) -> None:
        """Raise :class:`ModelContextLengthError` (nothing sent) for a prompt that clearly cannot fit."""
        if self.context_tokens is None:
            return
        sent = [
            Message(
                m.role,
                tuple(p for p in m.parts if isinstance(p, TextPart) or (self.vision and m.role == "user")),
            )
            for m in messages
        ]
        estimate = estimate_tokens(sent)
        if estimate > self.context_tokens * CONTEXT_ESTIMATE_SLACK:
            raise ModelContextLengthError(
                f"{self.name}: the prompt (about {estimate} tokens, estimated) cannot fit the "
                f"{self.context_tokens}-token context window; nothing was sent",
                status_code=400,
                body="",
                prompt_tokens=estimate,
                context_tokens=self.context_tokens,
                sent=False,
            )

    async def _post(
        self,
        body: dict[str, Any],
        *,
        timeout_s: float,
        give_up_at: float,
        spent: _Spent,
        path: str = "/chat/completions",
        max_bytes: int | None = None,
    ) -> dict[str, Any]:
        """Send ``body`` under the one HTTP policy (:func:`send_with_retries`): until an attempt
        succeeds, a failure is not transient, or the policy says stop."""

        async def attempt(limit: float) -> dict[str, Any]:
            return await self._post_once(body, timeout_s=limit, spent=spent, path=path, max_bytes=max_bytes)

        try:
            return await send_with_retries(
                attempt,
                timeout_s=timeout_s,
                policy=self.retry,
                give_up_at=give_up_at,
                now=self._clock,
                sleep=self._sleep,
                rng=self._rng,
                what=f"request to {self.name}",
            )
        except GiveUp as stopped:
            if isinstance(stopped.failure, ModelHTTPError):
                raise stopped.failure from None
            raise self._transport_error(stopped, timeout_s) from stopped.failure
        except httpx.UnsupportedProtocol as exc:
            raise ModelConfigError(f"{self.name}: cannot send to {self.base_url}: {exc}") from exc
        except httpx.HTTPError as exc:
            if is_unreachable(exc):
                raise ModelEndpointError(
                    f"{unreachable_words(exc, self.base_url, 'model server')}: start it or fix --model, or use --model rules",
                    url=self.base_url,
                ) from exc
            # our own request is malformed: another attempt cannot help
            raise self._transport_error(GiveUp(exc, 1), timeout_s) from exc

    def _transport_error(self, stopped: GiveUp, timeout_s: float) -> ModelError:
        failure, attempts = stopped.failure, stopped.attempts
        tries = f"{attempts} attempt{'s' if attempts != 1 else ''}"
        if stopped.timed_out:
            budget = f"{timeout_s:g} s" + (f", then {2 * timeout_s:g} s" if attempts > 1 else "")
            return ModelError(
                f"{self.name}: request to {self.base_url} timed out ({budget}) after {tries}: "
                f"{type(failure).__name__}: {failure}"
            )
        return ModelError(
            f"{self.name}: request to {self.base_url} failed after {tries}: {type(failure).__name__}: {failure}"
        )

    async def _post_once(
        self,
        body: dict[str, Any],
        *,
        timeout_s: float,
        spent: _Spent,
        path: str = "/chat/completions",
        max_bytes: int | None = None,
    ) -> dict[str, Any]:
        """One attempt (the policy bounds it as a whole): the reply's JSON object, or an
        exception saying what went wrong."""
        headers = {"Accept": "application/json"}
        if self._api_key:
            headers["Authorization"] = f"Bearer {self._api_key}"
        url = f"{self.base_url}{path}"
        client = self._http()
        async with client.stream("POST", url, json=body, headers=headers, timeout=timeout_s) as response:
            raw, whole = await read_capped(response, max_bytes or self.max_reply_bytes, excerpt=_EXCERPT_BYTES)
        status = response.status_code
        data = _json_or_none(raw) if whole else None
        spent.count(data)
        text = raw.decode("utf-8", errors="replace")
        if status == 200 and not whole:
            raise _UnusableReply(
                f"{text[:_EXCERPT_BYTES]}\n[... cut: the reply is over {self.max_reply_bytes} bytes]",
                f"the reply is larger than the {self.max_reply_bytes}-byte limit; answer with the JSON object only",
            )
        if status != 200:
            self._raise_for_status(status, data, text, body, response.headers.get("retry-after"), url)
        if not isinstance(data, dict):
            what = "is not JSON" if data is None else f"is JSON but not an object ({type(data).__name__})"
            raise _UnusableReply(
                text[:_EXCERPT_BYTES], f"the server's reply {what}; expected a chat completion"
            )
        error = data.get("error")
        if isinstance(error, dict) and error.get("message"):
            # An error wrapped in a 200 (some proxies and servers do this): no completion, so an
            # invalid reply the agent repairs or falls back from, unless it is the context window.
            message = str(error["message"])
            too_long = _context_length_error(200, data, message, text)
            if too_long is not None:
                raise too_long
            raise _UnusableReply(text[:_EXCERPT_BYTES], f"the server answered with an error: {message}")
        return data

    def _raise_for_status(
        self, status: int, data: Any, text: str, body: dict[str, Any], retry_after: str | None, url: str
    ) -> None:
        message = _error_message(data, text)
        too_long = _context_length_error(status, data, message, text)
        if too_long is not None:
            raise too_long
        if status in (401, 403):
            raise ModelEndpointError(
                f"the model server at {self.base_url} refused the key (HTTP {status}: {message[:200]}): "
                f"set a valid key in {self._api_key_env}, or use --model rules",
                url=self.base_url,
                status_code=status,
            )
        if status == 404:
            missing = f"model {self.model!r}" if "model" in message.lower() else f"nothing at {url}"
            raise ModelEndpointError(
                f"{missing} not found on the model server at {self.base_url} (HTTP 404: {message[:200]}): "
                "check the name and URL in --model, or use --model rules",
                url=self.base_url,
                status_code=status,
            )
        has_images = any(
            isinstance(m.get("content"), list) and any(p.get("type") == "image_url" for p in m["content"])
            for m in body.get("messages", [])
        )
        if has_images and _IMAGE_REJECTED.search(message):
            raise ModelConfigError(
                f"{self.name} at {self.base_url} does not accept images ({message!r}); "
                "turn the `vision` setting off (vision=False, --no-vision on the command line, or SCENEMOSAIC_VISION=0)"
            )
        if "response_format" in body and "response_format" in message:
            raise ModelConfigError(
                f"{self.name} at {self.base_url} rejected response_format {body['response_format']['type']!r} "
                f"({message!r}); set the `structured` setting to 'json_object' or 'none'"
            )
        transient = transient_status_error(status, text, retry_after, message=message)
        if transient is not None:
            raise transient
        raise ModelHTTPError(message, status_code=status, body=text)

    def _read_choice(self, data: dict[str, Any]) -> tuple[str, str | None]:
        """The reply text and finish reason of ``choices[0]``; :class:`_UnusableReply` when there is none."""
        shown = json.dumps(data)[:_EXCERPT_BYTES]
        choices = data.get("choices")
        if not isinstance(choices, list) or not choices:
            raise _UnusableReply(shown, "the server's reply holds no choices")
        choice = choices[0]
        if not isinstance(choice, dict):
            raise _UnusableReply(
                shown, f"choices[0] in the server's reply is a {type(choice).__name__}, not an object"
            )
        finish_raw = choice.get("finish_reason")
        finish = str(finish_raw) if finish_raw is not None else None
        message = choice.get("message")
        if not isinstance(message, dict):
            raise _UnusableReply(
                shown,
                f"choices[0].message in the server's reply is a {type(message).__name__}, not an object",
            )
        content = message.get("content")
        if isinstance(content, list):  # some servers answer in parts
            content = "".join(
                p if isinstance(p, str) else str(p.get("text") or "")
                for p in content
                if isinstance(p, str) or (isinstance(p, dict) and isinstance(p.get("text"), str))
            )
        elif content is not None and not isinstance(content, str):
            content = json.dumps(content)  # an already-decoded object: validation reads it the same
        if content:
            return content, finish
        if finish == "length":
            return "", finish  # cut before any text: the truncation path sends it again
        refusal = message.get("refusal")
        if refusal:
            raise _UnusableReply(f"(refusal: {refusal})", f"the model refused to answer: {refusal}")
        raise _UnusableReply(shown, "the reply has no content")

"""A model behind an OpenAI-compatible Chat Completions endpoint (OpenAI, vLLM, llama.cpp...).

The wire format is the plain ``POST {base_url}/chat/completions`` JSON; images travel as
``image_url`` parts holding ``data:image/png;base64,...`` URLs. Transient failures (429,
5xx, connect errors, timeouts) are retried with tenacity, honouring ``Retry-After``; a
dropped keep-alive connection (``httpx.RemoteProtocolError``) is retried once at once.
Everything else becomes a :class:`ModelHTTPError` carrying the status and the body.
"""

from __future__ import annotations

import asyncio
import base64
import json
import os
import random
import re
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from email.utils import parsedate_to_datetime
from typing import Any, Literal

import httpx
import structlog
from pydantic import BaseModel
from tenacity import AsyncRetrying, RetryCallState, retry_if_exception, stop_after_attempt

from scenemosaic.exceptions import ModelConfigError, ModelError, ModelHTTPError
from scenemosaic.models._base import ImagePart, Message, ModelSettings, RequestContext, TextPart, Usage
from scenemosaic.models._completion import Completion, CompletionModel
from scenemosaic.models._schema import SchemaBounds, strict_json_schema

__all__ = ["DEFAULT_OPENAI_BASE_URL", "HTTPRetryPolicy", "OpenAIChatModel", "StructuredMode"]

log = structlog.get_logger(__name__)

DEFAULT_OPENAI_BASE_URL = "https://api.openai.com/v1"
"""Where ``OpenAIChatModel`` sends requests unless told otherwise."""

StructuredMode = Literal["json_schema", "json_object", "none"]
"""How a reply is constrained: a strict JSON schema, any JSON object, or free text."""

_TRANSIENT_STATUS = frozenset({408, 409, 425, 429})
_IMAGE_REJECTED = re.compile(
    r"image input is not supported|mmproj|image_url is only supported|does not support (image|vision)"
    r"|(image|vision)[^.]{0,40}(not supported|unsupported)",
    re.IGNORECASE,
)


@dataclass(frozen=True)
class HTTPRetryPolicy:
    """When and how long to wait before re-sending a request that failed transiently."""

    max_attempts: int = 4
    """Attempts in all, the first included (429, 5xx, connect errors and timeouts)."""
    initial_backoff_s: float = 1.0
    """Wait before the second attempt when the server gives no ``Retry-After`` (seconds); doubles per attempt."""
    max_backoff_s: float = 30.0
    """Cap on the exponential wait (seconds), before jitter."""
    jitter_s: float = 1.0
    """Uniform random extra wait in ``[0, jitter_s]`` seconds, so parallel clients spread out."""
    max_retry_after_s: float = 120.0
    """Cap on a server's ``Retry-After`` (seconds): a longer request is waited out only this long."""


class _TransientHTTPError(ModelHTTPError):
    """A 429/5xx reply worth retrying; ``retry_after_s`` is the server's hint, if any."""

    def __init__(self, message: str, *, status_code: int, body: str, retry_after_s: float | None) -> None:
        super().__init__(message, status_code=status_code, body=body)
        self.retry_after_s = retry_after_s


def _is_transient(exc: BaseException) -> bool:
    return isinstance(exc, _TransientHTTPError | httpx.TimeoutException | httpx.ConnectError)


def parse_retry_after(value: str | None, *, now: datetime | None = None) -> float | None:
    """Seconds to wait from a ``Retry-After`` header (delta seconds or an HTTP date); ``None`` if absent."""
    if not value:
        return None
    value = value.strip()
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        when = parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return max(0.0, (when - (now or datetime.now(UTC))).total_seconds())


def _error_message(body: str) -> str:
    try:
        data = json.loads(body)
    except ValueError:
        return body.strip()[:500] or "(empty body)"
    if isinstance(data, dict):
        err = data.get("error")
        if isinstance(err, dict) and err.get("message"):
            return str(err["message"])
        if isinstance(err, str):
            return err
        if data.get("message"):
            return str(data["message"])
    return body.strip()[:500]


def _png_data_url(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


class OpenAIChatModel(CompletionModel):
    """A chat model behind an OpenAI-compatible ``/chat/completions`` endpoint.

    Replies are validated as the requested pydantic type, with schema repair (see
    :class:`CompletionModel`). ``vision=False`` drops image parts before sending: the
    agents already put a text rendering of the same facts in the messages.
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
        timeout_s: float = 120.0,
        retry: HTTPRetryPolicy | None = None,
        schema_bounds: SchemaBounds | None = None,
        max_tokens_field: str = "max_tokens",
        client: httpx.AsyncClient | None = None,
        transport: httpx.AsyncBaseTransport | None = None,
        sleep: Callable[[float], Awaitable[None]] | None = None,
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
        * ``timeout_s`` — per-request timeout (seconds) when the settings give none.
        * ``retry`` — the transient-failure policy.
        * ``schema_bounds`` — bounds added to unbounded arrays and strings in the sent schema.
        * ``max_tokens_field`` — ``"max_tokens"``, or ``"max_completion_tokens"`` for newer OpenAI models.
        * ``client`` / ``transport`` — an ``httpx.AsyncClient`` or transport to use (tests pass
          ``httpx.MockTransport``); a client passed in is not closed by :meth:`aclose`.
        * ``sleep`` — the coroutine used to wait between retries (tests replace it).
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
        self.timeout_s = timeout_s
        self.retry = retry or HTTPRetryPolicy()
        self.schema_bounds = schema_bounds or SchemaBounds()
        self.max_tokens_field = max_tokens_field
        key = api_key if api_key is not None else os.environ.get(api_key_env)
        if not key and httpx.URL(self.base_url).host == "api.openai.com":
            raise ModelConfigError(
                f"no API key for {self.base_url}: set the environment variable {api_key_env}"
            )
        self._api_key = key or None
        self._client = client
        self._owns_client = client is None
        self._client_loop: asyncio.AbstractEventLoop | None = None
        self._transport = transport
        self._sleep: Callable[[float], Awaitable[None]] = sleep or asyncio.sleep
        self._rng = random.Random()
        self._schemas: dict[type[BaseModel], dict[str, Any]] = {}

    def __repr__(self) -> str:
        return f"OpenAIChatModel({self.model!r}, base_url={self.base_url!r}, vision={self.vision})"

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
        """One completion; a reply cut at ``max_tokens`` is retried once with twice the cap."""
        body, images = self.payload(messages, output_type, settings)
        timeout = settings.timeout_s if settings.timeout_s is not None else self.timeout_s
        agent = context.agent if context else None
        usage = Usage()
        doubled = False
        while True:
            started = time.perf_counter()
            data = await self._post(body, timeout_s=timeout, has_images=images > 0)
            latency = time.perf_counter() - started
            text, finish = self._read_choice(data)
            usage = usage + self._read_usage(data, images)
            log.debug(
                "chat completion", model=self.model, agent=agent, latency_s=round(latency, 3), finish=finish
            )
            if finish != "length":
                return Completion(text=text, usage=usage)
            cap = body.get(self.max_tokens_field)
            if cap is None or doubled:
                return Completion(text=text, usage=usage, truncated=True)
            log.info(
                "reply truncated; retrying with a doubled token cap",
                model=self.model,
                agent=agent,
                max_tokens=cap,
            )
            body = {**body, self.max_tokens_field: int(cap) * 2}
            doubled = True

    async def _post(self, body: dict[str, Any], *, timeout_s: float, has_images: bool) -> dict[str, Any]:
        retrying = AsyncRetrying(
            stop=stop_after_attempt(max(1, self.retry.max_attempts)),
            wait=self._wait,
            retry=retry_if_exception(_is_transient),
            sleep=self._sleep,
            reraise=True,
            before_sleep=self._log_retry,
        )
        try:
            async for attempt in retrying:
                with attempt:
                    return await self._post_once(body, timeout_s=timeout_s, has_images=has_images)
        except httpx.TimeoutException as exc:
            raise ModelError(
                f"{self.name}: request timed out ({timeout_s:g} s) {self.retry.max_attempts} times: {exc!r}"
            ) from exc
        except httpx.HTTPError as exc:
            raise ModelError(
                f"{self.name}: request to {self.base_url} failed: {type(exc).__name__}: {exc}"
            ) from exc
        raise AssertionError("unreachable")  # pragma: no cover

    async def _post_once(self, body: dict[str, Any], *, timeout_s: float, has_images: bool) -> dict[str, Any]:
        headers = {"Accept": "application/json"}
        if self._api_key:
            headers["Authorization"] = f"Bearer {self._api_key}"
        url = f"{self.base_url}/chat/completions"
        client = self._http()
        try:
            response = await client.post(url, json=body, headers=headers, timeout=timeout_s)
        except httpx.RemoteProtocolError as exc:
            # A server may drop a pooled keep-alive connection (llama-server does after a
            # streamed reply); the pool has discarded it, so one immediate re-send suffices.
            log.warning("connection dropped by server; re-sending once", model=self.model, error=str(exc))
            response = await client.post(url, json=body, headers=headers, timeout=timeout_s)
        text = response.text
        if response.status_code != 200:
            message = _error_message(text)
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
            if response.status_code in _TRANSIENT_STATUS or response.status_code >= 500:
                raise _TransientHTTPError(
                    message,
                    status_code=response.status_code,
                    body=text,
                    retry_after_s=parse_retry_after(response.headers.get("retry-after")),
                )
            raise ModelHTTPError(message, status_code=response.status_code, body=text)
        try:
            data = response.json()
        except ValueError as exc:
            raise ModelHTTPError("reply body is not JSON", status_code=200, body=text) from exc
        if not isinstance(data, dict):
            raise ModelHTTPError("reply body is not a JSON object", status_code=200, body=text)
        error = data.get("error")
        if isinstance(error, dict) and error.get("message"):
            raise ModelHTTPError(str(error["message"]), status_code=200, body=text)
        return data

    def _wait(self, state: RetryCallState) -> float:
        exc = state.outcome.exception() if state.outcome else None
        if isinstance(exc, _TransientHTTPError) and exc.retry_after_s is not None:
            return min(exc.retry_after_s, self.retry.max_retry_after_s)
        backoff: float = self.retry.initial_backoff_s * 2.0 ** max(0, state.attempt_number - 1)
        return min(backoff, self.retry.max_backoff_s) + self._rng.uniform(0.0, self.retry.jitter_s)

    def _log_retry(self, state: RetryCallState) -> None:
        exc = state.outcome.exception() if state.outcome else None
        wait = state.next_action.sleep if state.next_action else None
        log.warning(
            "transient model failure; retrying",
            model=self.model,
            attempt=state.attempt_number,
            wait_s=wait,
            error=f"{type(exc).__name__}: {exc}",
        )

    def _read_choice(self, data: dict[str, Any]) -> tuple[str, str | None]:
        choices = data.get("choices")
        if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
            raise ModelHTTPError("reply has no choices", status_code=200, body=json.dumps(data)[:2000])
        choice = choices[0]
        message = choice.get("message") or {}
        content = message.get("content")
        if isinstance(content, list):  # some servers answer in parts
            content = "".join(str(p.get("text", "")) for p in content if isinstance(p, dict))
        if content is None:
            content = f"(no content; refusal: {message['refusal']})" if message.get("refusal") else ""
        finish = choice.get("finish_reason")
        return str(content), (str(finish) if finish is not None else None)

    @staticmethod
    def _read_usage(data: dict[str, Any], images: int) -> Usage:
        raw = data.get("usage") or {}
        return Usage(
            requests=1,
            input_tokens=int(raw.get("prompt_tokens") or 0),
            output_tokens=int(raw.get("completion_tokens") or 0),
            images=images,
        )

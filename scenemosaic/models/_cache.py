"""An on-disk cache of valid model replies, shared by processes and machines that see one folder.

``CachedModel(model, folder)`` answers a request it has seen before from ``folder`` and costs
nothing; otherwise it asks ``model`` and stores the reply. A request is keyed exactly as a
cassette keys it (:func:`~scenemosaic.models.canonical_request`: the model name, the messages with
images by their SHA-256, the output schema, the answer-changing settings), so equal requests hit
whatever run, job or worker made them first. Only validated replies are stored: a time-out, an
HTTP error or a reply that broke the schema is asked again next time.

One file per reply (``<folder>/<key[:2]>/<key>.json``), written to a temporary name and renamed
into place, so concurrent writers never leave a torn file and readers never take a half-written
one; two workers asking the same new question at once both pay once, and the last rename wins
with an equal answer. A cassette records a run to replay it exactly; this cache is for batch
re-runs (a retried or resumed job does not pay twice), not for reproducing a run.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import structlog
from pydantic import ValidationError

from scenemosaic.models._base import Message, Model, ModelSettings, OutputT, RequestContext, Usage
from scenemosaic.models._replay import canonical_request, request_key
from scenemosaic.models._wrapper import WrapperModel

__all__ = ["CACHE_FORMAT", "CachedModel"]

log = structlog.get_logger(__name__)

CACHE_FORMAT = "scenemosaic-reply"


class CachedModel(WrapperModel):
    """Answers from the reply cache in ``folder`` when it can, else asks ``wrapped`` and stores.

    ``hits`` and ``misses`` count this instance's requests (a hit reports ``Usage(cached=1)``:
    no request, no tokens).
    """

    def __init__(self, wrapped: Model, folder: str | os.PathLike[str]) -> None:
        super().__init__(wrapped)
        self.folder = Path(folder)
        self.hits = 0
        self.misses = 0

    def __repr__(self) -> str:
        return f"CachedModel({self.wrapped!r}, {str(self.folder)!r})"

    def _path(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.json"

    def _load(self, key: str, output_type: type[OutputT]) -> OutputT | None:
        path = self._path(key)
        try:
            entry = json.loads(path.read_text(encoding="utf-8"))
            if entry.get("format") != CACHE_FORMAT:
                return None
            return output_type.model_validate(entry["reply"])
        except FileNotFoundError:
            return None
        except (OSError, ValueError, KeyError, TypeError, AttributeError, ValidationError) as exc:
            # a damaged or foreign file: ask again and overwrite it
            log.warning("reply_cache_entry_unusable", path=str(path), error=f"{type(exc).__name__}: {exc}"[:300])
            return None

    def _store(self, key: str, entry: dict[str, Any]) -> None:
        path = self._path(key)
        try:
            from scenemosaic.scene import write_atomic  # the one atomic write

            path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(path, json.dumps(entry, sort_keys=True, ensure_ascii=False))
        except OSError as exc:  # a full or read-only disk costs the cache, not the run
            log.warning("reply_cache_write_failed", path=str(path), error=str(exc)[:300])

    async def request(
        self,
        messages: list[Message],
        output_type: type[OutputT],
        settings: ModelSettings | None = None,
        *,
        context: RequestContext | None = None,
    ) -> tuple[OutputT, Usage]:
        """The cached reply to an equal request, else the wrapped model's (then stored)."""
        canonical = canonical_request(self.name, messages, output_type, settings)
        key = request_key(canonical)
        cached = self._load(key, output_type)
        if cached is not None:
            self.hits += 1
            log.debug("reply_cache_hit", key=key[:12], agent=context.agent if context else None)
            return cached, Usage(cached=1)
        self.misses += 1
        output, usage = await self.wrapped.request(messages, output_type, settings, context=context)
        self._store(
            key,
            {
                "format": CACHE_FORMAT,
                "agent": context.agent if context else None,
                "output_type": output_type.__name__,
                "model": self.name,
                "reply": output.model_dump(mode="json"),
                "usage": dataclasses.asdict(usage),
            },
        )
        return output, usage

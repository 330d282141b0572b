"""The on-disk reply cache: an equal request is answered from disk at no cost, by any model
instance (another worker) that shares the folder; failures and broken replies are never cached."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from llm_fakes import VALID, FakeServer, Verdict, chat_reply, user_messages

from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models import CachedModel, RequestContext

CTX = RequestContext(agent="critic")


def _found(folder: Path, pattern: str) -> list[Path]:
    return sorted(folder.rglob(pattern))


async def test_an_equal_request_is_answered_from_disk_by_any_worker(tmp_path: Path) -> None:
    server = FakeServer(chat_reply(VALID), chat_reply({**VALID, "score": 40}))
    first_worker = CachedModel(server.model()[0], tmp_path)
    out, usage = await first_worker.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70 and usage.requests == 1 and len(server.requests) == 1
    second_worker = CachedModel(server.model()[0], tmp_path)  # another process, the same folder
    again, free = await second_worker.request(user_messages(), Verdict, context=CTX)
    assert again == out and free.requests == 0 and free.input_tokens == 0
    assert len(server.requests) == 1 and (second_worker.hits, second_worker.misses) == (1, 0)
    other, _ = await second_worker.request(user_messages("Evidence: two chairs."), Verdict, context=CTX)
    assert other.score == 40 and len(server.requests) == 2  # a different question is asked
    files = _found(tmp_path, "*.json")
    assert len(files) == 2 and all(f.parent.name == f.stem[:2] for f in files)
    assert not _found(tmp_path, "*.tmp")


async def test_a_broken_reply_is_not_cached_and_a_damaged_entry_is_asked_again(tmp_path: Path) -> None:
    server = FakeServer(chat_reply("not json at all"), default=chat_reply(VALID))
    model = CachedModel(server.model()[0], tmp_path)
    with pytest.raises(OutputValidationError):
        await model.request(user_messages(), Verdict, context=CTX)
    assert not _found(tmp_path, "*.json")
    out, _ = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    (entry,) = _found(tmp_path, "*.json")
    entry.write_text("{ torn", encoding="utf-8")
    asked = len(server.requests)
    again, usage = await model.request(user_messages(), Verdict, context=CTX)
    assert again == out and usage.requests == 1 and len(server.requests) == asked + 1
    assert json.loads(entry.read_text(encoding="utf-8"))["reply"]["score"] == 70  # rewritten whole

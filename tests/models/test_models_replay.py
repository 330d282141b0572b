"""ReplayModel: record, replay, record_missing, and misses that say what changed."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from llm_fakes import PNG_1PX, VALID, Verdict, user_messages
from pydantic import BaseModel

from scenemosaic.exceptions import ModelConfigError, ReplayMissError
from scenemosaic.models import (
    FunctionModel,
    Message,
    ModelSettings,
    ReplayModel,
    RequestContext,
    canonical_request,
    parse_model,
    request_key,
)


class Counter:
    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, messages: list[Message], context: RequestContext | None) -> dict[str, object]:
        self.calls += 1
        return {**VALID, "score": 10 + self.calls}


CRITIC = RequestContext(agent="critic")


async def _record(path: Path) -> tuple[Counter, Verdict]:
    fn = Counter()
    model = ReplayModel(FunctionModel(fn, name="vlm-a", vision=True), path, "record")
    out, _ = await model.request(user_messages(image=True), Verdict, context=CRITIC)
    return fn, out


async def test_record_then_replay_without_the_model(tmp_path: Path) -> None:
    path = tmp_path / "cassettes" / "run.json"
    fn, recorded = await _record(path)
    assert fn.calls == 1

    data = json.loads(path.read_text())
    assert data["format"] == "scenemosaic-cassette"
    assert data["models"] == {"vlm-a": {"vision": True}}
    ((key, entry),) = data["entries"].items()
    assert entry["agent"] == "critic"
    assert entry["reply"] == recorded.model_dump(mode="json")
    image_part = entry["request"]["messages"][1]["parts"][1]
    assert image_part == {"image_sha256": hashlib.sha256(PNG_1PX).hexdigest(), "label": "top-down view"}
    assert key == request_key(canonical_request("vlm-a", user_messages(image=True), Verdict, None))
    # Readable: indented, keys sorted, so diffs of a committed cassette stay small.
    text = path.read_text()
    assert text.startswith('{\n "entries"')
    assert list(tmp_path.joinpath("cassettes").iterdir()) == [path]  # no temp files left behind

    replay = ReplayModel(None, path, "replay")
    assert (replay.name, replay.vision) == ("vlm-a", True)
    out, usage = await replay.request(user_messages(image=True), Verdict, context=CRITIC)
    assert out == recorded
    assert usage.requests == 1
    # settings=None and the default settings are the same request.
    out2, _ = await replay.request(user_messages(image=True), Verdict, ModelSettings(), context=CRITIC)
    assert out2 == recorded


async def test_replay_miss_names_the_differing_message(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    await _record(path)
    replay = ReplayModel(None, path, "replay")
    with pytest.raises(ReplayMissError) as info:
        await replay.request(user_messages("Evidence: four chairs.", image=True), Verdict, context=CRITIC)
    assert info.value.differing == ["messages[1]"]
    assert "messages[1]" in str(info.value)
    assert "four" in str(info.value) and "three" in str(info.value)


async def test_replay_miss_names_a_changed_image(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    await _record(path)
    messages = user_messages(image=True)
    messages[1] = Message(
        role="user", parts=(messages[1].parts[0], type(messages[1].parts[1])(PNG_1PX + b"x"))
    )
    with pytest.raises(ReplayMissError) as info:
        await ReplayModel(None, path, "replay").request(messages, Verdict, context=CRITIC)
    assert info.value.differing == ["messages[1]"]


async def test_replay_miss_names_settings_schema_model_and_agent(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    await _record(path)
    replay = ReplayModel(None, path, "replay")
    with pytest.raises(ReplayMissError) as info:
        await replay.request(
            user_messages(image=True), Verdict, ModelSettings(temperature=0.7), context=CRITIC
        )
    assert info.value.differing == ["settings"]

    class Verdict2(Verdict):
        extra: str = ""

    with pytest.raises(ReplayMissError) as info:
        await replay.request(user_messages(image=True), Verdict2, context=CRITIC)
    assert info.value.differing == ["schema"]

    other_name = ReplayModel(None, path, "replay", name="vlm-b")
    with pytest.raises(ReplayMissError) as info:
        await other_name.request(user_messages(image=True), Verdict, context=CRITIC)
    assert info.value.differing == ["model"]

    # The agent is not part of the key (an identical request gets the identical answer)...
    actor = RequestContext(agent="actor")
    out, _ = await replay.request(user_messages(image=True), Verdict, context=actor)
    assert out.score == 11
    # ...but a miss for an agent without recordings says so.
    with pytest.raises(ReplayMissError, match=r"agent 'actor'.*it has: critic") as info:
        await replay.request(user_messages("Evidence: a desk."), Verdict, context=actor)
    assert info.value.differing == ["agent"]

    fewer = user_messages(image=True)[:1]
    with pytest.raises(ReplayMissError) as info:
        await replay.request(fewer, Verdict, context=CRITIC)
    assert info.value.differing == ["messages[1]"]
    assert isinstance(info.value, KeyError)


async def test_replay_of_missing_cassette_says_so(tmp_path: Path) -> None:
    replay = ReplayModel(None, tmp_path / "none.json", "replay", name="vlm-a")
    with pytest.raises(ReplayMissError, match="does not exist"):
        await replay.request(user_messages(), Verdict, context=CRITIC)


async def test_record_missing_asks_only_for_what_is_missing(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    fn = Counter()
    model = ReplayModel(FunctionModel(fn, name="vlm-a"), path, "record_missing")
    first, _ = await model.request(user_messages("A"), Verdict, context=CRITIC)
    again, _ = await model.request(user_messages("A"), Verdict, context=CRITIC)
    other, _ = await model.request(user_messages("B"), Verdict, context=CRITIC)
    assert fn.calls == 2
    assert first == again and first.score == 11 and other.score == 12
    assert len(json.loads(path.read_text())["entries"]) == 2
    # A fresh instance reads what was recorded.
    fresh = ReplayModel(FunctionModel(fn, name="vlm-a"), path, "record_missing")
    out, _ = await fresh.request(user_messages("B"), Verdict, context=CRITIC)
    assert (out.score, fn.calls) == (12, 2)


async def test_record_mode_overwrites_and_off_passes_through(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    fn = Counter()
    rec = ReplayModel(FunctionModel(fn, name="vlm-a"), path, "record")
    await rec.request(user_messages(), Verdict, context=CRITIC)
    await rec.request(user_messages(), Verdict, context=CRITIC)
    (entry,) = json.loads(path.read_text())["entries"].values()
    assert entry["reply"]["score"] == 12
    off = ReplayModel(FunctionModel(fn, name="vlm-a"), tmp_path / "off.json", "off")
    out, _ = await off.request(user_messages(), Verdict, context=CRITIC)
    assert out.score == 13
    assert not (tmp_path / "off.json").exists()


async def test_replay_via_parse_model_and_bad_cassettes(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    _, recorded = await _record(path)
    model = parse_model(f"replay:{path}")
    out, _ = await model.request(user_messages(image=True), Verdict, context=CRITIC)
    assert out == recorded
    bad = tmp_path / "bad.json"
    bad.write_text('{"not": "a cassette"}')
    with pytest.raises(ModelConfigError, match="not a scenemosaic cassette"):
        await ReplayModel(None, bad, "replay", name="x").request(user_messages(), Verdict, context=CRITIC)
    with pytest.raises(ModelConfigError):
        ReplayModel(None, path, "record")


class Tiny(BaseModel):
    v: float


async def test_floats_round_trip_exactly(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    value = 0.1 + 0.2
    rec = ReplayModel(FunctionModel(lambda m, c: Tiny(v=value), name="f"), path, "record")
    await rec.request(user_messages(), Tiny, context=CRITIC)
    out, _ = await ReplayModel(None, path, "replay").request(user_messages(), Tiny, context=CRITIC)
    assert out.v == value


def _asking(i: int) -> list[Message]:
    return [Message.text("user", f"evidence {i}")]


async def test_failures_are_recorded_and_replayed_as_they_happened(tmp_path: Path) -> None:
    """A time-out and an HTTP 503 (after the transport's retries) and a context refusal are part
    of a recorded run: replay raises them again, so agents fall back the same way."""
    from scenemosaic.exceptions import ModelContextLengthError, ModelError, ModelHTTPError

    failures: list[ModelError] = [
        ModelError("openai:qwen: request to http://127.0.0.1:8089/v1 timed out (120 s, then 240 s) after 2 attempts"),
        ModelHTTPError("server busy", status_code=503, body='{"error":"busy"}'),
        ModelContextLengthError("too long", status_code=400, body="{}", prompt_tokens=5000, context_tokens=4096),
    ]

    def failing(messages: list[Message], context: RequestContext | None) -> object:
        assert context is not None
        raise failures[int(context.agent[-1])]

    path = tmp_path / "failures.json"
    recorder = ReplayModel(FunctionModel(failing, name="vlm-a"), path, "record")
    raised: list[ModelError] = []
    for i in range(3):
        with pytest.raises(ModelError) as info:
            await recorder.request(_asking(i), Verdict, context=RequestContext(agent=f"agent{i}"))
        raised.append(info.value)
    entries = json.loads(path.read_text())["entries"].values()
    assert sorted(e["error"]["type"] for e in entries) == ["ModelContextLengthError", "ModelError", "ModelHTTPError"]

    replay = ReplayModel(None, path, "replay")
    for i, live in enumerate(raised):
        with pytest.raises(ModelError) as info:
            await replay.request(_asking(i), Verdict, context=RequestContext(agent=f"agent{i}"))
        again = info.value
        assert type(again) is type(live) and str(again) == str(live)
        if isinstance(live, ModelHTTPError):
            assert isinstance(again, ModelHTTPError) and again.status_code == live.status_code
        if isinstance(live, ModelContextLengthError):
            assert isinstance(again, ModelContextLengthError)
            assert (again.prompt_tokens, again.context_tokens) == (5000, 4096)

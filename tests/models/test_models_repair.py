"""Schema repair: invalid replies are sent back with their errors, a bounded number of times."""

from __future__ import annotations

import json

import pytest
from llm_fakes import VALID, FakeServer, Verdict, chat_reply, user_messages

from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models import FunctionModel, Message, RequestContext

CTX = RequestContext(agent="critic")


async def test_repair_succeeds_on_the_second_reply() -> None:
    bad = json.dumps({**VALID, "score": 150})
    server = FakeServer(
        chat_reply(bad, prompt_tokens=100, completion_tokens=20),
        chat_reply(VALID, prompt_tokens=160, completion_tokens=25),
    )
    model, _ = server.model()
    out, usage = await model.request(user_messages(), Verdict, context=CTX)
    assert out.score == 70
    assert (usage.requests, usage.input_tokens, usage.output_tokens) == (2, 260, 45)
    second = server.bodies[1]["messages"]
    assert len(second) == 4
    assert second[2] == {"role": "assistant", "content": bad}
    assert second[3]["role"] == "user"
    assert "score" in second[3]["content"]
    assert "less than or equal to 100" in second[3]["content"]


async def test_repair_gives_up_after_the_limit_with_the_raw_reply() -> None:
    replies = ["I think the chairs are fine.", '{"should_modify": "maybe"}', '{"notes": 3}']
    server = FakeServer(*[chat_reply(r) for r in replies])
    model, _ = server.model(max_repairs=2)
    with pytest.raises(OutputValidationError) as info:
        await model.request(user_messages(), Verdict, context=CTX)
    assert len(server.requests) == 3
    assert info.value.raw_reply == '{"notes": 3}'
    assert any(e.startswith("notes:") for e in info.value.errors)
    assert any("should_modify" in e for e in info.value.errors)
    assert "critic" in str(info.value)
    # Each repair request carries the whole conversation so far.
    assert [len(b["messages"]) for b in server.bodies] == [2, 4, 6]


async def test_function_model_prose_reply_is_repaired() -> None:
    seen: list[int] = []

    def critic(messages: list[Message], context: RequestContext | None) -> str:
        seen.append(len(messages))
        if len(messages) == 2:
            return "Sure! The layout looks good."
        assert "not JSON" in messages[-1].parts[0].text  # type: ignore[union-attr]
        return "```json\n" + json.dumps(VALID) + "\n```"

    model = FunctionModel({"critic": critic})
    out, usage = await model.request(user_messages(), Verdict, context=CTX)
    assert out == Verdict.model_validate(VALID)
    assert seen == [2, 4]
    assert usage.requests == 2

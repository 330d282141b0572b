"""Schema and check repair live in the agent: an invalid reply goes back with its errors, within one budget."""

from __future__ import annotations

import json
from typing import ClassVar

import pytest
from llm_fakes import VALID, FakeServer, Verdict, chat_reply
from pydantic import BaseModel

from scenemosaic.agents import AgentPolicy, SceneState, TaskAgent
from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models import FunctionModel, Message, Model, RequestContext, Usage
from scenemosaic.scene import Scene


class Chairs(BaseModel):
    n_chairs: int = 3


class CriticAgent(TaskAgent[SceneState, Chairs, Verdict]):
    """A critic-like agent: its evidence is a chair count, its output a :class:`Verdict`."""

    name: ClassVar[str] = "critic"
    prompt: ClassVar[str] = "You are a layout critic. Reply in JSON.\n"

    def gather(self, state: SceneState) -> Chairs:
        return Chairs()

    def solve(self, evidence: Chairs) -> Verdict:
        return Verdict(should_modify=False, notes=[], score=50)

    def apply(self, output: Verdict, state: SceneState) -> None:
        state.scene.metadata["score"] = output.score


def strict_state() -> SceneState:
    """Repairs only: no fallback, so a used-up budget raises."""
    return SceneState(scene=Scene(), policy=AgentPolicy(max_attempts=3, solver_fallback=False))


async def run(model: Model, state: SceneState | None = None) -> tuple[Verdict, Usage]:
    result = await CriticAgent().run(state or strict_state(), model)
    return result.output, result.usage


async def test_repair_succeeds_on_the_second_reply() -> None:
    bad = json.dumps({**VALID, "score": 150})
    server = FakeServer(
        chat_reply(bad, prompt_tokens=100, completion_tokens=20),
        chat_reply(VALID, prompt_tokens=160, completion_tokens=25),
    )
    model, _ = server.model()
    out, usage = await run(model)
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
    model, _ = server.model()
    with pytest.raises(OutputValidationError) as info:
        await run(model)
    assert len(server.requests) == 3
    assert info.value.raw_reply == '{"notes": 3}'
    assert any(e.startswith("notes:") for e in info.value.errors)
    assert any("should_modify" in e for e in info.value.errors)
    assert "critic" in str(info.value)
    # Each repair request carries the prompt, the last reply and its problems: it does not grow.
    assert [len(b["messages"]) for b in server.bodies] == [2, 4, 4]
    assert server.bodies[2]["messages"][2]["content"] == '{"should_modify": "maybe"}'
    assert "should_modify" in server.bodies[2]["messages"][3]["content"]


async def test_function_model_prose_reply_is_repaired() -> None:
    seen: list[int] = []

    def critic(messages: list[Message], context: RequestContext | None) -> str:
        seen.append(len(messages))
        if len(messages) == 2:
            return "Sure! The layout looks good."
        assert "not JSON" in messages[-1].parts[0].text  # type: ignore[union-attr]
        return "```json\n" + json.dumps(VALID) + "\n```"

    model = FunctionModel({"critic": critic})
    out, usage = await run(model)
    assert out == Verdict.model_validate(VALID)
    assert seen == [2, 4]
    assert usage.requests == 2

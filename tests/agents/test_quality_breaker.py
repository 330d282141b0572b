"""Issue 57: a kind of answer the model cannot give is found out at once and routed to the solver.

The run's :class:`~scenemosaic.models.QualityBreaker` counts, per agent kind, unusable replies in a
row; after ``--unusable-replies`` of them (2 by default) the kind's agents answer with their rule
solvers without asking, for the rest of the run. A kind that answers usably keeps being asked.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest
from agent_solvers import solver_answer

from scenemosaic import GenerateConfig, generate
from scenemosaic.agents import AgentPolicy
from scenemosaic.exceptions import ModelConfigError, UsageError
from scenemosaic.models import FunctionModel, Message, QualityBreaker, RequestContext

BEDROOM = Path(__file__).resolve().parents[1] / "fixtures" / "bedroom_22.json"


def test_a_kind_is_given_up_after_its_unusable_replies_in_a_row() -> None:
    async def go() -> QualityBreaker:
        breaker = QualityBreaker(2)
        first = await breaker.admit("walls")
        assert first.unusable("not JSON") is None  # one bad reply: a repair is still asked
        second = await breaker.admit("walls")
        second.usable()  # a repair that works resets the count
        third = await breaker.admit("walls")
        assert third.unusable("cut off") is None
        fourth = await breaker.admit("walls")
        given = fourth.unusable("object id 'room' does not exist")
        assert given is not None and given.requests == 4 and given.usable == 1
        refused = await breaker.admit("walls")
        assert refused.given_up is given  # nothing more is sent for this kind
        other = await breaker.admit("support")  # other kinds are asked as before
        assert other.given_up is None
        other.close()  # a time-out: no verdict either way
        return breaker

    summary = asyncio.run(go()).summary()
    assert summary["kinds"]["walls"] == {
        "requests": 4, "usable": 1, "unusable": 3, "answers": {}, "given_up": True,
        "reason": "object id 'room' does not exist",
    }  # fmt: skip
    assert summary["kinds"]["support"]["given_up"] is False and summary["kinds"]["support"]["unusable"] == 0
    assert summary["given_up"] == ["walls: given up after 4 requests (object id 'room' does not exist)"]


def test_concurrent_requests_of_an_untried_kind_cannot_overrun_the_threshold() -> None:
    async def go() -> tuple[int, int]:
        breaker = QualityBreaker(2)
        out = 0
        most = 0
        sent = 0

        async def ask() -> None:
            nonlocal out, most, sent
            ticket = await breaker.admit("critic")
            if ticket.given_up is not None:
                return
            sent += 1
            out += 1
            most = max(most, out)
            await asyncio.sleep(0.01)
            out -= 1
            ticket.unusable("no JSON")

        await asyncio.gather(*(ask() for _ in range(8)))
        return sent, most

    sent, most = asyncio.run(go())
    assert sent == 2 and most == 2  # eight layouts asked at once: two requests in all


def test_the_settings_are_checked() -> None:
    with pytest.raises(ModelConfigError):
        QualityBreaker(0)
    with pytest.raises(UsageError, match="solver_fallback"):
        AgentPolicy(quality=QualityBreaker())


def _poses(folder: Path) -> dict[str, Any]:
    scene = json.loads((folder / "scene.json").read_text(encoding="utf-8"))
    return {o["id"]: (o["pose"], o.get("parent")) for o in scene["objects"]}


def test_a_kind_answered_badly_is_asked_at_most_twice_and_the_others_every_time(tmp_path: Path) -> None:
    def counting(bad: str | None, asked: dict[str, int]) -> FunctionModel:
        def reply(messages: list[Message], context: RequestContext | None) -> Any:
            assert context is not None
            asked[context.agent] = asked.get(context.agent, 0) + 1
            if context.agent == bad:
                return "I think the layout is fine."  # never JSON
            return solver_answer(messages, context)

        return FunctionModel(reply, name=f"bad-{bad}", vision=False)

    good: dict[str, int] = {}
    generate(BEDROOM, tmp_path / "good", GenerateConfig(model=counting(None, good), variants=1, seed=3))
    bad: dict[str, int] = {}
    result = generate(BEDROOM, tmp_path / "bad", GenerateConfig(model=counting("critic", bad), variants=1, seed=3))
    generate(BEDROOM, tmp_path / "rules", GenerateConfig(variants=1, seed=3))

    assert good["critic"] > 2  # the critic is asked once per round of every layout
    assert bad["critic"] == 2  # ... a model that cannot do it, twice in the whole run
    assert {k: v for k, v in bad.items() if k != "critic"} == {k: v for k, v in good.items() if k != "critic"}
    for world in ("base", "variant_1"):  # where the critic decided, the rules decided: the rules' result
        assert _poses(tmp_path / "bad" / world) == _poses(tmp_path / "rules" / world)
    quality = result.report["model"]
    assert quality["kinds"]["critic"]["given_up"] and quality["kinds"]["critic"]["requests"] == 2
    assert quality["kinds"]["critic"]["answers"]["solver_fallback"] > 2  # every later critic, by the solver
    assert quality["summary"].endswith("; solver for critic (given up)")
    assert not any(v["given_up"] for k, v in quality["kinds"].items() if k != "critic")
    assert result.report["status"] == "degraded"  # the critic's solver answered: said as a fallback


def test_a_good_model_is_never_routed_to_the_solver(tmp_path: Path) -> None:
    # a recorded cassette of a model that gives every agent the rule answer
    # (tests/fixtures/make_good_model_cassette.py), replayed: a prompt or evidence that changed
    # stops the replay with a ReplayMissError naming what differs
    cassette = BEDROOM.parent / "cassettes" / "good_model_bedroom_22.cassette.json"
    result = generate(BEDROOM, tmp_path / "model", GenerateConfig(model=f"replay:{cassette}", variants=1, seed=3))
    generate(BEDROOM, tmp_path / "rules", GenerateConfig(variants=1, seed=3))
    quality = result.report["model"]
    assert quality["given_up"] == [] and quality["kinds"] and "solver for" not in quality["summary"]
    assert all(v["unusable"] == 0 for v in quality["kinds"].values())
    assert result.report["status"] == "ok"
    for world in ("base", "variant_1"):
        assert _poses(tmp_path / "model" / world) == _poses(tmp_path / "rules" / world)


def test_a_model_run_gets_a_deadline_by_default_and_none_waits(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import time

    from scenemosaic.pipeline import _state, default_deadline_s

    assert default_deadline_s(6) == 120.0 and default_deadline_s(None) == default_deadline_s(30)

    def slow(messages: list[Message], context: RequestContext | None) -> Any:
        time.sleep(0.4)
        return solver_answer(messages, context)

    # a budget small enough to pass during the structuring: the agents after it use their solvers
    monkeypatch.setattr(_state, "DEADLINE_BASE_S", 0.5)
    monkeypatch.setattr(_state, "DEADLINE_PER_OBJECT_S", 0.0)
    model = FunctionModel(slow, name="slow", vision=False)
    late = generate(BEDROOM, tmp_path / "late", GenerateConfig(model=model, stabilize=False))
    assert late.report["model"]["deadline_s"] == 0.5 and late.report["model"]["deadline"].startswith("default: ")
    assert late.report["status"] == "degraded" and late.report["model"]["stopped"]
    said = [w for w in late.report["warnings"] if "deadline" in w]
    assert said and len(said) == len({w.split("'")[1] for w in said})  # once per agent kind, not per agent run
    assert "(deadline)" in late.report["model"]["summary"]
    waited = generate(BEDROOM, tmp_path / "waited", GenerateConfig(model=model, stabilize=False, deadline_s="none"))
    assert waited.report["model"]["deadline_s"] is None and waited.report["status"] == "ok"
    assert waited.report["config"]["deadline_s"] == "none"


def test_a_house_shares_one_account_and_gives_a_kind_up_once_for_every_room(tmp_path: Path) -> None:
    house = Path(__file__).resolve().parents[1] / "fixtures" / "procthor_house.json"
    asked: dict[str, int] = {}

    def reply(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None
        asked[context.agent] = asked.get(context.agent, 0) + 1
        if context.agent == "critic":
            return '{"should_modify": "maybe"}'  # JSON, off the schema
        return solver_answer(messages, context)

    result = generate(house, tmp_path / "house", GenerateConfig(model=FunctionModel(reply, name="bad-critic", vision=False)))
    assert result.report["house"] is not None and len(result.report["house"]["rooms"]) == 2
    assert asked["critic"] == 2  # two rooms' layouts, one model stack: twice in the whole house
    account = result.report["model"]
    assert account["kinds"]["critic"]["given_up"] and account["kinds"]["critic"]["answers"]["solver_fallback"] >= 2
    assert {k: v["requests"] for k, v in account["kinds"].items() if v["requests"]} == asked
    assert account["summary"].endswith("solver for critic (given up)")
    said = [w for w in result.report["warnings"] if "'critic'" in w]
    assert len(said) <= len(result.report["house"]["rooms"])  # once a room at most, not once a layout

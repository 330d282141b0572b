"""``report.json`` says, per agent, how its answer came about: first time, repaired, fallen back."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agent_solvers import solver_answer

from scenemosaic import GenerateConfig, generate
from scenemosaic.models import FunctionModel, Message, RequestContext

BEDROOM = Path(__file__).resolve().parents[1] / "fixtures" / "bedroom_22.json"


def test_the_report_breaks_the_structuring_down_per_agent(tmp_path: Path) -> None:
    asked: dict[str, int] = {}

    def reply(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None
        asked[context.agent] = asked.get(context.agent, 0) + 1
        if context.agent == "attributes":
            return "no JSON here"  # never usable: falls back to the rule solver
        if context.agent == "support" and asked["support"] == 1:
            return '{"assignments": []}'  # schema-valid, but leaves every object without a parent
        return solver_answer(messages, context)

    # every attempt of each agent is asked (the run gives no kind up: tests/agents/test_quality_breaker.py)
    config = GenerateConfig(model=FunctionModel(reply, vision=False), stabilize=False, unusable_replies=0)
    generate(BEDROOM, tmp_path, config)
    report = json.loads((tmp_path / "report.json").read_text(encoding="utf-8"))
    [structure] = [s for s in report["stages"] if s["name"] == "structure"]
    agents = structure["detail"]["agents"]
    assert agents["walls"] == {
        "answered_by": "model", "requests": 1, "repairs": 0, "valid_first_time": True,
        "input_tokens": 0, "output_tokens": 0,
    }  # a FunctionModel reports no tokens
    # the input room already holds everything: nothing to decide, no call
    assert agents["room"]["answered_by"] == "solver_without_call" and "room" not in asked
    assert agents["support"]["answered_by"] == "model" and agents["support"]["repairs"] == 1
    assert agents["support"]["requests"] == 2 and not agents["support"]["valid_first_time"]
    assert agents["attributes"]["answered_by"] == "solver_fallback" and agents["attributes"]["requests"] == 3
    assert "unusable after 3 attempts" in agents["attributes"]["fallback_reason"]
    assert agents["verify"]["answered_by"] == "solver_without_call" and "verify" not in asked
    assert agents["manager"]["answered_by"] == "model"
    assert report["status"] == "degraded"  # a fallback is said loudly
    assert {name for name, n in asked.items() if n} == {k for k, v in agents.items() if v["requests"]}
    # the run's account of the model, per kind, says the same
    account = report["model"]["kinds"]
    assert {k: v["requests"] for k, v in account.items() if v["requests"]} == asked
    assert account["attributes"]["answers"] == {"solver_fallback": 1} and account["attributes"]["unusable"] == 3
    assert account["support"]["answers"] == {"repaired": 1} and account["walls"]["answers"] == {"model": 1}
    assert report["model"]["summary"] == f"{len(asked) - 1} of {len(asked)} agent kinds usable; solver for attributes (fell back)"

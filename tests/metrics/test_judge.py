"""The semantic judge: scores from a (scripted) vision model, never faked without one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from agent_solvers import solver_answer

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.metrics import judge_scene
from scenemosaic.models import FunctionModel, ImagePart, Message, RequestContext, parse_model
from scenemosaic.scene import Scene

DINING = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"


@pytest.fixture(scope="module")
def dining() -> Scene:
    from scenemosaic.exchange import load_scene

    return load_scene(DINING)


def _judge(messages: list[Message], context: RequestContext) -> dict[str, Any]:
    assert any(isinstance(p, ImagePart) for m in messages for p in m.parts)  # it sees the render
    ids = [row.id for row in context.evidence.objects]  # type: ignore[union-attr]
    return {"objects": [
        {"object_id": i, "position_plausible": i != "dining_chair_0", "rotation_plausible": not i.startswith("dining_chair"), "note": ""}
        for i in ids
    ]}  # fmt: skip


async def test_scores_are_the_shares_the_model_calls_plausible(dining: Scene) -> None:
    n = len(dining.objects)
    got = await judge_scene(dining, FunctionModel({"judge": _judge}, vision=True))
    chairs = sum(1 for o in dining.objects if o.id.startswith("dining_chair"))
    assert got["POS"] == pytest.approx(100 * (n - 1) / n, abs=0.01)
    assert got["ROT"] == pytest.approx(100 * (n - chairs) / n, abs=0.01)


async def test_not_measured_with_the_rules_a_text_model_or_unusable_answers(dining: Scene) -> None:
    rules = await judge_scene(dining, parse_model("rules"))
    assert rules["POS"] is None and "not measured" in rules["note"]
    text = await judge_scene(dining, FunctionModel({"judge": _judge}, vision=False))
    assert text["ROT"] is None and "no vision" in text["note"]
    broken = await judge_scene(dining, FunctionModel({"judge": lambda m, c: {"objects": []}}, vision=True))
    assert broken["POS"] is None and "not measured" in broken["note"]


async def test_generate_with_a_vision_model_reports_the_judge(tmp_path: Path) -> None:
    def answer(messages: list[Message], context: RequestContext) -> Any:
        return _judge(messages, context) if context.agent == "judge" else solver_answer(messages, context)

    result = await agenerate(DINING, tmp_path, GenerateConfig(model=FunctionModel(answer, vision=True)))
    judge = result.report["metrics"]["semantic_judge"]
    assert judge["base"]["POS"] is not None and judge["base"]["objects"] == len(result.scene.objects)

"""Issue 28, finding 8: a model's answer never outranks a rule.

A critic that always answers "no change" (the weak local model's reply that once left a chair
facing away and the floor cut) drives ``generate`` on every shipped PhyScene room; every other
agent answers as the rules would. The result must be at least as valid as the rules run of the
same input: no more collisions or objects out of bounds, NAV no lower than the rules' less 0.005,
no more rule violations."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

from scenemosaic import GenerateConfig, generate
from scenemosaic.evolve import CriticOutput
from scenemosaic.models import FunctionModel, Message, RequestContext
from tests.agent_solvers import solver_answer
from tests.conftest import PHYSCENE_DIR

ROOMS = sorted(PHYSCENE_DIR.glob("*.json"))


def _lazy_critic(messages: list[Message], context: RequestContext | None) -> BaseModel:
    assert context is not None
    if context.agent == "critic":
        return CriticOutput(should_modify=False, reasoning="looks fine", modification_notes=[], quality_basis="", quality_score=95)
    return solver_answer(messages, context)


def _figures(report: dict[str, Any]) -> tuple[float, float, float, int]:
    base = report["metrics"]["base"]
    evolve = next(s for s in report["stages"] if s["name"] == "evolve")["detail"]
    return base["COL"], base["OOB"], base["NAV"], evolve["rule_violations"]


@pytest.mark.long
@pytest.mark.parametrize("room", ROOMS, ids=lambda p: p.stem)
def test_a_critic_that_always_says_no_change_ends_as_valid_as_the_rules(room: Path, tmp_path: Path) -> None:
    rules = generate(room, tmp_path / "rules", GenerateConfig())
    lazy = generate(room, tmp_path / "lazy", GenerateConfig(model=FunctionModel(_lazy_critic, name="no-change-critic", vision=False)))
    r_col, r_oob, r_nav, r_viol = _figures(rules.report)
    col, oob, nav, viol = _figures(lazy.report)
    assert col <= r_col and oob <= r_oob, (col, oob, r_col, r_oob)
    assert nav >= r_nav - 0.005, (nav, r_nav)
    assert viol <= r_viol, (viol, r_viol)

"""One model stack per run: the breaker, deadline and usage belong to the whole run, not a stage."""

from __future__ import annotations

import contextlib
from pathlib import Path

import httpx
from pydantic import BaseModel

from scenemosaic.exceptions import ModelError
from scenemosaic.exchange import save_scene
from scenemosaic.models import HTTPRetryPolicy, Message, open_run_model
from scenemosaic.pipeline import GenerateConfig, demo_scene, generate
from tests.llm_fakes import FakeServer


class Answer(BaseModel):
    """A tiny output type for direct requests."""

    ok: bool


def _failing_server() -> tuple[FakeServer, object]:
    server = FakeServer(default=httpx.Response(500, json={"error": {"message": "down"}}))
    model, _ = server.model(retry=HTTPRetryPolicy(max_attempts=1, initial_backoff_s=0.0, jitter_s=0.0))
    return server, model


def test_a_breaker_tripped_in_structure_stays_open_for_evolve(tmp_path: Path) -> None:
    server, model = _failing_server()
    room = tmp_path / "room"
    save_scene(demo_scene(), room)
    seen: dict[str, int] = {}

    def on_stage(name: str, status: str) -> None:
        seen[f"{name}:{status}"] = len(server.requests)

    result = generate(room, tmp_path / "out", GenerateConfig(model=model), on_stage=on_stage)
    stages = {s["name"]: s for s in result.report["stages"]}
    # the failing server was asked during structuring until the breaker opened (5 failures)...
    assert seen["structure:done"] - seen["structure:started"] >= 5
    assert stages["structure"]["detail"]["usage"]["failed_calls"] >= 5
    # ...and never again: evolve's agents were refused by the same breaker, still open
    assert seen["evolve:done"] == seen["evolve:started"] == seen["structure:done"] == len(server.requests)
    assert stages["evolve"]["status"] == "done"
    assert stages["evolve"]["detail"]["usage"]["requests"] == 0  # refused before reaching the client
    assert any("'critic'" in w and "ModelUnavailableError" in w for w in result.report["warnings"])
    assert result.status == "degraded"
    assert any("answered by its rule solver" in w for w in result.report["warnings"])


async def test_stage_usage_is_the_difference_of_two_readings() -> None:
    server, model = _failing_server()
    async with await open_run_model(model) as stack:  # type: ignore[arg-type]
        assert stack.detail["model"] == model.name and stack.settings is None  # type: ignore[attr-defined]
        mark = stack.mark()
        for _ in range(2):
            with contextlib.suppress(ModelError):
                await stack.model.request([Message.text("user", "hi")], Answer)
        assert stack.usage_since(mark)["failed_calls"] == 2
        assert stack.usage_since(stack.mark())["requests"] == 0
    assert len(server.requests) == 2


async def test_the_rules_model_gets_no_breaker_and_no_deadline() -> None:
    async with await open_run_model("rules") as stack:
        assert stack.uses_rule_solvers
        assert "CircuitBreaker" not in repr(stack.model) and "Deadline" not in repr(stack.model)

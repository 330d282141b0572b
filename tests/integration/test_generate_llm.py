"""``generate`` on a real-data room with a real OpenAI-compatible server (opt-in).

Runs only when ``SCENEMOSAIC_LLM_URL`` is set (see ``test_llm_client.py``). A small local model's
answers may be poor; what must hold is that the run succeeds anyway and says how: it exits 0,
every agent was answered by the model or by its rule solver with the fallback reported, the
model's answers were used where they were usable, and the result validates at least as well as
the offline rules run of the same room.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app

pytestmark = pytest.mark.integration

URL = os.environ.get("SCENEMOSAIC_LLM_URL", "")
MODEL = os.environ.get("SCENEMOSAIC_LLM_MODEL", "qwen2.5-coder-0.5b-instruct")

if not URL:
    pytest.skip(
        "integration suite not run: set SCENEMOSAIC_LLM_URL to an OpenAI-compatible server",
        allow_module_level=True,
    )


@pytest.mark.timeout(1800)  # a 0.5 B model on 2 CPU cores: tens of seconds per call
def test_generate_with_a_real_text_only_server(tmp_path: Path, repo_data: Path) -> None:
    source = repo_data / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
    runs = {}
    for name, model in (("model", f"openai:{MODEL}@{URL}"), ("rules", "rules")):
        out = tmp_path / name
        result = CliRunner().invoke(app, ["generate", str(source), "--out", str(out), "--model", model, "--no-vision"])
        assert result.exit_code == 0, result.output
        runs[name] = json.loads((out / "report.json").read_text())
    report = runs["model"]
    stages = {s["name"]: s for s in report["stages"]}
    detail = stages["structure"]["detail"]
    agents = detail["agents"]
    assert agents and all(a["answered_by"] in ("model", "solver_without_call", "solver_fallback") for a in agents.values())
    fell_back = {a for a, v in agents.items() if v["answered_by"] == "solver_fallback"}
    reported = {f["agent"] for f in detail["solver_fallbacks"]}
    assert fell_back == reported  # every fallback is said, and only those
    assert all(any(f"agent {a!r}" in w for w in report["warnings"]) for a in fell_back)
    assert detail["usage"]["requests"] >= 1
    # at least as valid as the rules run of the same room
    ours, rules = report["validation"], runs["rules"]["validation"]
    assert len(ours["collisions"]["pairs"]) <= len(rules["collisions"]["pairs"])
    assert len(ours["out_of_bounds"]["objects"]) <= len(rules["out_of_bounds"]["objects"])
    assert len(ours["tipped"]) + len(ours["fell"]) <= len(rules["tipped"]) + len(rules["fell"])
    print(  # figures for the issue note: pytest -s shows them
        f"\nreal-server calls: {detail['usage']['requests']}, mean latency {detail['usage']['latency_s']['mean']} s, "
        f"answered: {json.dumps({k: v['answered_by'] for k, v in agents.items()})}"
    )

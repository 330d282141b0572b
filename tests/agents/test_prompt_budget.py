"""The structuring prompts fit a small local model (issue 41, item 12): ``benchmarks/prompts.py``
run as a user runs it, its figures held to the budgets of ``docs/small-models.md``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BUDGET_ROOM60 = 3500
"""Tokens (the library's estimate) the largest prompt of a 60-object room may take: what keeps a
4,096-token model working with its reply."""
BUDGET_ROOM16 = 3000


def test_every_prompt_of_a_60_object_room_is_within_budget() -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "prompts.py")], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr[-2000:]
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    assert figures["max_prompt_tokens_room60"] <= BUDGET_ROOM60, figures["prompt_tokens_room60"]
    assert figures["max_prompt_tokens_room16"] <= BUDGET_ROOM16, figures["prompt_tokens_room16"]
    assert "verify" in figures["prompt_tokens_room60"]  # the 60-object room gives verification work to ask about

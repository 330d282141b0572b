"""Helpers for the reliability suite: run the real CLI in a subprocess and read its report.

(A module with its own name: ``conftest`` names are shared by every test folder.)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "data"
DINING = DATA / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"


@dataclass
class CliRun:
    code: int
    stdout: str
    stderr: str
    seconds: float


def cli_env(tmp_path: Path) -> dict[str, str]:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "COLUMNS": "200"}
    env.setdefault("SCENEMOSAIC_CACHE", str(tmp_path / "cache"))
    return env


def run_cli(args: list[str], tmp_path: Path, *, timeout: float = 180, stage: str = "-", action: str = "-") -> CliRun:
    """``scenemosaic <args>`` in a fresh interpreter (through the test driver when a stage is patched)."""
    cmd = [sys.executable, str(HERE / "cli_driver.py"), stage, action, "--", *args]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=cli_env(tmp_path), check=False)
    return CliRun(done.returncode, done.stdout, done.stderr, time.perf_counter() - t0)


def report(out: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((out / "report.json").read_text(encoding="utf-8"))
    return data

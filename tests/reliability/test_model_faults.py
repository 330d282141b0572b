"""A broken or hung model server never fails or stalls a run: agents fall back, the run is degraded.

Each case runs the real CLI against a fault-injecting OpenAI-compatible server on 127.0.0.1.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import report, run_cli
from fault_server import FaultServer

FAST_MODES = ["braces", "html", "message_string", "bad_usage", "error503", "retry_after", "context", "reset"]


def _generate(server: FaultServer, dining: Path, out: Path, tmp_path: Path, *extra: str, timeout: float = 170):
    args = [
        "generate", str(dining), "--out", str(out),
        "--model", f"openai:test-model@{server.base_url}", "--no-vision", *extra,
    ]  # fmt: skip
    return run_cli(args, tmp_path, timeout=timeout)


@pytest.mark.long  # about 18 s each: CI runs them with `make test-houses`
@pytest.mark.parametrize("mode", FAST_MODES)
def test_a_faulty_server_gives_a_degraded_scene_not_a_failed_run(mode: str, tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    with FaultServer(mode) as server:
        # a short deadline keeps the suite quick: retries and backoffs of 5xx/429 stop at it
        done = _generate(server, dining, out, tmp_path, "--request-timeout", "5", "--deadline", "15")
    assert done.code == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    rep = report(out)
    assert rep["status"] == "degraded", rep["warnings"]
    structure = next(s for s in rep["stages"] if s["name"] == "structure")
    assert structure["detail"]["solver_fallbacks"], "the agents should have used their rule solvers"
    assert any("rule solver" in w for w in rep["warnings"])
    assert (out / "base" / "scene.json").is_file()
    assert done.seconds < 45, f"{mode}: {done.seconds:.0f} s"


@pytest.mark.long  # about 50 s: CI runs it with `make test-houses`
def test_a_hung_server_is_bounded_by_the_request_timeout_and_the_deadline(tmp_path: Path, dining: Path) -> None:
    out = tmp_path / "out"
    with FaultServer("hang") as server:
        done = _generate(server, dining, out, tmp_path, "--request-timeout", "5", "--deadline", "60", timeout=200)
    assert done.code == 0, done.stderr[-3000:]
    assert done.seconds < 70, f"a hung server held the run for {done.seconds:.0f} s"
    rep = report(out)
    assert rep["status"] == "degraded"
    assert (out / "base" / "scene.json").is_file()


def test_strict_turns_fallbacks_into_a_failure_exit(tmp_path: Path, dining: Path) -> None:
    with FaultServer("error503") as server:
        done = _generate(server, dining, tmp_path / "out", tmp_path, "--strict", "--request-timeout", "5", "--deadline", "10")
    assert done.code == 1
    assert report(tmp_path / "out")["status"] == "degraded"

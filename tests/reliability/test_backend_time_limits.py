"""One clock for every outbound call: hung or trickling perception servers and images endpoints are
bounded by ``--request-timeout`` and ``--deadline``, a signal interrupts a waiting call at once, and a
model server that cannot serve the run stops it at once (exit 2, the fix in one line) unless
``--fallback rules`` asks for the rule solvers.

Each case runs the real CLI against a fault-injecting server on 127.0.0.1, with small limits so the
suite stays quick (the 5 s / 30 s figures of ``docs/reliability.md`` were measured by hand).
"""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_helpers import DATA, cli_env, report, run_cli
from fault_server import FaultServer

DEMO = DATA / "images" / "demo_bedroom"


def _photo_args(segmenter: str, reconstructor: str) -> list[str]:
    return [
        str(DEMO / "photo.png"), "--detections", str(DEMO / "boxes.json"),
        "--segmenter", segmenter, "--reconstructor", reconstructor, "--no-evolve",
    ]  # fmt: skip


def _only_out_and_cache(tmp_path: Path) -> None:
    """Nothing but the output folder and the cache was written."""
    assert {p.name for p in tmp_path.iterdir()} <= {"out", "cache"}, sorted(p.name for p in tmp_path.iterdir())


@pytest.mark.parametrize(
    ("mode", "backend", "limits", "said"),
    [
        ("hang", "segmenter", ["--request-timeout", "1", "--deadline", "6"], "no complete reply in time (1 s, then 2 s)"),
        ("trickle", "reconstructor", ["--request-timeout", "1", "--deadline", "6"], "no complete reply in time (1 s, then 2 s)"),
        ("hang", "segmenter", ["--request-timeout", "60", "--deadline", "3"], "did not answer within the run's 3 s deadline"),
        ("trickle", "images", ["--request-timeout", "1", "--deadline", "6"], "timed out (1 s, then 2 s)"),
    ],
    ids=["hung-segmenter", "trickling-reconstructor", "segmenter-past-the-deadline", "trickling-images"],
)
def test_a_hung_or_trickling_backend_is_bounded(mode: str, backend: str, limits: list[str], said: str, tmp_path: Path) -> None:
    out = tmp_path / "out"
    with FaultServer(mode) as server:
        if backend == "images":
            args = ["--prompt", "a bedroom with a desk", "--model", f"openai:m@{server.base_url}", "--no-vision", "--no-evolve"]
        else:
            seg = f"{server.root}/segment" if backend == "segmenter" else "box"
            rec = f"{server.root}/reconstruct" if backend == "reconstructor" else "box-lifter"
            args = _photo_args(seg, rec)
        done = run_cli(["generate", *args, "--out", str(out), *limits], tmp_path, timeout=90)
        asked = server.requests
    assert done.code == 2, done.stderr[-2000:]
    assert done.seconds < 20, f"{backend}: {done.seconds:.1f} s"
    assert "Traceback" not in done.stderr and said in done.stderr, done.stderr[-2000:]
    assert asked >= 1
    rep = report(out)
    assert rep["status"] == "failed" and rep["failed_stage"] == "import" and said in rep["error"]
    _only_out_and_cache(tmp_path)


def test_sigterm_during_a_hung_segmenter_call_is_an_interruption(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with FaultServer("hang") as server:
        args = _photo_args(f"{server.root}/segment", "box-lifter")
        cmd = [sys.executable, "-m", "scenemosaic.cli", "generate", *args, "--out", str(out)]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(tmp_path))
        give_up = time.monotonic() + 60
        while server.requests == 0:  # perception is waiting on the segmenter now
            assert proc.poll() is None, proc.communicate()[1][-2000:]
            assert time.monotonic() < give_up, "the segmenter was never asked"
            time.sleep(0.05)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        stopped_in = time.monotonic() - t0
    assert proc.returncode == 143, err[-2000:]
    assert stopped_in < 5, f"{stopped_in:.1f} s"
    rep = report(out)
    assert rep["status"] == "interrupted" and rep["failed_stage"] == "import", rep.get("error")
    _only_out_and_cache(tmp_path)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def test_no_model_server_stops_the_run_at_once_with_the_fix(tmp_path: Path, dining: Path) -> None:
    url = f"http://127.0.0.1:{_free_port()}/v1"
    out = tmp_path / "out"
    done = run_cli(["generate", str(dining), "--out", str(out), "--model", f"openai:m@{url}", "--no-vision"], tmp_path, timeout=90)
    assert done.code == 2, done.stderr[-2000:]
    fix = f"no model server at {url}: start it or fix --model, or use --model rules"
    assert any(line.endswith(fix) for line in done.stderr.splitlines()), done.stderr[-2000:]
    rep = report(out)
    assert rep["status"] == "failed" and rep["failed_stage"] == "structure"
    assert rep["error"].startswith("ModelEndpointError: " + fix)
    # at once: the stage that asked the model gave up without the retry policy's waits (its
    # 300 s budget); the whole process, start-up and the stages before included, is timed too,
    # with room for a loaded machine (10.2 s was seen with three test runs on two cores)
    (structure,) = [s for s in rep["stages"] if s["name"] == "structure"]
    assert structure["seconds"] < 5, structure["seconds"]
    assert done.seconds < 30, done.seconds


def test_fallback_rules_keeps_going_on_the_rule_solvers(tmp_path: Path, dining: Path) -> None:
    url = f"http://127.0.0.1:{_free_port()}/v1"
    out = tmp_path / "out"
    args = ["generate", str(dining), "--out", str(out), "--model", f"openai:m@{url}", "--no-vision", "--fallback", "rules", "--no-evolve"]
    done = run_cli(args, tmp_path, timeout=120)
    assert done.code == 0, done.stderr[-2000:]
    rep = report(out)
    assert rep["status"] == "degraded" and any("no model server" in w for w in rep["warnings"])
    assert (out / "base" / "scene.json").is_file()


def test_a_batch_job_stopped_at_its_time_out_reports_interrupted(tmp_path: Path) -> None:
    from scenemosaic.batch import run_batch

    manifest = tmp_path / "jobs.jsonl"
    with FaultServer("hang") as server:
        line = {
            "input": str(DEMO / "photo.png"), "id": "photo", "timeout_s": 8, "detections": str(DEMO / "boxes.json"),
            "segmenter": f"{server.root}/segment", "reconstructor": "box-lifter", "evolve": False,
        }  # fmt: skip
        manifest.write_text(json.dumps(line) + "\n", encoding="utf-8")
        summary = run_batch(manifest, tmp_path / "out", workers=1)
    (job,) = summary.jobs
    assert (job.status, job.report_status) == ("timeout", "interrupted"), job
    assert job.wall_s is not None and job.wall_s < 8 + 10
    rep = report(tmp_path / "out" / "photo")
    assert rep["status"] == "interrupted" and rep["failed_stage"] == "import"

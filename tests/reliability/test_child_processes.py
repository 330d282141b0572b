"""Every child process a run starts is the package's own worker: a user's script without a
``__main__`` guard runs once and still decomposes with CoACD, a failed decomposition degrades the
run out loud, and a run stopped by a signal leaves no process behind (found by an environment
marker every child inherits)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from structlog.testing import capture_logs

import scenemosaic as sm
from scenemosaic.assets import HullCache
from scenemosaic.exchange import write_sam3d_example

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="finds processes through /proc")

REPO = Path(__file__).resolve().parents[2]
SAM3D = REPO / "data" / "sam3d_objects"
MARK = "SCENEMOSAIC_TEST_MARK"


def _office(folder: Path, keep: set[str] | None = None) -> Path:
    """The SAM3D office's pose file (only the objects ``keep`` names, when given)."""
    poses = write_sam3d_example(folder, SAM3D)
    if keep is not None:
        data = json.loads(poses.read_text())
        data["objects"] = [o for o in data["objects"] if o["id"] in keep]
        poses.write_text(json.dumps(data))
    return poses


def _marked(mark: str) -> list[tuple[int, str]]:
    """Live processes (pid, command line) whose environment holds ``MARK=mark``, zombies left out."""
    found = []
    needle = f"{MARK}={mark}".encode()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if needle not in (entry / "environ").read_bytes().split(b"\0"):
                continue
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
            argv = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except (OSError, IndexError):
            continue
        if state != "Z":
            found.append((int(entry.name), argv))
    return found


def _wait_for(check: Callable[[], Any], timeout: float) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = check()
        if value:
            return value
        time.sleep(0.1)
    return None


def test_a_script_without_a_main_guard_runs_once_and_decomposes_with_coacd(tmp_path: Path) -> None:
    poses = _office(tmp_path / "input", keep={"coffee_mug"})
    script = tmp_path / "my_script.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import scenemosaic as sm
            print("SCRIPT BODY RAN", flush=True)
            result = sm.generate({str(poses)!r}, {str(tmp_path / "run")!r}, sm.GenerateConfig(overwrite=True))
            print("STATUS", result.status, flush=True)
            """
        )
    )  # no `if __name__ == "__main__":` guard, as a new user writes it
    env = {**os.environ, "SCENEMOSAIC_CACHE": str(tmp_path / "cold-cache")}
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.count("SCRIPT BODY RAN") == 1  # no worker ran the user's script again
    assert "STATUS ok" in done.stdout
    assert "another run is writing" not in done.stderr
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["status"] == "ok" and report["warnings"] == []
    hulls = sorted((tmp_path / "run" / "base" / "mjcf").glob("coffee_mug_hull_*.obj"))
    assert len(hulls) > 1  # CoACD's pieces, not the single convex hull of a failed decomposition
    assert list((tmp_path / "cold-cache" / "hulls").rglob("*.npz"))  # and stored for the next run


def test_a_failed_decomposition_is_a_warning_and_the_run_is_degraded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    poses = _office(tmp_path / "input", keep={"coffee_mug"})

    def crashed(_cache: HullCache, *_args: Any) -> Any:
        raise OSError("simulated: no CoACD worker could start")

    monkeypatch.setattr(HullCache, "_submit", crashed)
    config = sm.GenerateConfig(overwrite=True, cache_dir=tmp_path / "cache")
    with capture_logs() as logs:
        result = sm.generate(poses, tmp_path / "run", config)
    assert result.status == "degraded"
    coacd = [w for w in result.report["warnings"] if "CoACD failed" in w]
    assert len(coacd) == 1 and "single convex hull" in coacd[0]
    assert any(e["event"] == "coacd_failed_using_convex_hull" for e in logs)  # said on the console as it happens
    assert any(e["event"] == "run_degraded" for e in logs)  # and in the run's closing summary


HOUSE = REPO / "data" / "houses" / "procthor" / "procthor_4room.json"
DRIVER = Path(__file__).resolve().parent / "cli_driver.py"


def _stop_when(args: list[str], ready: Callable[[subprocess.Popen[str], str], bool], sig: signal.Signals, tmp_path: Path) -> None:
    """Start ``scenemosaic`` (or the test driver) with ``args`` under a fresh environment marker and a
    cold hull cache, wait until ``ready(process, mark)``, send ``sig``, and check that no process
    carrying the marker is alive 2 s after the run ended (none is left for the rest of the suite)."""
    mark = uuid.uuid4().hex
    env = {**os.environ, MARK: mark, "SCENEMOSAIC_CACHE": str(tmp_path / "cold-cache"), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    run = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        assert ready(run, mark), "the run never reached the moment to stop it"
        run.send_signal(sig)
        run.communicate(timeout=30)
        left = _wait_for(lambda: not _marked(mark), timeout=2.0)
        assert left, f"still alive 2 s after {sig.name}: {_marked(mark)}"
    finally:
        run.kill()
        for pid, _ in _marked(mark):
            os.kill(pid, signal.SIGKILL)


def _worker_alive(module: str) -> Callable[[subprocess.Popen[str], str], bool]:
    return lambda _run, mark: bool(_wait_for(lambda: [p for p in _marked(mark) if module in p[1]], timeout=120))


def _stage_started(stage: str, module: str) -> Callable[[subprocess.Popen[str], str], bool]:
    def ready(run: subprocess.Popen[str], mark: str) -> bool:
        assert run.stderr is not None
        deadline = time.monotonic() + 240
        for line in run.stderr:
            if f"STAGE-STARTED {stage}" in line:
                return any(module in p[1] for p in _marked(mark))
            if time.monotonic() > deadline:
                return False
        return False

    return ready


CLI = str(Path(sys.executable).with_name("scenemosaic"))
SIGNALS = pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])


@SIGNALS
def test_a_run_stopped_while_coacd_works_leaves_no_process_behind(tmp_path: Path, sig: signal.Signals) -> None:
    poses = _office(tmp_path / "input")  # the whole office: the desk keeps CoACD busy for many seconds
    _stop_when([CLI, "generate", str(poses), "--out", str(tmp_path / "run")], _worker_alive("_coacd_worker"), sig, tmp_path)


@pytest.mark.house
@SIGNALS
def test_a_house_run_stopped_in_its_rooms_leaves_no_process_behind(tmp_path: Path, sig: signal.Signals) -> None:
    args = [CLI, "generate", str(HOUSE), "--out", str(tmp_path / "run"), "--variants", "2", "--room-workers", "2"]
    _stop_when(args, _worker_alive("_house_worker"), sig, tmp_path)


@pytest.mark.house
@SIGNALS
def test_a_house_run_stopped_while_its_houses_are_delivered_ahead_leaves_no_process_behind(
    tmp_path: Path, sig: signal.Signals
) -> None:
    """Held in its validate stage, a house run has its workers delivering the composed houses (or
    idle, kept): a signal then still leaves nothing of the run alive 2 s later."""
    held = [sys.executable, str(DRIVER), "validate", "sleep", "--"]
    args = [*held, "generate", str(HOUSE), "--out", str(tmp_path / "run"), "--variants", "2", "--room-workers", "2"]
    _stop_when(args, _stage_started("validate", "_house_worker"), sig, tmp_path)

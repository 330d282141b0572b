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


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_a_run_stopped_while_coacd_works_leaves_no_process_behind(tmp_path: Path, sig: signal.Signals) -> None:
    poses = _office(tmp_path / "input")  # the whole office: the desk keeps CoACD busy for many seconds
    mark = uuid.uuid4().hex
    env = {**os.environ, MARK: mark, "SCENEMOSAIC_CACHE": str(tmp_path / "cold-cache")}
    cli = Path(sys.executable).with_name("scenemosaic")
    run = subprocess.Popen(
        [str(cli), "generate", str(poses), "--out", str(tmp_path / "run")],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        busy = _wait_for(lambda: [p for p in _marked(mark) if "_coacd_worker" in p[1]], timeout=120)
        assert busy, "no CoACD worker started"
        run.send_signal(sig)
        run.wait(timeout=30)
        left = _wait_for(lambda: not _marked(mark), timeout=2.0)
        assert left, f"still alive 2 s after {sig.name}: {_marked(mark)}"
    finally:
        run.kill()
        for pid, _ in _marked(mark):  # never leave one behind for the rest of the suite
            os.kill(pid, signal.SIGKILL)


@pytest.mark.house
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_a_house_run_stopped_in_its_rooms_leaves_no_process_behind(tmp_path: Path, sig: signal.Signals) -> None:
    house = REPO / "data" / "houses" / "procthor" / "procthor_4room.json"
    mark = uuid.uuid4().hex
    env = {**os.environ, MARK: mark, "SCENEMOSAIC_CACHE": str(tmp_path / "cold-cache")}
    cli = Path(sys.executable).with_name("scenemosaic")
    run = subprocess.Popen(
        [str(cli), "generate", str(house), "--out", str(tmp_path / "run"), "--variants", "2", "--room-workers", "2"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        busy = _wait_for(lambda: [p for p in _marked(mark) if "_house_worker" in p[1]], timeout=120)
        assert busy, "no room worker started"
        run.send_signal(sig)
        run.wait(timeout=30)
        left = _wait_for(lambda: not _marked(mark), timeout=2.0)
        assert left, f"still alive 2 s after {sig.name}: {_marked(mark)}"
    finally:
        run.kill()
        for pid, _ in _marked(mark):
            os.kill(pid, signal.SIGKILL)


@pytest.mark.house
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_a_house_run_stopped_while_its_houses_are_delivered_ahead_leaves_no_process_behind(
    tmp_path: Path, sig: signal.Signals
) -> None:
    """Held in its validate stage, a house run has its workers delivering the composed houses (or
    idle, kept): a signal then still leaves nothing of the run alive 2 s later."""
    house = REPO / "data" / "houses" / "procthor" / "procthor_4room.json"
    mark = uuid.uuid4().hex
    env = {**os.environ, MARK: mark, "SCENEMOSAIC_CACHE": str(tmp_path / "cold-cache"), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    driver = Path(__file__).resolve().parent / "cli_driver.py"
    args = ["generate", str(house), "--out", str(tmp_path / "run"), "--variants", "2", "--room-workers", "2"]
    run = subprocess.Popen([sys.executable, str(driver), "validate", "sleep", "--", *args], env=env, stderr=subprocess.PIPE, text=True)
    try:
        assert run.stderr is not None
        deadline = time.monotonic() + 240
        for line in run.stderr:
            if "STAGE-STARTED validate" in line:
                break
            assert time.monotonic() < deadline, "the house never reached its validate stage"
        assert [p for p in _marked(mark) if "_house_worker" in p[1]], "no house worker alive at validate"
        run.send_signal(sig)
        run.communicate(timeout=30)
        left = _wait_for(lambda: not _marked(mark), timeout=2.0)
        assert left, f"still alive 2 s after {sig.name}: {_marked(mark)}"
    finally:
        run.kill()
        for pid, _ in _marked(mark):
            os.kill(pid, signal.SIGKILL)

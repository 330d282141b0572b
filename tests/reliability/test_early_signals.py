"""A signal while the CLI is still loading the pipeline (before the run's event loop is up) stops
the run as soon as it starts: it used to raise ``KeyboardInterrupt`` inside an import, where a
library could swallow it and the run went on to the end (issue 41, low items)."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import DINING, cli_env

# the CLI, with its pipeline "loading" for 3 s in a library that swallows KeyboardInterrupt
DRIVER = """
import sys, time
import scenemosaic.cli as cli
held = cli._run_held
def loading(*args, **kwargs):
    print("LOADING", file=sys.stderr, flush=True)
    try:
        time.sleep(3)
    except KeyboardInterrupt:
        pass
    return held(*args, **kwargs)
cli._run_held = loading
sys.argv = ["scenemosaic", *sys.argv[1:]]
cli.main()
"""


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_before_the_run_starts_stops_it(sig: signal.Signals, code: int, tmp_path: Path) -> None:
    out = tmp_path / "out"
    cli = subprocess.Popen(
        [sys.executable, "-c", DRIVER, "generate", str(DINING), "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(tmp_path),
    )  # fmt: skip
    try:
        assert cli.stderr is not None
        while "LOADING" not in cli.stderr.readline():
            assert cli.poll() is None, "the CLI ended before loading"
        cli.send_signal(sig)
        _, err = cli.communicate(timeout=120)
    finally:
        if cli.poll() is None:
            cli.kill()
            cli.wait()
    assert cli.returncode == code, err[-2000:]
    assert "interrupted before the run started: nothing written" in " ".join(err.split())
    assert "Traceback" not in err and not (out / "base").exists()

"""The CLI starts light (issue 38, item 4): ``--help`` loads no part of the library, a command's
help loads what its options need, and ``inspect`` of a house or a room run loads neither the
pipeline nor a backend (MuJoCo, CoACD, trimesh, scipy).

Each check runs the command in a fresh interpreter and looks at ``sys.modules`` afterwards: what
got imported, not how long it took (``benchmarks/cli.py`` times them)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

import pytest

from scenemosaic.exchange import load_scene, save_house, save_scene
from scenemosaic.scene import House, Scene

DATA = Path(__file__).resolve().parents[2] / "data"
HOUSE = DATA / "houses/procthor/procthor10k_house3703_2room.json"
ROOM = DATA / "layouts/physcene/DiningRoom-19325_diningroom.json"

BACKENDS = ("mujoco", "coacd", "trimesh", "scipy", "httpx")
"""Modules no command that only reads a scene needs."""
HEAVY_PARTS = ("scenemosaic.pipeline", "scenemosaic.assets", "scenemosaic.physics", "scenemosaic.render", "scenemosaic.models")
"""The parts of the library (and what they import) that ``inspect`` does without."""

# the CLI's console entry point, run in-process; then the modules it loaded
DRIVER = """
import json, sys
from scenemosaic.cli import main
sys.argv = ["scenemosaic", *sys.argv[1:]]
try:
    main()
except SystemExit as exc:
    if exc.code:
        raise
print("LOADED " + json.dumps(sorted(sys.modules)))
"""


def _loaded(*args: str) -> set[str]:
    """The modules loaded by ``scenemosaic ARGS`` in a fresh interpreter (which must exit 0)."""
    done = subprocess.run([sys.executable, "-c", DRIVER, *args], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    line = next(line for line in done.stdout.splitlines() if line.startswith("LOADED "))
    return set(json.loads(line.removeprefix("LOADED ")))


def _within(loaded: set[str], packages: Iterable[str]) -> list[str]:
    """The modules of ``loaded`` that are ``packages`` or lie in them."""
    return sorted(m for m in loaded if any(m == p or m.startswith(p + ".") for p in packages))


def test_help_loads_no_part_of_the_library() -> None:
    loaded = _loaded("--help")
    assert "scenemosaic.cli" in loaded
    library = [m for m in loaded if m.startswith("scenemosaic.")]
    assert sorted(library) == ["scenemosaic.cli", "scenemosaic.exceptions"], library
    assert not _within(loaded, (*BACKENDS, "numpy", "pydantic", "structlog"))


def test_a_commands_help_loads_what_its_options_need() -> None:
    assert not _within(_loaded("inspect", "--help"), ("scenemosaic.pipeline", "scenemosaic.scene", *BACKENDS))
    generate = _loaded("generate", "--help")  # its options come from the run's settings
    assert "scenemosaic.pipeline._config" in generate
    assert not _within(generate, ("scenemosaic.pipeline._stages", "scenemosaic.pipeline._run", "mujoco", "coacd", "trimesh"))


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A house run and a room run: their base/ as generate delivers it (the native scene files)."""
    root = tmp_path_factory.mktemp("light_runs")
    house, room = load_scene(HOUSE), load_scene(ROOM)
    assert isinstance(house, House) and isinstance(room, Scene)
    save_house(house, root / "house" / "base")
    save_scene(room, root / "room" / "base")
    return {"house": root / "house", "room": root / "room"}


@pytest.mark.parametrize("kind", ["house", "room"])
def test_inspect_loads_neither_the_pipeline_nor_a_backend(kind: str, runs: dict[str, Path]) -> None:
    loaded = _loaded("inspect", str(runs[kind]))
    assert "scenemosaic.exchange" in loaded  # it did read the scene
    assert not _within(loaded, (*BACKENDS, *HEAVY_PARTS))

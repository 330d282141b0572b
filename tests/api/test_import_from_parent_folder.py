"""Issue 26, item 9: Python started in the folder above a clone (where ``scenemosaic/`` is the
clone itself, not the package) still imports the library — as ``make`` installs it (compat
editable mode: the clone is on ``sys.path``, so its package wins over the bare folder)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import scenemosaic


def test_a_folder_named_like_the_package_in_the_working_directory_does_not_shadow_it(tmp_path: Path) -> None:
    (tmp_path / "scenemosaic" / "docs").mkdir(parents=True)  # what a clone's folder looks like from above
    done = subprocess.run(
        [sys.executable, "-c", "import scenemosaic; print(scenemosaic.__file__); scenemosaic.generate"],
        cwd=tmp_path, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert Path(done.stdout.strip()) == Path(scenemosaic.__file__)

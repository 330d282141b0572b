"""Architecture rules a tool checks: no package reaches into another package's private modules.

The layer order itself is an import-linter contract (``[tool.importlinter]`` in pyproject.toml),
run by ``.ci/run``; this test runs the same contract and adds the private-module rule, which
import-linter has no built-in contract for.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[2]


def _package(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2])


def _is_private(module: str) -> bool:
    return any(part.startswith("_") and not part.startswith("__") for part in module.split(".")[2:])


def test_no_package_imports_another_packages_private_modules() -> None:
    graph = grimp.build_graph("scenemosaic")
    offences = []
    for importer in sorted(graph.modules):
        for imported in sorted(graph.find_modules_directly_imported_by(importer)):
            if not imported.startswith("scenemosaic.") or not _is_private(imported):
                continue
            if _package(importer) != _package(imported):
                offences.append(f"{importer} -> {imported}")
    assert not offences, "private imports across packages:\n" + "\n".join(offences)


def test_the_layer_contract_holds() -> None:
    lint = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    assert lint is not None, "import-linter is a dev dependency"
    done = subprocess.run([lint], cwd=ROOT, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stdout[-3000:]
    assert "0 broken" in done.stdout

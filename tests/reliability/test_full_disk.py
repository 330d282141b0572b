"""A full disk: a clear "no space left" line and exit 2, the report kept, no 0-byte or temporary files.

The disk is filled by patching the one write every file of a run goes through
(``scene.write_atomic``); the CLI runs in this process so the patch reaches it.
"""

from __future__ import annotations

import errno
import json
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app


def _fill_disk(monkeypatch: pytest.MonkeyPatch, where: str) -> list[str]:
    """Every write whose temporary file's path contains ``where`` fails with ENOSPC."""
    refused: list[str] = []

    def write_all(fh: Any, payload: bytes, tmp: Path) -> None:
        if where in str(tmp):
            refused.append(str(tmp))
            raise OSError(errno.ENOSPC, "No space left on device")
        fh.write(payload)

    monkeypatch.setattr("scenemosaic.scene._files._write_all", write_all)
    return refused


def _left_behind(out: Path) -> list[str]:
    """Empty files and temporaries under ``out``."""
    files = (p for p in out.rglob("*") if p.is_file() and p.name != ".lock")  # the run lock is empty by design
    return sorted(str(p.relative_to(out)) for p in files if p.stat().st_size == 0 or p.name.endswith(".tmp"))


def test_a_disk_full_at_the_export_keeps_the_report(tmp_path: Path, dining: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    refused = _fill_disk(monkeypatch, "/base/")
    result = CliRunner().invoke(app, ["generate", str(dining), "--out", str(out), "--no-evolve", "--variants", "0"])
    assert refused, "the export never wrote a file"
    assert result.exit_code == 2, result.output
    assert "no space left on device writing" in result.output and "choose another --out" in result.output
    assert "Traceback" not in result.output and "unexpected" not in result.output
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "failed" and report["failed_stage"] == "export"
    assert report["error"].startswith("OutputSpaceError: no space left on device writing")
    assert _left_behind(out) == []


def test_a_disk_full_from_the_start_leaves_nothing_half_written(tmp_path: Path, dining: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    _fill_disk(monkeypatch, str(out))
    result = CliRunner().invoke(app, ["generate", str(dining), "--out", str(out), "--no-evolve"])
    assert result.exit_code == 2, result.output
    assert "no space left on device writing" in result.output and "Traceback" not in result.output
    assert _left_behind(out) == []

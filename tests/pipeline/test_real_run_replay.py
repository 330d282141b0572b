"""A run recorded against the real llama.cpp server replays byte for byte with no server at all.

The cassette in ``tests/fixtures/cassettes/`` was recorded by ``benchmarks/real_model.py``
against the shared server (Qwen2.5-Coder-0.5B, 4,096-token context, text only); its companion
``*.expected.json`` holds what that live run wrote: the SHA-256 of every file of its ``base/``
folder, how each agent was answered, and the extra ``generate`` arguments it ran with
(``extra_args``: a recording made before the evolve stage existed replays with ``--no-evolve``, one made before the run gave up kinds of answer with ``--unusable-replies 0``). Replaying (``--model replay:<cassette>``) must reproduce
it: the same replies, the same repairs, the same fallbacks, the same ``scene.json`` bytes (and
every file identical from one replay to the next). A change to a
prompt or to the evidence changes the requests, and the replay then stops with a
``ReplayMissError`` naming what differs: re-record with the server (see the benchmark).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic.cli import app

REPO = Path(__file__).resolve().parents[2]
CASSETTES = REPO / "tests" / "fixtures" / "cassettes"
RECORDED = sorted(CASSETTES.glob("real_*.expected.json"))


def _digests(folder: Path, source: Path) -> dict[str, str]:
    """SHA-256 per file; ``scene.json`` records where its input was read, so that path is written
    ``<input>`` first (the live run read the same file from another checkout)."""
    out: dict[str, str] = {}
    for p in sorted(folder.rglob("*")):
        if not p.is_file():
            continue
        data = p.read_bytes()
        if p.name == "scene.json" and p.parent == folder:
            data = data.replace(source.as_posix().encode("utf-8"), b"<input>")
        out[p.relative_to(folder).as_posix()] = hashlib.sha256(data).hexdigest()
    return out


@pytest.mark.parametrize("expected_file", RECORDED, ids=lambda p: p.name.split(".")[0])
def test_a_recorded_real_run_replays_byte_for_byte(expected_file: Path, tmp_path: Path) -> None:
    expected = json.loads(expected_file.read_text(encoding="utf-8"))
    cassette = CASSETTES / expected["cassette"]
    source = REPO / expected["input"]
    runs = []
    for name in ("first", "second"):
        out = tmp_path / name
        result = CliRunner().invoke(
            app,
            ["generate", str(source), "--out", str(out), "--no-vision", "--model", f"replay:{cassette}", *expected.get("extra_args", [])],
        )
        assert result.exit_code == 0, result.output
        runs.append(out)
    report = json.loads((runs[0] / "report.json").read_text(encoding="utf-8"))
    agents = next(s for s in report["stages"] if s["name"] == "structure")["detail"]["agents"]
    assert {k: v["answered_by"] for k, v in agents.items()} == expected["answered_by"]
    assert {k: v["requests"] for k, v in agents.items()} == expected["requests"]
    if "evolve_layouts" in expected:  # a recording with the evolve stage: the critic's replies replay too
        evolve = next(s for s in report["stages"] if s["name"] == "evolve")["detail"]["layouts"]
        keys = ("anchor", "layout_id", "answered_by", "requests", "rounds", "valid")
        assert [{k: lay[k] for k in keys} for lay in evolve] == expected["evolve_layouts"]
    first, second = _digests(runs[0] / "base", source), _digests(runs[1] / "base", source)
    assert first == second  # every file, byte for byte, run after run
    assert set(first) == set(expected["base_sha256"])
    # what the live run wrote: the scene and its SceneEval state are our own bytes (the GLB and the
    # MJCF also carry trimesh's and MuJoCo's, which a newer release of either may write differently)
    ours = {k: v for k, v in expected["base_sha256"].items() if k.endswith(".json")}
    assert ours and {k: first[k] for k in ours} == ours


def test_a_recording_is_shipped() -> None:
    assert RECORDED, f"no recorded real run in {CASSETTES}"
    assert any("evolve_layouts" in json.loads(p.read_text(encoding="utf-8")) for p in RECORDED)
    for expected_file in RECORDED:
        expected = json.loads(expected_file.read_text(encoding="utf-8"))
        cassette = json.loads((CASSETTES / expected["cassette"]).read_text(encoding="utf-8"))
        assert list(cassette["models"]) == ["openai:qwen2.5-coder-0.5b-instruct"]  # the real server's model
        assert any(e.get("reply") for e in cassette["entries"].values())  # it did answer usably

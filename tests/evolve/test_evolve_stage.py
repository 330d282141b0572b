"""The evolve stage inside ``generate``: files, views, report, determinism and switches."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from agent_solvers import solver_answer
from PIL import Image
from typer.testing import CliRunner

from scenemosaic import GenerateConfig, generate
from scenemosaic.cli import app
from scenemosaic.exceptions import ModelHTTPError, UsageError
from scenemosaic.models import FunctionModel, Message, RequestContext

BEDROOM = Path(__file__).resolve().parents[1] / "fixtures" / "bedroom_22.json"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bed_views")
    result = CliRunner().invoke(app, ["generate", str(BEDROOM), "--out", str(out), "--variants", "5", "--save-views"])
    assert result.exit_code == 0, result.output
    return out


def test_views_are_written_per_unit_layout_and_round(run: Path) -> None:
    report = json.loads((run / "report.json").read_text())
    evolve = next(s for s in report["stages"] if s["name"] == "evolve")
    layouts = evolve["detail"]["layouts"]
    anchors = {lay["anchor"] for lay in layouts}
    assert {"floor", "ceiling", "bookshelf_0", "bed"} <= anchors and any(a.startswith("wall_") for a in anchors)
    for lay in layouts:
        folder = run / "evolve" / lay["anchor"] / lay["layout_id"]
        record = json.loads((run / "evolve" / lay["anchor"] / f"{lay['layout_id']}.json").read_text())
        rounds = sorted(folder.glob("round_*.png"))
        assert len(rounds) == len(record["memory"]) >= 1, lay
        assert (folder / "final.png").is_file()
        assert set(record["views"]) == {str(p.relative_to(run)) for p in [*rounds, folder / "final.png"]}
    with Image.open(run / "evolve" / "floor" / "original" / "round_1.png") as image:
        assert image.size == (1024, 1024)


def test_the_report_counts_layouts_and_the_base_is_valid(run: Path) -> None:
    report = json.loads((run / "report.json").read_text())
    assert report["status"] == "ok", report["warnings"]
    evolve = next(s for s in report["stages"] if s["name"] == "evolve")
    d = evolve["detail"]
    assert d["variants"] >= 3 and d["layout_count"] == len(d["layouts"]) == d["variants"] + d["units"]
    assert d["valid_layouts"] == len(d["layouts"]) and d["rule_violations"] == 0
    assert report["validation"]["collisions"]["pairs"] == [] and report["validation"]["out_of_bounds"]["objects"] == []


def test_equal_seeds_give_identical_files(tmp_path: Path) -> None:
    room = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "LivingDiningRoom-13536_livingroom.json"
    runs = [generate(room, tmp_path / name, GenerateConfig(variants=3, seed=7)) for name in ("a", "b")]
    a, b = (tmp_path / "a"), (tmp_path / "b")
    assert (a / "base" / "scene.json").read_text() == (b / "base" / "scene.json").read_text().replace(str(b), str(a))
    files = sorted(p.relative_to(a) for p in (a / "evolve").rglob("*.json"))
    assert files and files == sorted(p.relative_to(b) for p in (b / "evolve").rglob("*.json"))
    for f in files:
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    assert runs[0].scene.objects == runs[1].scene.objects


def test_no_evolve_keeps_the_stabilized_scene_and_variants_need_it(tmp_path: Path) -> None:
    room = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
    result = generate(room, tmp_path / "off", GenerateConfig(evolve=False))
    evolve = next(s for s in result.report["stages"] if s["name"] == "evolve")
    assert evolve["status"] == "skipped" and not (tmp_path / "off" / "evolve").exists()
    with pytest.raises(UsageError, match="variants come from the evolve stage"):
        generate(room, tmp_path / "bad", GenerateConfig(evolve=False, variants=2))


DINING = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"


def _critic_fails(messages: list[Message], context: RequestContext) -> Any:
    if context.agent == "critic":
        raise ModelHTTPError("the critic's server answered 500", status_code=500, body="")
    return solver_answer(messages, context)


def test_a_failing_critic_without_fallback_keeps_the_stabilized_unit_and_says_so(tmp_path: Path) -> None:
    stable = generate(DINING, tmp_path / "stable", GenerateConfig(evolve=False)).scene
    model = FunctionModel(_critic_fails, vision=False)
    result = generate(DINING, tmp_path / "run", GenerateConfig(model=model, solver_fallback=False))
    assert result.status == "degraded"
    assert any("evolution failed, kept the stabilized layout" in w for w in result.report["warnings"])
    evolve = next(s for s in result.report["stages"] if s["name"] == "evolve")
    assert all(lay["error"] and "ModelHTTPError" in lay["error"] for lay in evolve["detail"]["layouts"])
    assert [o.pose for o in result.scene.objects] == [o.pose for o in stable.objects]


def test_a_failing_critic_with_fallback_is_answered_by_the_rules_and_reported(tmp_path: Path) -> None:
    rules = generate(DINING, tmp_path / "rules", GenerateConfig()).scene
    result = generate(DINING, tmp_path / "run", GenerateConfig(model=FunctionModel(_critic_fails, vision=False)))
    assert result.status == "degraded"
    assert any("agent 'critic' (floor/original) answered by its rule solver" in w for w in result.report["warnings"])
    assert [o.pose for o in result.scene.objects] == [o.pose for o in rules.objects]  # the rules' own answer

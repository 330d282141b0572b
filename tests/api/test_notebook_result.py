"""The result a notebook gets from ``generate``: variants and metrics on demand, inline display,
and a synchronous call that works inside a running event loop (a Jupyter cell)."""

from __future__ import annotations

import asyncio
import base64
import json
from pathlib import Path

import pytest

import scenemosaic as sm
import scenemosaic.pipeline
from scenemosaic.exchange import read_scene

ROOM = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> sm.GenerateResult:
    return sm.generate(ROOM, tmp_path_factory.mktemp("nb") / "out", sm.GenerateConfig(variants=2))


def test_variants_and_metrics_come_from_the_output_folder(result: sm.GenerateResult) -> None:
    assert [d.name for d in result.variant_dirs] == ["variant_1", "variant_2"]
    variants = result.variants
    assert len(variants) == 2
    assert variants[0].model_dump_json() == read_scene(result.out_dir / "variant_1").model_dump_json()
    assert {o.id for o in variants[1].objects} == {o.id for o in result.scene.objects}
    m = result.metrics
    assert m is not None and len(m["variants"]) == 2 and set(m["base"]) >= {"COL", "OOB", "NAV"}
    assert m == json.loads((result.out_dir / "report.json").read_text(encoding="utf-8"))["metrics"]


def test_it_displays_inline_as_a_png_and_an_html_summary(result: sm.GenerateResult) -> None:
    png = result._repr_png_()
    assert png is not None and png.startswith(b"\x89PNG\r\n\x1a\n")
    assert png == (result.out_dir / "contact_sheet.png").read_bytes()
    page = result._repr_html_()
    assert "variant_2" in page and "NAV" in page and "Div-IoU" in page
    embedded = page.split('src="data:image/png;base64,', 1)[1].split('"', 1)[0]
    assert base64.b64decode(embedded) == png


def test_generate_works_inside_a_running_loop(tmp_path: Path) -> None:
    async def cell() -> sm.GenerateResult:  # what a Jupyter cell is: code run while a loop runs
        return sm.generate(ROOM, tmp_path / "in_loop", sm.GenerateConfig(evolve=False))

    res = asyncio.run(cell())
    assert res.status in ("ok", "degraded") and (res.base_dir / "scene.json").is_file()
    assert res.variant_dirs == [] and res.variants == []
    assert res._repr_png_() == (res.base_dir / "topdown.png").read_bytes()


def test_a_progress_bar_follows_the_stages_and_passes_them_on(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    seen: list[tuple[str, str]] = []
    res = sm.generate(ROOM, tmp_path / "bar", sm.GenerateConfig(evolve=False), progress=True, on_stage=lambda n, s: seen.append((n, s)))
    assert res.status in ("ok", "degraded")
    assert ("import", "started") in seen and seen[-1][1] in ("done", "reused")
    err = capsys.readouterr().err  # not a terminal (as a Jupyter cell): a plain line per stage, no widget
    lines = [line for line in err.splitlines() if line.startswith("generate: ")]
    assert len(lines) == len(sm.pipeline.STAGES), err
    assert f"({len(sm.pipeline.STAGES)}/{len(sm.pipeline.STAGES)}, " in lines[-1]

"""The result a notebook gets from ``generate``: variants and metrics on demand, inline display,
and a synchronous call that works inside a running event loop (a Jupyter cell); a house shown as
its plan with a short repr, and a house run's result giving each room's scene."""

from __future__ import annotations

import asyncio
import base64
import json
from pathlib import Path

import pytest

import scenemosaic as sm
import scenemosaic.pipeline
from scenemosaic.exchange import read_scene
from scenemosaic.render import render_house_plan
from scenemosaic.render._topdown import NOTEBOOK_HOUSE_PLAN_PX
from scenemosaic.scene import House, Scene

DATA = Path(__file__).resolve().parents[2] / "data"
ROOM = DATA / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"
FOUR_ROOMS = DATA / "houses" / "procthor" / "procthor_4room.json"
TWO_ROOMS = DATA / "houses" / "procthor" / "procthor10k_house3703_2room.json"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


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


def test_a_house_shows_as_its_whole_plan_with_a_short_repr() -> None:
    four, two = sm.load_scene(FOUR_ROOMS), sm.load_scene(TWO_ROOMS)
    assert isinstance(four, House) and isinstance(two, House)
    png = four._repr_png_()
    assert png is not None and png.startswith(PNG_SIGNATURE)
    # the house's plan, every room named (not one room's, not the pydantic text)
    assert png == render_house_plan(four, base_dir=FOUR_ROOMS.parent, size_px=NOTEBOOK_HOUSE_PLAN_PX)
    assert png != four.rooms[0]._repr_png_()
    assert png != four.with_rooms(four.rooms[:-1])._repr_png_()  # the last room is drawn too
    other = two._repr_png_()
    assert other is not None and other.startswith(PNG_SIGNATURE) and other != png
    text = repr(four)
    assert len(text) < 200 and len(str(four)) < 200, text
    assert "procthor_4room" in text and all(r in text for r in four.room_ids) and "objects=74" in text


def test_a_house_plan_that_cannot_be_drawn_falls_back_to_the_text_repr(monkeypatch: pytest.MonkeyPatch) -> None:
    from scenemosaic.scene import _model

    house = sm.load_scene(TWO_ROOMS)

    def broken(_: object) -> bytes:
        raise RuntimeError("no plan")

    monkeypatch.setattr(_model, "_plan_renderers", [broken])
    assert house._repr_png_() is None
    monkeypatch.setattr(_model, "_plan_renderers", [])
    assert house._repr_png_() is None


@pytest.fixture(scope="module")
def house_result(tmp_path_factory: pytest.TempPathFactory) -> sm.GenerateResult:
    return sm.generate(TWO_ROOMS, tmp_path_factory.mktemp("nb_house") / "out", sm.GenerateConfig(variants=1))


@pytest.mark.house  # a whole-house run (module fixture)
def test_a_house_result_gives_each_room(house_result: sm.GenerateResult) -> None:
    house = house_result.scene
    assert isinstance(house, House)
    assert house_result.rooms == ["room_2", "room_3"]
    kitchen = house_result.room("room_2")
    assert isinstance(kitchen, Scene) and kitchen.model_dump_json() == house.rooms[0].model_dump_json()
    assert house_result.room("room|3").id == "room_3"  # the source's id works too
    delivered = read_scene(house_result.base_dir / "rooms" / "room_3")
    assert {o.id: o.pose for o in house_result.room("room_3").objects} == {o.id: o.pose for o in delivered.objects}
    in_variant = house_result.room("room_3", variant=1)
    variant = house_result.variants[0]
    assert isinstance(variant, House) and in_variant.model_dump_json() == variant.room("room_3").model_dump_json()
    with pytest.raises(KeyError, match="room_2, room_3"):
        house_result.room("room_9")
    with pytest.raises(sm.UsageError, match="variant_1"):
        house_result.room("room_2", variant=2)


@pytest.mark.house  # a whole-house run (module fixture)
def test_a_house_result_displays_the_house_figures(house_result: sm.GenerateResult) -> None:
    png = house_result._repr_png_()
    assert png is not None and png == (house_result.out_dir / "contact_sheet.png").read_bytes()
    page = house_result._repr_html_()
    m = house_result.metrics
    assert m is not None and set(m) == {"house", "rooms"}
    for shown in ("house NAV", "door blockers", "room_2", "room_3", "COL / OOB", "variant_1", "house Div-IoU"):
        assert shown in page, shown
    assert f"<td>{m['house']['base']['house_nav']}</td>" in page
    assert f"house Div-IoU {m['house']['diversity']['Div-IoU']}" in page
    rooms = page.split("COL / OOB", 1)[1]
    room = m["rooms"]["room_3"]
    assert f"<td>room_3</td><td>{room['base']['COL']} / {room['base']['OOB']}</td>" in rooms


def test_a_room_run_is_a_house_of_one_room(result: sm.GenerateResult) -> None:
    """Rooms and houses read alike: ``result.house``, ``result.rooms`` and ``result.room(id)``
    answer for a one-room run too, its room being its scene."""
    assert isinstance(result.scene, Scene) and not isinstance(result.scene, House)
    house = result.house
    assert isinstance(house, House) and house.room_ids == result.rooms == [result.scene.id]
    assert result.room(result.scene.id).model_dump_json() == result.scene.model_dump_json()
    if result.variants:
        assert result.room(result.scene.id, variant=1).model_dump_json() == result.variants[0].model_dump_json()
    with pytest.raises(KeyError, match=result.scene.id):
        result.room("floor")

"""What stands on a toilet's tank stays on it (issue 54: a toilet-paper stand-in fell off the
cistern of an Objaverse-form house; the soap of a shipped house went to the floor): an item at the
tank's height that overhangs its front edge is laid out on the tank, not on the lid below, and an
item moved out of the lid's way goes back along the tank, never off its support's pieces down to
the floor beside the pedestal. The lid then opens."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import load_scene
from scenemosaic.scene import Scene
from tests.house_forms import FOUR_ROOMS, objaverse_form


@pytest.mark.parametrize("form", ["shipped", "objaverse"])
def test_the_items_on_a_toilets_tank_stay_on_it_and_its_lid_opens(tmp_path: Path, form: str) -> None:
    house = FOUR_ROOMS
    if form == "objaverse":  # the toilet paper and the sponge stand in as their types' median boxes
        house = tmp_path / "house.json"
        objaverse_form(FOUR_ROOMS, house)
    result = generate(house, tmp_path / "run", GenerateConfig(room="room|5", evolve=False))
    assert result.status == "ok", result.report.get("warnings")
    scene = load_scene(tmp_path / "run")
    assert isinstance(scene, Scene)
    toilet = next(o for o in scene.objects if o.category == "toilet")
    on_it = [o for o in scene.objects if (r := scene.support_of(o.id)) is not None and r.parent == toilet.id]
    assert {o.category for o in on_it} == {"toilet_paper", "soap_bottle", "dish_sponge"}
    top = float(toilet.aabb()[1][2])
    for o in on_it:
        assert float(o.aabb()[0][2]) == pytest.approx(top, abs=0.02), f"{o.id} is not on the tank"
    assert result.report["metrics"]["base"]["PARTS"] == 1.0 and not result.report["metrics"]["base"]["parts_blocked"]

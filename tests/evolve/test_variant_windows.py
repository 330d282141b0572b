"""Variants keep windows clear (issue 53): the rule patterns and room plans do not back tall furniture
onto more windows than the stabilized room has before them. The shipped 4-room house's base has
none blocked; before this, every one of its five variants stood a TV stand, dresser or wardrobe
before one or two (``scene.blocked_windows``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.pipeline import GenerateConfig, generate

HOUSE = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"


@pytest.mark.house
def test_no_variant_of_the_4_room_house_blocks_a_window_its_base_keeps_clear(tmp_path: Path) -> None:
    result = generate(HOUSE, tmp_path, GenerateConfig(variants=5, seed=0))
    metrics = result.report["metrics"]
    assert result.status == "ok" and len(metrics["house"]["variants"]) == 5
    for room_id, room in metrics["rooms"].items():
        base = len(room["base"]["windows_blocked"])
        for k, variant in enumerate(room["variants"], start=1):
            assert len(variant["windows_blocked"]) <= base, (room_id, k, variant["windows_blocked"])
    assert metrics["house"]["diversity"]["Div-IoU"] <= 0.60

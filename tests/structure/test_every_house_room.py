"""Every room of every shipped ProcTHOR house, generated as a user would (``--room``, rules model),
ends ``ok``: no collision, nothing out of bounds, nothing tipped or fallen (read from ``report.json``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenemosaic.exchange import load_scenes
from scenemosaic.pipeline import GenerateConfig, generate

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"
ROOMS = [
    pytest.param(house, scene.provenance.source_room_id, id=f"{house.stem}-{scene.provenance.source_room_id}")
    for house in sorted(HOUSES.glob("procthor*.json"))
    for scene in load_scenes(house)
]


def test_the_shipped_houses_are_dense_enough_to_mean_something() -> None:
    assert len(ROOMS) >= 25
    objects = sum(len(s.objects) for house in HOUSES.glob("procthor*.json") for s in load_scenes(house))
    assert objects >= 400


@pytest.mark.slow
@pytest.mark.house
@pytest.mark.parametrize(("house", "room"), ROOMS)
def test_every_room_ends_physically_valid(house: Path, room: str, tmp_path: Path) -> None:
    generate(house, tmp_path / "out", GenerateConfig(room=room, model="rules"))
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    validation = report["validation"]
    assert validation["collisions"]["pairs"] == [], validation["collisions"]["pairs"]
    assert validation["out_of_bounds"]["objects"] == [], validation["out_of_bounds"]["objects"]
    assert validation["fell"] == [] and validation["tipped"] == []
    assert report["status"] == "ok", report["warnings"]

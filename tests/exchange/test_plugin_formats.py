"""A format is its module and one registration (``docs/architecture.md``, "Adding a format"): a plugin
export format is written for a room and for a whole house, delivered in every delivered folder and
offered by ``scenemosaic export``; a plugin house source is detected, read as a house and run as
one; and neither needs any other file of the package touched."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

import scenemosaic as sm
from scenemosaic.cli import app
from scenemosaic.exchange import (
    FORMATS,
    ReadOptions,
    SceneFormat,
    deliver_scene,
    delivered_formats,
    delivery_parts,
    house_formats,
    is_house_source,
    load_house,
    load_scenes,
    plugin_formats,
)
from scenemosaic.scene import House, Provenance, Scene

DATA = Path(__file__).resolve().parents[2] / "data"
TWO_ROOMS = DATA / "houses" / "procthor" / "procthor10k_house3703_2room.json"
ROOM = DATA / "layouts" / "physcene" / "DiningRoom-19325_diningroom.json"


# -- a plugin export format: one text line per object ----------------------------------------------


def _write_positions(world: Scene | House, destination: Path, base_dir: Path | None) -> Path:
    """``positions.txt``: ``<room id> <object id> x y z`` a line (a house: every room's objects)."""
    del base_dir
    rooms = world.rooms if isinstance(world, House) else [world]
    lines = [f"{room.id} {o.id} " + " ".join(f"{c:.3f}" for c in o.pose.position) for room in rooms for o in room.objects]
    destination.parent.mkdir(parents=True, exist_ok=True)
    destination.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return destination


POSITIONS = SceneFormat(
    "positions", "object positions, one line each", write=_write_positions, writes_houses=True, delivered="positions.txt"
)


@pytest.fixture
def positions_format(monkeypatch: pytest.MonkeyPatch) -> SceneFormat:
    monkeypatch.setitem(FORMATS, POSITIONS.name, POSITIONS)  # gone again after the test
    return POSITIONS


def test_a_registered_export_format_writes_rooms_and_houses(positions_format: SceneFormat, tmp_path: Path) -> None:
    room = sm.load_scene(ROOM)
    written = sm.write_scene(room, "positions", tmp_path / "room.txt")
    assert len(written.read_text().splitlines()) == len(room.objects)
    house = load_house(TWO_ROOMS)
    lines = sm.write_scene(house, "positions", tmp_path / "house.txt").read_text().splitlines()
    assert len(lines) == len(house.objects) and {line.split()[0] for line in lines} == set(house.room_ids)
    assert ("positions", "positions.txt") in delivered_formats() and "positions" in delivery_parts()
    assert plugin_formats() == ["positions"]


def test_a_registered_export_format_is_delivered_with_every_scene(positions_format: SceneFormat, tmp_path: Path) -> None:
    room = sm.load_scene(ROOM)
    files = deliver_scene(room, tmp_path / "room", ROOM.parent)
    assert "positions.txt" in files
    house = load_house(TWO_ROOMS)
    files = deliver_scene(house, tmp_path / "house", TWO_ROOMS.parent)
    assert "positions.txt" in files
    assert len((tmp_path / "house" / "positions.txt").read_text().splitlines()) == len(house.objects)


def test_the_export_command_offers_a_registered_format(positions_format: SceneFormat, tmp_path: Path) -> None:
    run = sm.generate(ROOM, tmp_path / "run", sm.GenerateConfig(variants=0))
    assert (run.out_dir / "base" / "positions.txt").is_file()  # delivered by generate too
    result = CliRunner().invoke(app, ["export", str(run.out_dir), "--format", "positions", "--out", str(tmp_path / "x")])
    assert result.exit_code == 0, result.output
    assert list((tmp_path / "x").rglob("positions.txt"))


# -- a plugin house source: a file that names a ProcTHOR house and reads it as its own -------------


def _looks_like_toy_house(data: Any) -> bool:
    return isinstance(data, dict) and set(data) == {"toy_house"}


def _read_toy_house(data: Any, path: Path, options: ReadOptions) -> list[Scene]:
    """Every room of the house file ``data["toy_house"]`` names (beside ``path``), as this format's."""
    del options
    rooms = load_scenes(path.parent / data["toy_house"])
    for room in rooms:
        room.provenance = Provenance(source_format="toy_house", source_path=path.as_posix(), importer="tests.toy_house")
    return rooms


TOY_HOUSE = SceneFormat(
    "toy_house", "a house by reference (a test plugin)", detect=_looks_like_toy_house, read=_read_toy_house, holds_houses=True
)


@pytest.fixture
def toy_house(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    import shutil

    # registered first: detection tries formats in order, and ours is a precise test
    monkeypatch.setattr("scenemosaic.exchange._registry.FORMATS", {TOY_HOUSE.name: TOY_HOUSE, **FORMATS})
    shutil.copy(TWO_ROOMS, tmp_path / TWO_ROOMS.name)
    source = tmp_path / "toy.json"
    source.write_text(json.dumps({"toy_house": TWO_ROOMS.name}), encoding="utf-8")
    return source


def test_a_registered_house_source_is_read_and_run_as_a_house(toy_house: Path, tmp_path: Path) -> None:
    assert "toy_house" in house_formats()
    assert is_house_source(toy_house)
    house = load_house(toy_house)
    assert house.room_ids == ["room_2", "room_3"] and house.provenance.source_format == "toy_house"
    run = sm.generate(toy_house, tmp_path / "run", sm.GenerateConfig(variants=1))
    assert run.report["house"]["rooms"] == ["room_2", "room_3"]  # every room at once, as a house
    assert (run.out_dir / "base" / "house_scene.json").is_file()
    rooms = next(s for s in run.report["stages"] if s["name"] == "rooms")
    assert not rooms["detail"]["processes"]  # a plugin's reader is known in this process only


def test_a_single_room_file_of_a_house_format_is_not_a_house(tmp_path: Path) -> None:
    one_room = DATA / "houses" / "procthor" / "procthor_1room_bedroom.json"
    assert "procthor" in house_formats()
    assert not is_house_source(one_room)  # read as one room
    assert not is_house_source(ROOM)  # 3D-FRONT holds no houses
    assert not is_house_source(tmp_path)  # a folder is no house source

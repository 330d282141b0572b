"""``write_scene`` takes a whole ``House`` (issue 35): every format with a house writer, from a
house in memory (the shipped four-room ProcTHOR house as ``load_scene`` imports it), each file read
back by its consumer; the same bytes as the delivered house folder; nothing left behind when a
writer fails; a clear error for a format that cannot write a house."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import pytest
from simulator_checks import destination, read_back

import scenemosaic as sm
from scenemosaic.assets import room_door_leaves
from scenemosaic.exceptions import MissingExtraError, UsageError
from scenemosaic.exchange import (
    FORMATS,
    SceneFormat,
    deliver_scene,
    delivered_formats,
    formats_left_out,
    writable_formats,
)
from scenemosaic.scene import House

HOUSE_FILE = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"
HOUSE_FORMATS = ("native", "glb", "sceneeval", "mjcf", "urdf", "usd", "procthor")


@pytest.fixture(scope="module")
def house() -> House:
    loaded = sm.load_scene(HOUSE_FILE)
    assert isinstance(loaded, House) and len(loaded.rooms) == 4
    return loaded


def test_every_delivered_format_writes_a_house() -> None:
    assert set(writable_formats(house=True)) == set(HOUSE_FORMATS)
    assert {fmt for fmt, _ in delivered_formats()} <= set(HOUSE_FORMATS)


@pytest.mark.parametrize("fmt", HOUSE_FORMATS)
def test_write_scene_writes_the_whole_house(house: House, fmt: str, tmp_path: Path) -> None:
    folder = tmp_path / "out"
    written = sm.write_scene(house, fmt, destination(folder, fmt), HOUSE_FILE.parent)
    assert written.is_file() and folder in written.parents
    names = read_back(fmt, folder)
    ids = {o.id for o in house.objects}
    if fmt == "procthor":  # the AI2-THOR house file, every room of it
        assert names == {s.provenance.source_room_id for s in house.rooms}
        return
    assert ids <= names, sorted(ids - names)[:5]
    static = {"world", "floor", "room", *house.room_ids}  # the house's own bodies, links and nodes
    doors = {d.object.id for d in room_door_leaves(house)}  # the rooms' doors, hung in the simulator files
    # ``<object id>/<part>``: the drawers, doors and lids of furniture that opens (docs/articulation.md)
    known = static | ids | doors | {"scenemosaic:z_up"}
    assert {n.split("/")[0] for n in names - ids} <= known, sorted(names - ids)[:5]


def test_write_scene_gives_the_delivered_bytes(house: House, tmp_path: Path) -> None:
    """One writer per format: a house written format by format equals the delivered folder."""
    delivered = tmp_path / "delivered"
    deliver_scene(house, delivered, HOUSE_FILE.parent)
    saved = sm.load_scene(delivered)
    assert isinstance(saved, House)
    for fmt, _ in delivered_formats():
        if fmt in formats_left_out():
            continue
        main = sm.write_scene(saved, fmt, destination(tmp_path / fmt, fmt), delivered)
        assert main.read_bytes() == (delivered / main.relative_to(tmp_path / fmt)).read_bytes(), fmt


def _failing(fmt: str) -> SceneFormat:
    """Format ``fmt`` whose writer writes everything, then fails."""
    real = FORMATS[fmt].write
    assert real is not None and FORMATS[fmt].writes_houses

    def write(house: House, dest: Path, base_dir: Path | None) -> Path:
        real(house, dest, base_dir)
        raise RuntimeError("the disk went away")

    return dataclasses.replace(FORMATS[fmt], write=write)


@pytest.mark.parametrize("fmt", HOUSE_FORMATS)
def test_a_failed_write_leaves_no_folder_behind(
    house: House, fmt: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(FORMATS, fmt, _failing(fmt))
    with pytest.raises(RuntimeError, match="the disk went away"):
        sm.write_scene(house, fmt, destination(tmp_path / "new" / "house", fmt), HOUSE_FILE.parent)
    assert list(tmp_path.iterdir()) == []
    # in a folder that was there, what was there stays and nothing else
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "notes.txt").write_text("mine", encoding="utf-8")
    with pytest.raises(RuntimeError):
        sm.write_scene(house, fmt, destination(kept, fmt), HOUSE_FILE.parent)
    assert [p.name for p in kept.iterdir()] == ["notes.txt"]


def test_a_missing_extra_names_its_pip_install_and_writes_nothing(
    house: House, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "pxr", None)
    with pytest.raises(MissingExtraError) as failed:
        sm.write_scene(house, "usd", tmp_path / "usd")
    assert FORMATS["usd"].extra is not None and FORMATS["usd"].extra[1] in str(failed.value)
    assert not (tmp_path / "usd").exists()


def test_a_format_without_a_house_writer_is_refused_by_name(
    house: House, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(FORMATS, "rooms_only", SceneFormat("rooms_only", "a plugin", write=lambda s, d, b: d))
    with pytest.raises(UsageError, match="cannot write a whole house") as refused:
        sm.write_scene(house, "rooms_only", tmp_path / "x")
    assert "mjcf" in str(refused.value) and "house.room(" in str(refused.value)
    with pytest.raises(UsageError, match="cannot write a whole house"):
        sm.write_scene(house, "front3d", tmp_path / "x")  # a reader only
    assert not (tmp_path / "x").exists()
    one_room = house.rooms[0]
    assert sm.write_scene(one_room, "rooms_only", tmp_path / "y") == tmp_path / "y"  # a room still goes through

"""Datasets of houses (``.jsonl``/``.jsonl.gz``, one house a line, as ProcTHOR-10k ships): a house
is read by its index, lazily, named after the file and the index, and written back into its line's
house; what is not a house of a dataset is refused with a clear error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dataset_helpers import FOUR_ROOMS, ONE_ROOM, TWO_ROOMS, write_dataset

from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.exchange import (
    dataset_entries,
    dataset_size,
    export_procthor,
    is_dataset,
    load_house,
    load_scene,
)
from scenemosaic.scene import House


@pytest.mark.parametrize("name", ["houses.jsonl.gz", "houses.jsonl"])
def test_a_house_of_a_dataset_is_the_house_of_its_file(tmp_path: Path, name: str) -> None:
    dataset = write_dataset(tmp_path / name, [ONE_ROOM, TWO_ROOMS, FOUR_ROOMS], blank_after=0)
    assert is_dataset(dataset) and dataset_size(dataset) == 3
    house = load_scene(dataset, index=2)
    alone = load_house(FOUR_ROOMS)
    assert isinstance(house, House)
    assert house.id == "houses-2"
    assert house.room_ids == alone.room_ids
    assert [len(r.objects) for r in house.rooms] == [len(r.objects) for r in alone.rooms]
    assert house.provenance.source_index == 2 and house.rooms[0].provenance.source_index == 2
    assert house.rooms[0].provenance.source_path == dataset.as_posix()
    one = load_scene(dataset, index=0)  # the blank line after it is not a house
    assert not isinstance(one, House) and one.provenance.source_index == 0
    assert [e.line for e in dataset_entries(dataset)] == [1, 3, 4]


def test_a_house_of_a_dataset_is_written_back_into_its_own_line(tmp_path: Path) -> None:
    dataset = write_dataset(tmp_path / "houses.jsonl.gz", [ONE_ROOM, TWO_ROOMS])
    house = load_house(dataset, index=1)
    room = house.rooms[0]
    moved = room.objects[0]
    x, y, z = moved.pose.position
    shifted = moved.model_copy(update={"pose": moved.pose.model_copy(update={"position": (x + 0.1, y, z)})})
    room = room.model_copy(update={"objects": [shifted, *room.objects[1:]]})
    written = json.loads(export_procthor(room, tmp_path / "back").read_text(encoding="utf-8"))
    source = json.loads(TWO_ROOMS.read_text(encoding="utf-8"))
    assert [r["id"] for r in written["rooms"]] == [r["id"] for r in source["rooms"]]
    raw = room.provenance.source_ids[moved.id]
    back = next(o for o in written["objects"] if o["id"] == raw)
    before = next(o for o in source["objects"] if o["id"] == raw)
    assert back["position"]["x"] == pytest.approx(before["position"]["x"] + 0.1, abs=1e-6)


def test_a_dataset_needs_an_index_within_it_and_only_a_dataset_takes_one(tmp_path: Path) -> None:
    dataset = write_dataset(tmp_path / "houses.jsonl.gz", [ONE_ROOM, TWO_ROOMS])
    with pytest.raises(UsageError, match="dataset of 2 houses: pick one with index="):
        load_scene(dataset)
    with pytest.raises(UsageError, match=r"holds 2 houses \(indices 0 to 1\); there is no house 5"):
        load_scene(dataset, index=5)
    with pytest.raises(UsageError, match="picks a house of a dataset"):
        load_scene(TWO_ROOMS, index=0)


def test_a_broken_line_is_named_by_its_house_and_line(tmp_path: Path) -> None:
    dataset = tmp_path / "houses.jsonl"
    write_dataset(dataset, [ONE_ROOM])
    dataset.write_text(dataset.read_text(encoding="utf-8") + '{"rooms": [\n', encoding="utf-8")
    assert load_scene(dataset, index=0) is not None  # the house before it reads
    with pytest.raises(ImportFormatError, match=r"house 1 \(line 2\): invalid JSON"):
        load_scene(dataset, index=1)
    truncated = tmp_path / "cut.jsonl.gz"
    write_dataset(truncated, [ONE_ROOM, TWO_ROOMS])
    truncated.write_bytes(truncated.read_bytes()[:-40])  # a download cut short
    with pytest.raises(ImportFormatError, match="cannot read the dataset"):
        dataset_size(truncated)


def test_a_house_read_again_comes_from_memory_until_the_file_changes(tmp_path: Path) -> None:
    from scenemosaic.exchange import dataset_entry

    dataset = write_dataset(tmp_path / "houses.jsonl", [ONE_ROOM, TWO_ROOMS])
    first = dataset_entry(dataset, 1)
    assert dataset_entry(dataset, 1) is first  # a run asks several times: the file is streamed once
    write_dataset(dataset, [TWO_ROOMS, ONE_ROOM, FOUR_ROOMS])  # rewritten: another size
    again = dataset_entry(dataset, 1)
    assert again is not first and json.loads(again.text) == json.loads(ONE_ROOM.read_text(encoding="utf-8"))

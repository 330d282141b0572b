"""``format_tree`` of a house: every room's own tree under the house, in the house's room order."""

from __future__ import annotations

from pathlib import Path

from scenemosaic.exchange import load_house
from scenemosaic.scene import format_tree

HOUSE = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"


def test_a_house_tree_holds_each_rooms_tree_in_order() -> None:
    house = load_house(HOUSE)
    text = format_tree(house)
    assert text.splitlines()[0].startswith(f"{house.id}  ({len(house.rooms)} rooms, {len(house.objects)} objects)")
    positions = [text.index(f"  {room.id}:") for room in house.rooms]
    assert positions == sorted(positions)
    for room in house.rooms:
        for line in format_tree(room).splitlines():
            assert "    " + line in text

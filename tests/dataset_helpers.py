"""Helpers of the house-file tests: datasets of houses (``.jsonl``/``.jsonl.gz``) written from the
shipped ProcTHOR houses, and a house file's objects in file order."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

HOUSES = Path(__file__).resolve().parents[1] / "data" / "houses" / "procthor"
TWO_ROOMS = HOUSES / "procthor10k_house3703_2room.json"
ONE_ROOM = HOUSES / "procthor_1room_bedroom.json"
FOUR_ROOMS = HOUSES / "procthor_4room.json"


def write_dataset(path: Path, houses: list[Path], *, blank_after: int | None = None) -> Path:
    """The houses' files, one compact line each (gzip when the name ends in .gz), a blank line
    after house ``blank_after`` (blank lines do not count)."""
    lines = []
    for i, house in enumerate(houses):
        lines.append(json.dumps(json.loads(house.read_text(encoding="utf-8"))))
        if i == blank_after:
            lines.append("")
    text = "\n".join(lines) + "\n"
    if path.name.endswith(".gz"):
        with gzip.open(path, "wt", encoding="utf-8") as handle:
            handle.write(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def house_items(objects: list[dict]) -> list[dict]:
    """An AI2-THOR house file's objects and their children, in file order (as its readers walk it)."""
    out = []
    for item in objects:
        out.append(item)
        out.extend(house_items(item.get("children") or []))
    return out

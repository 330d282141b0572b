"""A house asked for more variants than its rooms can give (issue 54): capped at the room
arrangements its rooms hold besides their bases, said once in the notes, each variant delivered
(``--variants 1000`` on a two-room house: 12 variants in about 25 s, not a run of hours)."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic.pipeline import GenerateConfig, generate

pytestmark = pytest.mark.house

TWO_ROOMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor10k_house3703_2room.json"


def test_a_thousand_variants_of_a_two_room_house_are_capped_at_its_rooms_arrangements(tmp_path: Path) -> None:
    result = generate(TWO_ROOMS, tmp_path / "run", GenerateConfig(variants=1000, seed=0))
    report = result.report
    compose = next(s for s in report["stages"] if s["name"] == "compose")
    per_room = {room: int(n) for room, n in compose["detail"]["room_variants"].items()}
    cap = sum(per_room.values())
    assert 1 < cap < 1000
    assert compose["detail"]["capped_at"] == cap
    assert report["variants_written"] == cap
    assert sorted(p.name for p in (tmp_path / "run").glob("variant_*")) == sorted(f"variant_{i}" for i in range(1, cap + 1))
    said = [n for n in report["notes"] if "house variants asked for" in n]
    assert len(said) == 1 and f"1000 house variants asked for, {cap} given" in said[0]
    rooms = [
        {p.parent.name: p.read_bytes() for p in sorted((tmp_path / "run" / f"variant_{i}" / "rooms").glob("*/scene.json"))}
        for i in (1, cap)
    ]
    assert set(rooms[0]) == {"room_2", "room_3"} and rooms[0] != rooms[1]

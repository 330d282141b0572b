"""A fork that writes floor objects at ``y = 0`` (the bottom of their box, not ProcTHOR's centre;
issue 54): told apart per file, read to the same scene as the ProcTHOR form, said once, and written
back in the file's own convention."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from dataset_helpers import house_items

from scenemosaic.exchange import export_procthor, load_asset_database, load_house
from scenemosaic.exchange._procthor import positions_at_base
from tests.house_forms import base_form as fork_form

FOUR_ROOMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"


def base_form(path: Path) -> Path:
    """The 4-room house as the fork writes it: every position at the bottom of its box."""
    return fork_form(FOUR_ROOMS, path)


def test_both_conventions_are_told_apart_and_read_to_one_house(tmp_path: Path) -> None:
    db = load_asset_database(None)
    fork = base_form(tmp_path / "fork.json")
    assert not positions_at_base(json.loads(FOUR_ROOMS.read_text()), db)
    assert positions_at_base(json.loads(fork.read_text()), db)
    ours, theirs = load_house(FOUR_ROOMS), load_house(fork)
    for a, b in zip(ours.rooms, theirs.rooms, strict=True):
        assert [o.id for o in a.objects] == [o.id for o in b.objects]
        for x, y in zip(a.objects, b.objects, strict=True):
            assert np.allclose(x.pose.position, y.pose.position, atol=1e-6), x.id
        assert not a.provenance.source_faults or all("bottom of its box" not in f for f in a.provenance.source_faults)
        assert sum("bottom of its box" in f for f in b.provenance.source_faults) == 1


def test_a_fork_house_is_written_back_at_base(tmp_path: Path) -> None:
    fork = base_form(tmp_path / "fork.json")
    house = load_house(fork)
    written = json.loads(export_procthor(house, tmp_path / "back").read_text(encoding="utf-8"))
    before = house_items(json.loads(fork.read_text())["objects"])
    after = house_items(written["objects"])
    for a, b in zip(before, after, strict=True):
        assert b["position"]["y"] == pytest.approx(a["position"]["y"], abs=1e-4), a["id"]

"""A room taken from an AI2-THOR / ProcTHOR house goes back into that house: ``house.json``
beside the delivered scene, with the room's objects where the pipeline put them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.exceptions import UsageError
from scenemosaic.exchange import export_procthor, load_scenes, read_scene
from scenemosaic.pipeline import demo_scene

HOUSE = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"


def _same_pose(a: object, b: object) -> tuple[float, float]:
    pa, pb = a.pose, b.pose  # type: ignore[attr-defined]
    dp = float(np.abs(np.subtract(pa.position, pb.position)).max())
    dq = min(float(np.abs(np.subtract(pa.quaternion, pb.quaternion)).max()), float(np.abs(np.add(pa.quaternion, pb.quaternion)).max()))
    return dp, dq


def test_a_generated_room_round_trips_through_its_house(tmp_path: Path) -> None:
    original = {s.id: s for s in load_scenes(HOUSE)}
    result = generate(HOUSE, tmp_path / "out", GenerateConfig(room="room_5", variants=1))
    for folder in (result.base_dir, result.out_dir / "variant_1"):
        scene = read_scene(folder)
        house = folder / "house.json"
        assert house.is_file(), sorted(p.name for p in folder.iterdir())
        back = {s.id: s for s in load_scenes(house)}
        assert set(back) == set(original)
        for obj in scene.objects:
            dp, dq = _same_pose(back["room_5"].get(obj.id), obj)
            assert dp < 2e-6 and dq < 1e-6, (folder.name, obj.id, dp, dq)
        for rid in set(original) - {"room_5"}:  # the other rooms as the house had them
            assert back[rid].model_dump()["objects"] == original[rid].model_dump()["objects"]
    moved = [o.id for o in result.scene.objects if _same_pose(o, original["room_5"].get(o.id))[0] > 1e-3]
    assert moved  # the pipeline did move something, and the house carries it
    raw = json.loads((result.base_dir / "house.json").read_text(encoding="utf-8"))
    assert raw.keys() == json.loads(HOUSE.read_text(encoding="utf-8")).keys()


def test_a_scene_from_elsewhere_is_not_written_as_a_house(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="not imported from an AI2-THOR/ProcTHOR house"):
        export_procthor(demo_scene(), tmp_path)


def test_objects_fill_adds_go_into_the_house_file(tmp_path: Path) -> None:
    """``--clutter fill`` draws objects from the asset database; the written-back house lists each,
    a child of the receptacle it rests on, and reads back at the delivered pose."""
    result = generate(HOUSE, tmp_path / "out", GenerateConfig(room="room_6", clutter="fill"))
    scene = read_scene(result.base_dir)
    added = scene.metadata["clutter"]["objects"]
    assert len(added) >= 5
    raw = json.loads((result.base_dir / "house.json").read_text(encoding="utf-8"))
    source_ids = scene.provenance.source_ids
    children: dict[str, str] = {}

    def walk(items: list[dict[str, object]]) -> None:
        for item in items:
            kids = item.get("children") or []
            assert isinstance(kids, list)
            children.update({str(c["id"]): str(item["id"]) for c in kids})
            walk(kids)

    walk(raw["objects"])
    for oid, entry in added.items():
        assert children.get(oid) == source_ids[entry["receptacle"]], oid  # under its receptacle
    back = {s.id: s for s in load_scenes(result.base_dir / "house.json")}["room_6"]
    for oid, entry in added.items():
        obj = back.get(oid)
        assert entry["asset_id"] in obj.description
        dp, dq = _same_pose(obj, scene.get(oid))
        assert dp < 2e-6 and dq < 1e-6, (oid, dp, dq)
    assert len(back.objects) == len(scene.objects)

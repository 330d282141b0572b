"""Issue 38: a house's variants share their furniture's exported files.

Collision shapes, hull meshes, OBJ files and USD geometry layers are made once per process for
each asset (its fingerprint, or the hash of the vertices) and written again for every variant
that holds it. What the memos hand out must be what fresh work gives: a variant delivered after
another is byte for byte the variant delivered by a process that has seen nothing before.
"""

from __future__ import annotations

import gc
from pathlib import Path

from scenemosaic._memo import Memo
from scenemosaic.exchange import deliver_scene, load_house
from scenemosaic.scene import House, Pose

HOUSE_JSON = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"


def _forget_everything() -> int:
    """Empty every memo of the process (what a fresh worker starts with); how many there were."""
    memos = [o for o in gc.get_objects() if isinstance(o, Memo)]
    for memo in memos:
        memo.clear()
    return len(memos)


def _moved(house: House, dx: float) -> House:
    """The house with every object shifted by ``dx`` along x and turned a quarter (a variant)."""
    rooms = []
    for scene in house.rooms:
        objects = [
            o.model_copy(
                update={
                    "pose": Pose.from_yaw(
                        (o.pose.position[0] + dx, o.pose.position[1], o.pose.position[2]), 90.0
                    )
                }
            )
            for o in scene.objects
        ]
        rooms.append(scene.model_copy(update={"objects": objects}))
    return house.model_copy(update={"rooms": rooms})


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_variant_delivered_after_another_equals_it_delivered_fresh(tmp_path: Path) -> None:
    house = load_house(HOUSE_JSON)
    variant = _moved(house, 0.05)
    assert _forget_everything() >= 5  # shapes, hull meshes, pieces, OBJ texts, layers, wall pieces
    deliver_scene(house, tmp_path / "base", HOUSE_JSON.parent)
    deliver_scene(variant, tmp_path / "after", HOUSE_JSON.parent)
    _forget_everything()
    deliver_scene(variant, tmp_path / "fresh", HOUSE_JSON.parent)
    after, fresh = _files(tmp_path / "after"), _files(tmp_path / "fresh")
    assert sorted(after) == sorted(fresh)
    assert [name for name in after if after[name] != fresh[name]] == []
    base = _files(tmp_path / "base")
    shared = [
        name
        for name in after
        if name.startswith(("mjcf/", "urdf/meshes/", "usd/")) and base.get(name) == after[name]
    ]
    assert len(shared) > 100  # the furniture's files: equal in both variants (written from the memos)
    assert base["scene.xml"] != after["scene.xml"]  # the poses are the variant's own

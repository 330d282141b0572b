"""The scene tree: SAM3D-like acceptance, unit frames, unit independence, the readable tree."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenemosaic.scene import FLOOR, Pose, Room, Scene
from scenemosaic.scene._tree import build_structure, format_tree, unit_frame, unit_layout, with_unit_layout
from scenemosaic.structure import structure_scene


async def test_sam3d_desk_unit_and_chair_constraint(sam3d_scene: Scene, procthor_dir: Path) -> None:
    out = await structure_scene(sam3d_scene, priors_dir=procthor_dir)
    assert out.structure is not None
    units = {u.anchor_id: u for u in out.structure.units}
    assert set(units["desk"].children) == {"printer", "mug"}
    assert units["desk"].anchor_kind == "object" and units["desk"].projection == "top_down"
    assert set(units[FLOOR].children) == {"desk", "chair", "bed"}
    # chair-faces-desk: one cross-unit constraint, split into a floor clause and a desk clause
    [c] = [c for c in out.constraints if "chair" in c.anchor_a.related_objects + c.anchor_b.related_objects]
    assert c.kind == "orientation"
    clauses = {c.anchor_a.anchor_id: c.anchor_a, c.anchor_b.anchor_id: c.anchor_b}
    assert set(clauses) == {FLOOR, "desk"}
    assert "chair" in clauses[FLOOR].related_objects
    assert set(clauses["desk"].related_objects) <= {"printer", "mug"}
    assert any(cl.anchor_id == "desk" for cl in units["desk"].clauses)
    assert any(cl.anchor_id == FLOOR for cl in units[FLOOR].clauses)
    # units are top-down: every object anchor comes after the unit holding it
    order = [u.anchor_id for u in out.structure.units]
    assert order.index(FLOOR) < order.index("desk")
    # the structure is part of scene.json
    again = Scene.from_json(out.to_json())
    assert again.structure == out.structure and again.constraints == out.constraints


def test_wall_frame_is_proper_and_faces_outward() -> None:
    scene = Scene(room=Room.rectangle(0, 0, 5, 4, ceiling_height=2.6))
    for w in scene.room.walls:  # type: ignore[union-attr]
        m = unit_frame(scene, w.id)
        r = m[:3, :3]
        assert abs(np.linalg.det(r) - 1.0) < 1e-9
        assert np.allclose(r[:2, 1], w.outward_normal)  # y = outward normal
        assert np.allclose(r[:, 2], (0, 0, 1))  # z up
        assert np.allclose(m[:2, 3], w.end) and m[2, 3] == 0.0
    assert unit_frame(scene, "ceiling")[2, 3] == 2.6


async def test_units_are_independent(sam3d_scene: Scene, procthor_dir: Path) -> None:
    scene = await structure_scene(sam3d_scene, priors_dir=procthor_dir)
    assert scene.structure is not None
    before = {u.anchor_id: unit_layout(scene, u) for u in scene.structure.units}
    snapshot = scene.to_json()

    # edit the floor unit: move and turn the desk, move the chair
    floor = dict(before[FLOOR])
    d = floor["desk"]
    floor["desk"] = Pose.from_yaw((d.position[0] + 0.4, d.position[1] - 0.3, d.position[2]), 0.5, d.scale)
    floor["chair"] = floor["chair"].model_copy(update={"position": (1.0, 0.5, 0.0)})
    edited = with_unit_layout(scene, FLOOR, {"desk": floor["desk"], "chair": floor["chair"]})
    after = {u.anchor_id: unit_layout(edited, u) for u in scene.structure.units}
    assert after[FLOOR]["chair"].position == (1.0, 0.5, 0.0)
    assert not np.allclose(edited.get("mug").pose.position, scene.get("mug").pose.position)  # carried along
    for anchor, layout in before.items():
        if anchor == FLOOR:
            continue
        for oid, pose in layout.items():
            assert np.allclose(after[anchor][oid].position, pose.position, atol=1e-9), (anchor, oid)
            assert np.allclose(after[anchor][oid].quaternion, pose.quaternion, atol=1e-9), (anchor, oid)
    assert scene.to_json() == snapshot  # with_unit_layout returned a new scene

    # edit the desk unit: only the mug moves; the floor unit is unchanged
    mug = before["desk"]["mug"]
    edited2 = with_unit_layout(scene, "desk", {"mug": mug.model_copy(update={"position": (-0.5, 0.1, mug.position[2])})})
    for oid, pose in unit_layout(edited2, FLOOR).items():
        assert np.allclose(pose.position, before[FLOOR][oid].position)
    assert unit_layout(edited2, "desk")["printer"] == before["desk"]["printer"]
    assert np.allclose(unit_layout(edited2, "desk")["mug"].position, (-0.5, 0.1, mug.position[2]))


async def test_format_tree_and_rebuild(sam3d_scene: Scene, procthor_dir: Path) -> None:
    scene = await structure_scene(sam3d_scene, priors_dir=procthor_dir)
    text = format_tree(scene)
    lines = text.splitlines()
    assert lines[0].startswith("room")
    assert any("── desk [work_desk]" in line for line in lines)
    mug_line = next(line for line in lines if "mug [" in line)
    desk_line = next(line for line in lines if "desk [" in line)
    assert mug_line.index("mug [") > desk_line.index("desk [")  # nested one level deeper
    assert "constraints:" in text and "@desk" in text
    assert build_structure(scene) == scene.structure


async def test_imported_sam3d_meshes_give_the_desk_unit_and_chair_constraint(
    tmp_path: Path, repo_data: Path, procthor_dir: Path
) -> None:
    """The acceptance on the real meshes as the SAM3D importer lays them out (not boxes)."""
    from scenemosaic.exchange import load_scene, write_sam3d_example

    scene = load_scene(write_sam3d_example(tmp_path / "office", repo_data / "sam3d_objects"))
    assert {o.asset.kind for o in scene.objects} == {"mesh"}
    out = await structure_scene(scene, priors_dir=procthor_dir)
    assert out.structure is not None
    units = {u.anchor_id: u for u in out.structure.units}
    assert set(units["work_desk"].children) == {"printer", "coffee_mug"}
    assert set(units[FLOOR].children) == {"bed", "work_desk", "office_chair"}
    [c] = [c for c in out.constraints if "office_chair" in c.anchor_a.related_objects + c.anchor_b.related_objects]
    assert c.kind == "orientation"
    clauses = {c.anchor_a.anchor_id: c.anchor_a, c.anchor_b.anchor_id: c.anchor_b}
    assert set(clauses) == {FLOOR, "work_desk"}
    assert "office_chair" in clauses[FLOOR].related_objects
    assert set(clauses["work_desk"].related_objects) <= {"printer", "coffee_mug"}
    assert clauses["work_desk"] in units["work_desk"].clauses and clauses[FLOOR] in units[FLOOR].clauses

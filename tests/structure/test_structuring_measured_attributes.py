"""Structuring keeps simulation attributes the input measured (SDF masses) and estimates the rest."""

from __future__ import annotations

from pathlib import Path

from scenemosaic.exchange import load_scene, write_sam3d_example
from scenemosaic.scene import AssetRef, Pose, Room, Scene, SceneObject
from scenemosaic.structure import structure_scene


async def test_sdf_masses_survive_structuring(tmp_path: Path, repo_data: Path) -> None:
    scene = load_scene(write_sam3d_example(tmp_path, repo_data / "sam3d_objects"))
    measured = {o.id: o.sim.mass_kg for o in scene.objects}
    assert all(m is not None for m in measured.values())
    structured = await structure_scene(scene)
    for obj in structured.objects:
        assert obj.sim.mass_kg == measured[obj.id], obj.id
        assert obj.sim.source is not None and obj.sim.source.startswith("sdf:")


async def test_unmeasured_objects_get_table_estimates() -> None:
    chair = SceneObject(
        id="chair",
        category="dining_chair",
        asset=AssetRef(kind="procedural", category="dining_chair", extents=(0.45, 0.5, 0.9)),
        pose=Pose.from_yaw((1.0, 1.0, 0.0), 0.0),
    )
    structured = await structure_scene(Scene(room=Room.rectangle(0, 0, 3, 3), objects=[chair]))
    sim = structured.get("chair").sim
    assert sim.mass_kg is not None and 1.0 < sim.mass_kg < 20.0
    assert sim.source is not None and sim.source.startswith("attributes:")

"""Noisy input plus a given room: the offline run repairs it and says what it changed (issue 10, point 2)."""

from __future__ import annotations

from pathlib import Path

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import load_scene, save_scene, write_sam3d_example
from scenemosaic.scene import AssetRef, Pose, SceneObject

DATA = Path(__file__).resolve().parents[2] / "data"


def test_a_bed_in_the_wall_and_a_painting_through_the_ceiling_are_repaired(tmp_path: Path) -> None:
    source = write_sam3d_example(tmp_path / "office", DATA / "sam3d_objects")
    scene = load_scene(source)
    room = scene.room
    assert room is not None
    wall_y = max(y for _, y in room.floor)
    bed = scene.get("bed")
    x, y, z = bed.pose.position
    back = y + bed.size[1] / 2
    bed.pose = bed.pose.model_copy(update={"position": (x, y + (wall_y - back) + 0.10, z)})  # 10 cm into the wall
    scene.objects.append(
        SceneObject(
            id="painting",
            category="painting",
            asset=AssetRef(kind="procedural", category="painting", extents=(0.8, 0.04, 0.6)),
            pose=Pose.from_yaw((0.0, wall_y - 0.05, room.ceiling_height - 0.3), 0.0),  # top 0.3 m above the ceiling
        )
    )
    noisy = tmp_path / "noisy"
    save_scene(scene, noisy, base_dir=source if source.is_dir() else source.parent)

    result = generate(noisy, tmp_path / "out", GenerateConfig(model="rules"))
    structure = next(s for s in result.report["stages"] if s["name"] == "structure")
    repairs = " ".join(structure["detail"]["repairs"])
    assert "bed moved" in repairs and "inside the walls" in repairs
    assert "painting moved" in repairs and "under the ceiling" in repairs
    out = result.scene
    assert out.get("bed").aabb()[1][1] <= wall_y + 0.02
    assert out.get("painting").aabb()[1][2] <= room.ceiling_height + 0.02
    validation = result.report["validation"]
    assert not validation["out_of_bounds"]["objects"]

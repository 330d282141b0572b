"""Thin screens and soft furnishings on furniture are held in place; the ProcTHOR bedroom validates clean."""

from __future__ import annotations

from pathlib import Path

from scenemosaic import GenerateConfig, generate
from scenemosaic.scene import AssetRef, Pose, Room, Scene, SceneObject
from scenemosaic.structure import structure_scene

DATA = Path(__file__).resolve().parents[2] / "data"


def _obj(oid: str, category: str, extents: tuple[float, float, float], z: float) -> SceneObject:
    return SceneObject(
        id=oid,
        category=category,
        asset=AssetRef(kind="procedural", category=category, extents=extents),
        pose=Pose.from_yaw((2.0, 2.0, z), 0.0),
    )


async def test_a_plate_tv_and_a_pillow_on_furniture_are_fixed_a_bottle_is_not() -> None:
    scene = Scene(
        id="s",
        room=Room.rectangle(0, 0, 4, 4, ceiling_height=2.6),
        objects=[
            _obj("stand", "tv_stand", (1.4, 0.45, 0.5), 0.0),
            _obj("tv", "television", (1.0, 0.01, 0.6), 0.5),  # a 1 cm plate
        ],
    )
    out = await structure_scene(scene)
    assert out.support_of("tv").parent == "stand"  # type: ignore[union-attr]
    assert out.get("tv").sim.static and not out.get("stand").sim.static

    bed = Scene(
        id="b",
        room=Room.rectangle(0, 0, 4, 4, ceiling_height=2.6),
        objects=[
            _obj("bed", "double_bed", (1.6, 2.0, 0.5), 0.0),
            _obj("pillow", "pillow", (0.5, 0.3, 0.12), 0.5),
        ],
    )
    bed.objects.append(_obj("bottle", "bottle", (0.08, 0.08, 0.25), 0.5).model_copy(
        update={"pose": Pose.from_yaw((2.5, 2.5, 0.5), 0.0)}
    ))
    out = await structure_scene(bed)
    assert out.get("pillow").sim.static and not out.get("bottle").sim.static


def test_the_procthor_bedroom_has_nothing_tipped_or_fallen(tmp_path: Path) -> None:
    result = generate(DATA / "houses/procthor/procthor_1room_bedroom.json", tmp_path, GenerateConfig())
    validation = result.report["validation"]
    assert validation["tipped"] == [] and validation["fell"] == []


async def test_a_pillow_on_the_floor_beside_a_bed_is_put_on_the_bed() -> None:
    scene = Scene(
        id="p",
        room=Room.rectangle(0, 0, 4, 4, ceiling_height=2.6),
        objects=[
            _obj("bed", "double_bed", (1.6, 2.0, 0.5), 0.0),
            _obj("pillow", "pillow", (0.5, 0.3, 0.12), 0.0).model_copy(
                update={"pose": Pose.from_yaw((3.15, 2.0, 0.0), 0.0)}  # on the floor, just beside the bed
            ),
        ],
    )
    out = await structure_scene(scene)
    assert out.support_of("pillow").parent == "bed"  # type: ignore[union-attr]
    assert any("pillow" in n and "beside" in n for n in out.provenance.notes)

"""MJCF export: the file loads in plain mujoco and the scene stays at rest."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from scenemosaic.exchange._mjcf import export_mjcf
from scenemosaic.physics import StabilizationReport
from scenemosaic.scene import Scene


def _rest_drift(xml: Path, seconds: float = 2.0) -> tuple[float, mujoco.MjModel]:
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.xpos.copy()
    mujoco.mj_step(model, data, nstep=round(seconds / model.opt.timestep))
    return float(np.linalg.norm(data.xpos - start, axis=1).max()), model


def test_exported_room_loads_and_stays_at_rest(
    tmp_path: Path, physcene_stabilized: dict[str, tuple[Scene, StabilizationReport]]
) -> None:
    name = next(n for n in physcene_stabilized if n.startswith("LivingDiningRoom-124277"))
    scene, _ = physcene_stabilized[name]
    xml = export_mjcf(scene, tmp_path / "out")
    assert xml.name == "scene.xml" and (xml.parent / "mjcf").is_dir()
    text = xml.read_text()
    assert str(tmp_path) not in text  # relative paths only
    drift, model = _rest_drift(xml)
    assert drift < 0.01
    floor_objects = [r.child for r in scene.relations if r.parent == "floor"]
    assert sum(model.body(o).jntnum[0] for o in floor_objects) == len(floor_objects)  # free joints
    lamps = [r.child for r in scene.relations if r.parent == "ceiling"]
    assert all(model.body(o).jntnum[0] == 0 for o in lamps)  # welded


def test_exported_sam3d_office_loads_and_stays_at_rest(
    tmp_path: Path,
    sam3d_raw: tuple[Scene, dict[str, list[np.ndarray]]],
    sam3d_stabilized: tuple[Scene, StabilizationReport],
) -> None:
    _, hulls = sam3d_raw
    scene, _ = sam3d_stabilized
    xml = export_mjcf(scene, tmp_path, hulls=hulls)
    assert list((tmp_path / "mjcf").glob("*_hull_*.obj"))
    # the imported meshes are found, so every object carries its visual mesh too
    assert {p.stem for p in (tmp_path / "mjcf").glob("*_visual.obj")} == {
        f"{o.id}_visual" for o in scene.objects
    }
    drift, model = _rest_drift(xml)
    assert drift < 0.01
    mug_mass = scene.get("coffee_mug").sim.mass_kg
    assert mug_mass is not None and 0.1 < mug_mass < 1.0
    assert model.body("coffee_mug").mass[0] == np.float64(mug_mass)


def test_nan_pose_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    import math

    import pytest

    from scenemosaic.exceptions import PhysicsError
    from scenemosaic.scene import AssetRef, Pose, Room, SceneObject

    ok = SceneObject(
        id="ok",
        category="box",
        asset=AssetRef(kind="box", extents=(0.5, 0.5, 0.5)),
        pose=Pose.from_yaw((1.0, 1.0, 0.0), 0.0),
    )
    bad = ok.model_copy(
        update={"id": "bad", "pose": ok.pose.model_copy(update={"position": (math.inf, 1.0, 0.0)})}
    )
    scene = Scene(room=Room.rectangle(0, 0, 4, 4), objects=[ok, bad])
    with pytest.raises(PhysicsError, match="bad") as info:
        export_mjcf(scene, tmp_path / "out")
    assert info.value.object_ids == ["bad"]
    assert not (tmp_path / "out").exists()
    # the same scene without the bad object exports and loads
    drift, _ = _rest_drift(export_mjcf(Scene(room=scene.room, objects=[ok]), tmp_path / "good"))
    assert drift < 0.01

"""A thin object (the demo's rug) gets an explicit inertial in the MJCF export, not one MuJoCo
would infer from a near-zero mesh volume, and lies still."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import save_scene
from scenemosaic.physics import is_thin
from scenemosaic.pipeline import demo_scene


def test_the_rug_has_an_explicit_inertial_and_stays_put(tmp_path: Path) -> None:
    source = save_scene(demo_scene(), tmp_path / "input")
    result = generate(source, tmp_path / "out", GenerateConfig(evolve=False))
    rug = result.scene.get("rug")
    assert is_thin(rug)
    root = ET.parse(result.base_dir / "scene.xml").getroot()
    body = next(b for b in root.iter("body") if b.get("name") == "rug")
    inertial = body.find("inertial")
    assert inertial is not None and float(inertial.get("mass", "0")) > 0
    diag = [float(v) for v in (inertial.get("diaginertia") or inertial.get("fullinertia") or "").split()]
    assert len(diag) >= 3 and all(v > 0 for v in diag[:3])
    model = mujoco.MjModel.from_xml_path(str(result.base_dir / "scene.xml"))
    assert np.all(model.body("rug").inertia > 0)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.body("rug").xpos.copy()
    mujoco.mj_step(model, data, nstep=round(2.0 / model.opt.timestep))
    assert float(np.linalg.norm(data.body("rug").xpos - start)) < 0.01

"""A textured mesh keeps its texture through the delivered GLB (the SAM3D bed's image)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import write_sam3d_example

DATA = Path(__file__).resolve().parents[2] / "data" / "sam3d_objects"


def test_the_sam3d_bed_keeps_its_texture_in_scene_glb(tmp_path: Path) -> None:
    poses = write_sam3d_example(tmp_path / "input", DATA)
    result = generate(poses, tmp_path / "out", GenerateConfig(evolve=False))
    glb = trimesh.load(result.base_dir / "scene.glb")
    bed_id = next(o.id for o in result.scene.objects if "bed" in o.category)
    geometry = glb.geometry[glb.graph[bed_id][1]]
    material = geometry.visual.material
    image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    assert image is not None and geometry.visual.uv is not None and len(geometry.visual.uv) == len(geometry.vertices)
    original = trimesh.load(DATA / "generated_assets" / "sdf" / "king_bed_1761578419" / "king_bed.gltf", force="mesh")
    source = getattr(original.visual.material, "baseColorTexture", None) or original.visual.material.image
    assert image.size == source.size
    # the same picture (JPEG in, PNG or JPEG out): mean colours agree within a few levels
    assert np.allclose(np.asarray(image.convert("RGB")).mean(axis=(0, 1)), np.asarray(source.convert("RGB")).mean(axis=(0, 1)), atol=3)
    desk = next(o.id for o in result.scene.objects if "desk" in o.category)
    assert glb.geometry[glb.graph[desk][1]].visual.uv is not None  # every SAM3D mesh is textured

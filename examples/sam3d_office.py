"""The SAM3D office: real image-to-3D meshes (a bed, a desk, an office chair, a printer, a mug)
placed by a pose file, structured, stabilized and evolved.

Run: ``python examples/sam3d_office.py [OUT_DIR]``. The meshes ship in ``data/sam3d_objects``
(see its licence file); CoACD decomposes them once, then the hull cache answers.
"""

# %%
from __future__ import annotations

import sys
from pathlib import Path

import scenemosaic as sm
from scenemosaic.exchange import write_sam3d_example

DATA = Path(__file__).resolve().parents[1] / "data" / "sam3d_objects"
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out/sam3d_office")

# %%
poses = write_sam3d_example(out / "input", DATA)  # poses.json + copies of the meshes beside it
scene = sm.load_scene(poses)
print(f"{len(scene.objects)} objects read from {poses.name}: {', '.join(o.category for o in scene.objects)}")

# %%
result = sm.generate(poses, out / "run", sm.GenerateConfig(overwrite=True))
print(sm.format_tree(result.scene))
mug = next(o for o in result.scene.objects if "mug" in o.category)
print(f"status {result.status}; the mug rests at z = {mug.pose.position[2]:.3f} m")

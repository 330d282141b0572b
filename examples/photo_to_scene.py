"""From a photograph to a simulation-ready scene, offline: boxes in, a stabilized room and variants out.

The photograph is a render of the demo room shipped in ``data/images/demo_bedroom`` with its
COCO boxes; any detector's COCO output would do. GrabCut cuts the objects out, the box lifter
places them in 3D (single-view metrology with category sizes), and the pipeline takes it from
there. With a vision model, drop ``detections`` and pass ``model="openai:<model>@<url>"``.

Run: ``python examples/photo_to_scene.py [OUT_DIR]``
"""

# %%
from __future__ import annotations

import json
import sys
from pathlib import Path

import scenemosaic as sm
from scenemosaic.perception import load_image, read_detections

PHOTO = Path(__file__).resolve().parents[1] / "data" / "images" / "demo_bedroom"
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out/photo_to_scene")

# %%
image = load_image(PHOTO / "photo.png")
boxes = read_detections(PHOTO / "boxes.json", image.width, image.height, image_name="photo.png")
print(f"{image.width}x{image.height} photograph, {len(boxes)} boxed objects: {', '.join(b.id for b in boxes)}")

# %%
config = sm.GenerateConfig(
    detections=PHOTO / "boxes.json", segmenter="grabcut", reconstructor="box-lifter", variants=2, overwrite=True
)
result = sm.generate(PHOTO / "photo.png", out, config)
seen = result.report["stages"][0]["detail"]["perception"]
print(
    f"camera {seen['camera_height_m']} m above the floor, pitched {seen['camera_pitch_deg']} degrees down; "
    f"room turned {seen.get('room_direction_deg')} degrees to the picture"
)
print(json.dumps(seen["placements"]))

# %%
print(sm.format_tree(result.scene))
print(f"status {result.status}, {len(result.variants)} variants; metrics of the base: {result.metrics and result.metrics['base']}")

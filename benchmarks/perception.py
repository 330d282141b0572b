"""The image front end on the shipped renders (``data/images/``): time and accuracy.

Per fixture: the time to segment every boxed object with GrabCut, the box lifter's fit, and the
lift error against the truth (bottom centres, XY, the true camera pose); then one whole
``generate photo.png --detections ... --variants 2`` of the demo render. Last line: one JSON
object of named figures.

Run: ``MUJOCO_GL=egl python benchmarks/perception.py``
"""

from __future__ import annotations

import asyncio
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from scenemosaic.models import RulesModel
from scenemosaic.perception import BoxLifter, GrabCutSegmenter, load_image, perceive, read_detections
from scenemosaic.pipeline import GenerateConfig, generate

DATA = Path(__file__).resolve().parents[1] / "data" / "images"


def main() -> None:
    figures: dict[str, float | int | str] = {}
    errors_all: list[float] = []
    for folder in sorted(p for p in DATA.iterdir() if (p / "truth.json").is_file()):
        name = folder.name
        truth = json.loads((folder / "truth.json").read_text())
        image = load_image(folder / "photo.png")
        boxes = read_detections(folder / "boxes.json", image.width, image.height, image_name="photo.png")
        seg = GrabCutSegmenter()
        t0 = time.perf_counter()
        for d in boxes:
            seg.segment(image, d.label, d.box)
        figures[f"{name}_grabcut_s_per_object"] = round((time.perf_counter() - t0) / len(boxes), 4)
        result = asyncio.run(
            perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="box", reconstructor=BoxLifter())
        )
        t0 = time.perf_counter()  # again, now that the size priors are loaded
        asyncio.run(perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="box", reconstructor="box-lifter"))
        figures[f"{name}_perceive_box_lifter_s"] = round(time.perf_counter() - t0, 3)
        pose = np.array(truth["camera"]["world_from_camera"]).reshape(4, 4)
        true_pos = {o["id"]: np.array(o["position"][:2]) for o in truth["objects"]}
        errs = [float(np.linalg.norm((pose[:3, :3] @ o.position + pose[:3, 3])[:2] - true_pos[o.id])) for o in result.reconstruction.objects]
        errors_all += errs
        figures[f"{name}_objects"] = len(errs)
        figures[f"{name}_lift_error_median_m"] = round(float(np.median(errs)), 3)
        figures[f"{name}_lift_error_max_m"] = round(float(np.max(errs)), 3)
        figures[f"{name}_camera_height_error_m"] = round(abs(float(result.report["camera_height_m"]) - truth["camera"]["position"][2]), 3)
    figures["lift_error_median_m"] = round(float(np.median(errors_all)), 3)
    figures["lift_error_p90_m"] = round(float(np.quantile(errors_all, 0.9)), 3)
    demo = DATA / "demo_bedroom"
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        generate(demo / "photo.png", Path(tmp) / "run", GenerateConfig(detections=demo / "boxes.json", segmenter="grabcut", reconstructor="box-lifter", variants=2))
        figures["generate_demo_photo_variants2_s"] = round(time.perf_counter() - t0, 2)
    print(json.dumps(figures, sort_keys=True))


if __name__ == "__main__":
    main()

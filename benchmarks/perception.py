"""The image front end on the shipped renders (``data/images/``): time and accuracy.

Per fixture: the time to segment every boxed object with GrabCut, the box lifter's fit, and how
close it lands with the true boxes (``score_against_truth``: position and heading per object,
camera height and tilt), per render and pooled (all, the varied renders, the renders used in
tuning and those held out of it, and the fresh renders made after the tuning), with markdown
tables; all renders again with the true camera height given (``--camera-height``) and with the
true sizes as the size priors' means (what the catalogue's sizes cost); then one whole
``generate photo.png --detections ... --variants 2`` of the demo render. Last line: one JSON
object of named figures.

Run: ``MUJOCO_GL=egl python benchmarks/perception.py``
"""

from __future__ import annotations

import asyncio
import importlib.util
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from scenemosaic.models import RulesModel
from scenemosaic.perception import (
    BoxLifter,
    GrabCutSegmenter,
    PerceptionResult,
    TruthScore,
    load_image,
    perceive,
    read_detections,
    score_against_truth,
)
from scenemosaic.pipeline import GenerateConfig, generate

DATA = Path(__file__).resolve().parents[1] / "data" / "images"


HELD_OUT = ("v_33922_", "v_1344_", "v_124277_", "v_13536_")
"""Renders kept out of the lifter's tuning (issue 27): their figures are reported apart."""


def _fresh() -> tuple[str, ...]:
    """The renders made once the lifter's rules were settled (``make_fixtures.FRESH``), never tuned on."""
    spec = importlib.util.spec_from_file_location("make_fixtures", DATA / "make_fixtures.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return tuple(module.FRESH)


def _pooled(scores: list[TruthScore]) -> dict[str, float | int]:
    pooled = TruthScore([o for s in scores for o in s.objects], 0.0, 0.0, 0.0).figures()
    lamps = [o.position_error_m for s in scores for o in s.objects if o.placement == "ceiling"]
    return {
        **{k: v for k, v in pooled.items() if not k.startswith(("camera", "tilt"))},
        "views": len(scores),
        "camera_height_abs_error_max_m": round(max(abs(s.camera_height_error_m) for s in scores), 3),
        "camera_height_within_0_1m": round(float(np.mean([abs(s.camera_height_error_m) <= 0.1 for s in scores])), 3),
        "tilt_max_deg": round(max(s.tilt_deg for s in scores), 2),
        "tilt_within_2deg": round(float(np.mean([s.tilt_deg <= 2.0 for s in scores])), 3),
        "ceiling_objects": len(lamps),
        "ceiling_within_0_5m": round(float(np.mean(np.array(lamps) <= 0.5)), 3) if lamps else math.nan,
    }


def score_fixture(folder: Path, reconstructor: object = "box-lifter", *, given_height: bool = False) -> tuple[TruthScore, PerceptionResult]:
    """One render through the offline path with its true boxes (the box as the mask), scored;
    ``given_height``: with the true camera height given (``--camera-height``)."""
    truth = json.loads((folder / "truth.json").read_text())
    height = float(truth["camera"]["position"][2]) if given_height else None
    result = asyncio.run(
        perceive(folder / "photo.png", RulesModel(), detections=folder / "boxes.json", segmenter="box", reconstructor=reconstructor, camera_height_m=height)  # type: ignore[arg-type]
    )
    boxes = {o.id: o.box for o in result.inventory}
    return score_against_truth(result.reconstruction, truth, float(result.report["camera_height_m"]), boxes), result


def _with_true_sizes(folder: Path) -> TruthScore:
    """One render scored with each category's true size (the mean over its objects in the render)
    as the size prior's mean, the spread unchanged: what the catalogue's sizes cost, an upper
    bound no photograph gives (issue 27's scale discussion in ``docs/perception.md``)."""
    from unittest import mock

    from scenemosaic.perception import _lift
    from scenemosaic.scene import normalize_category

    truth = json.loads((folder / "truth.json").read_text())
    sizes: dict[str, list[list[float]]] = {}
    for o in truth["objects"]:
        sizes.setdefault(normalize_category(o["category"]), []).append(o["extents"])
    catalogue = _lift.size_prior

    def true_prior(category: str) -> tuple[tuple[float, float, float], bool]:
        found = sizes.get(normalize_category(category))
        if found is None:
            return catalogue(category)
        w, d, h = np.mean(np.asarray(found), axis=0)
        return (float(w), float(d), float(h)), True

    with mock.patch.object(_lift, "size_prior", true_prior):
        return score_fixture(folder)[0]


def main() -> None:
    figures: dict[str, float | int | str] = {}
    errors_all: list[float] = []
    scores: dict[str, TruthScore] = {}
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
        score_fixture(folder, BoxLifter())  # loads the size priors
        t0 = time.perf_counter()
        score, result = score_fixture(folder)
        figures[f"{name}_perceive_box_lifter_s"] = round(time.perf_counter() - t0, 3)
        scores[name] = score
        errors_all += [o.position_error_m for o in score.objects]
        for key, value in score.figures().items():
            figures[f"{name}_{key}"] = value
        cam = truth["camera"]
        print(
            f"{name}: {image.width}x{image.height}, hfov {cam['hfov_deg']:.1f}, camera {cam['position'][2]:.2f} m "
            f"pitch {cam['pitch_deg']:.0f} -> {score.camera_height_m:.3f} m (fit sd {result.report.get('camera_height_sd_m')}), "
            f"tilt {score.tilt_deg:.2f} deg"
        )
        for o in score.objects:
            head = "-" if o.heading_error_deg is None else f"{o.heading_error_deg:5.1f}"
            reason = result.report.get("headings", {}).get(o.id, "")
            print(f"   {o.id:24s} {o.category:18s} {o.placement:8s} {'cut' if o.cut else '   '} pos {o.position_error_m:5.2f} m  head {head}  {reason}")
    figures["lift_error_median_m"] = round(float(np.median(errors_all)), 3)
    figures["lift_error_p90_m"] = round(float(np.quantile(errors_all, 0.9)), 3)
    held = [s for n, s in scores.items() if n.startswith(HELD_OUT)]
    tuned = [s for n, s in scores.items() if not n.startswith(HELD_OUT)]
    varied = [s for n, s in scores.items() if n.startswith("v_")]
    fresh_names = _fresh()
    fresh = [s for n, s in scores.items() if n in fresh_names]
    groups: list[tuple[str, list[TruthScore]]] = [("all", list(scores.values())), ("varied", varied), ("tuned", tuned), ("held_out", held), ("fresh", fresh)]
    for group, members in groups:
        for key, value in _pooled(members).items():
            figures[f"pooled_{group}_{key}"] = value
    print("\n| render | objects | position median / p90 (m) | within 0.5 m | headed | heading median (deg) | within 20 deg | camera height error (m) | tilt (deg) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, score in scores.items():
        f = score.figures()
        print(
            f"| {name} | {f['objects']} | {f['position_median_m']:.2f} / {f['position_p90_m']:.2f} | {f['position_within_0_5m']:.0%} | "
            f"{f['headed_objects']} | {f['heading_median_deg']:.1f} | {f['heading_within_20deg']:.0%} | {f['camera_height_error_m']:+.3f} | {f['tilt_deg']:.2f} |"
        )
    given = [score_fixture(DATA / name, given_height=True)[0] for name in scores]
    for key, value in _pooled(given).items():
        figures[f"pooled_height_given_{key}"] = value
    true_sizes = [_with_true_sizes(DATA / name) for name in scores]
    for key, value in _pooled(true_sizes).items():
        figures[f"pooled_true_sizes_{key}"] = value
    groups += [("all, camera height given", given), ("all, true sizes as the priors' means", true_sizes)]
    print("\n| renders | objects | position median (m) | within 0.5 m | heading within 20 deg | camera height within 0.1 m (max error) | tilt within 2 deg (max) | ceiling lamps within 0.5 m |")
    print("|---|---|---|---|---|---|---|---|")
    for group, members in groups:
        f = _pooled(members)
        print(
            f"| {group} ({f['views']}) | {f['objects']} | {f['position_median_m']:.3f} | {f['position_within_0_5m']:.1%} | "
            f"{f['heading_within_20deg']:.1%} of {f['headed_objects']} | {f['camera_height_within_0_1m']:.0%} ({f['camera_height_abs_error_max_m']:.2f} m) | "
            f"{f['tilt_within_2deg']:.0%} ({f['tilt_max_deg']:.1f}) | {f['ceiling_within_0_5m']:.0%} of {f['ceiling_objects']} |"
        )
    demo = DATA / "demo_bedroom"
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        generate(demo / "photo.png", Path(tmp) / "run", GenerateConfig(detections=demo / "boxes.json", segmenter="grabcut", reconstructor="box-lifter", variants=2))
        figures["generate_demo_photo_variants2_s"] = round(time.perf_counter() - t0, 2)
    print(json.dumps(figures, sort_keys=True))


if __name__ == "__main__":
    main()

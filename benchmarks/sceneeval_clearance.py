"""SceneEval's own Opening Clearance on the sceneState of every world of one or more runs (issue 53).

Each delivered world (``base/`` and each ``variant_<i>/``) holds ``sceneeval/scene_base.json`` and its
GLB assets (``sceneeval/assets/``); this script hands them to SceneEval's ``OpeningClearanceMetric``
(its own code, with the settings of its ``configs/metrics.yaml``) and compares each variant with its
base: which door and window sides a variant occludes that its base left clear, and whether any
room-door leaf is listed among the objects (it must not be: a door rides on its hole).

SceneEval is not a dependency of scenemosaic: it needs Blender as a Python module. Run this script
with a Python that has SceneEval's requirements (``bpy`` 4.2, trimesh, shapely, omegaconf, ...) and
point ``SCENEEVAL_DIR`` at a SceneEval checkout (github.com/3dlg-hcvc/SceneEval; measured at commit
116881e)::

    .venv/bin/scenemosaic generate data/houses/procthor/procthor_4room.json --out runs/h4 --variants 5 --seed 0
    SCENEEVAL_DIR=/path/to/SceneEval /path/to/bpy-venv/bin/python benchmarks/sceneeval_clearance.py runs/h4

SceneEval's ``vlm`` package builds an OpenAI client when imported; the script sets a placeholder key
and a local base URL (the client is never called). One line per world, then one JSON line:
``worlds``, ``door_sides`` / ``door_sides_occluded`` and ``window_sides`` / ``window_sides_occluded``
over every world, ``variant_sides_newly_occluded`` (sides a variant occludes that its base left
clear), ``leaves_as_objects`` and ``seconds``.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENAI_API_KEY", "not-used")
os.environ.setdefault("OPENAI_BASE_URL", "http://127.0.0.1:9")


def _sceneeval() -> Path:
    root = os.environ.get("SCENEEVAL_DIR")
    if not root or not (Path(root) / "metrics" / "opening_clearance.py").is_file():
        sys.exit("set SCENEEVAL_DIR to a SceneEval checkout (github.com/3dlg-hcvc/SceneEval)")
    return Path(root)


def _measure(world: Path, scratch: Path) -> dict[str, Any]:
    """SceneEval's Opening Clearance of one delivered world: its door and window sides, which are
    occluded and by what (our object ids), and the object ids it was given."""
    from assets import Retriever
    from assets.base import AssetInfo, BaseAssetDataset, DatasetConfig
    from assets.registry import register_dataset
    from metrics.opening_clearance import OpeningClearanceMetric, OpeningClearanceMetricConfig
    from scenes import BlenderConfig, Scene, SceneConfig, SceneState, TrimeshConfig
    from spatial import BoundingBoxConfig

    @register_dataset("scenemosaic")
    class _Ours(BaseAssetDataset):  # our export's assets: sceneeval/assets/<asset id>.glb
        def __init__(self, config: DatasetConfig) -> None:
            self.root = Path(config.dataset_root_path)
            meta = Path(config.dataset_metadata_path)
            self.meta = json.loads(meta.read_text(encoding="utf-8")) if meta.is_file() else {}

        def get_asset_info(self, asset_id: str) -> AssetInfo:
            what = str(self.meta.get(asset_id, {}).get("category", asset_id))
            return AssetInfo(asset_id=asset_id, file_path=self.root / f"{asset_id}.glb", description=what, extra_rotation_transform=None)

    folder = world / "sceneeval"
    state = folder / "scene_base.json"
    raw = json.loads(state.read_text(encoding="utf-8"))
    retriever = Retriever({"scenemosaic": DatasetConfig(
        asset_id_prefix="scenemosaic", dataset_root_path=str(folder / "assets"),
        dataset_metadata_path=str(folder / "assets" / "metadata.json"),
    )})  # fmt: skip
    out = scratch / f"{world.parent.name}_{world.name}"
    out.mkdir(parents=True, exist_ok=True)
    scene = Scene(retriever, SceneState(state), SceneConfig(), BlenderConfig(suppress_warning=True), TrimeshConfig(), out)
    config = OpeningClearanceMetricConfig(bounding_box=BoundingBoxConfig(
        epsilon=1e-6, sample_points_per_unit_volume=5000, min_num_sample_points=64, presample_points=False,
    ))  # fmt: skip
    result = OpeningClearanceMetric(scene, out, config).run()
    ours = {f"idx{o['index']}_{o['modelId']}": o["id"] for o in raw["scene"]["object"]}
    found: dict[str, Any] = {"objects": [o["id"] for o in raw["scene"]["object"]]}
    for kind in ("door", "window"):
        sides = [(oid, side) for oid, listed in result.data[f"{kind}_clearance"].items() for side in listed]
        found[kind] = {
            f"{oid}@{','.join(f'{x:.2f}' for x in side['direction'])}": sorted(
                ours.get(k, k) for k in side["occlusion_info"]["object_occlusions"]
            )
            for oid, side in sides
        }
    return found


def main() -> None:
    runs = [Path(p) for p in sys.argv[1:]]
    if not runs:
        sys.exit(__doc__)
    sys.path.insert(0, str(_sceneeval()))
    started = time.perf_counter()
    totals = {"worlds": 0, "door_sides": 0, "door_sides_occluded": 0, "window_sides": 0, "window_sides_occluded": 0}
    newly, leaves = 0, 0
    with tempfile.TemporaryDirectory() as scratch:
        for run in runs:
            worlds = sorted((p for p in run.iterdir() if (p / "sceneeval" / "scene_base.json").is_file()), key=lambda p: (p.name != "base", p.name))
            measured = {w.name: _measure(w, Path(scratch)) for w in worlds}
            base = measured.get("base")
            for name, found in measured.items():
                totals["worlds"] += 1
                leaves += sum(o.startswith("room_door") for o in found["objects"])
                new = []
                for kind in ("door", "window"):
                    totals[f"{kind}_sides"] += len(found[kind])
                    totals[f"{kind}_sides_occluded"] += sum(bool(v) for v in found[kind].values())
                    if base is not None and name != "base":
                        new += [f"{side} by {', '.join(by)}" for side, by in found[kind].items() if by and not base[kind].get(side)]
                newly += len(new)
                print(f"{run.name}/{name}: doors {sum(bool(v) for v in found['door'].values())}/{len(found['door'])} occluded, "
                      f"windows {sum(bool(v) for v in found['window'].values())}/{len(found['window'])}; new: {new}", flush=True)
    print(json.dumps({**totals, "variant_sides_newly_occluded": newly, "leaves_as_objects": leaves, "seconds": round(time.perf_counter() - started, 1)}))


if __name__ == "__main__":
    main()

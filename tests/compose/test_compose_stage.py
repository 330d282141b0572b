"""``generate --variants m``: m diverse, valid whole-scene variants beside the base."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.compose import OCCUPANCY_GRID, OCCUPANCY_WEIGHT, Arrangement, novelty_distance
from scenemosaic.exchange import read_scene
from scenemosaic.physics import check_collisions, check_out_of_bounds
from scenemosaic.scene import FloorRaster, Scene, convex_hull_2d, is_thin

LIVING = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene" / "LivingDiningRoom-124277_livingroom.json"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("composed")
    generate(LIVING, out, GenerateConfig(variants=3, seed=2))
    return out


def _occupancy(scene: Scene) -> np.ndarray:
    """The selection's footprint raster: non-thin boxes, OCCUPANCY_GRID cells along the floor."""
    assert scene.room is not None
    floor = np.asarray(scene.room.floor)
    raster = FloorRaster(floor, cell=float(np.ptp(floor, axis=0).max()) / OCCUPANCY_GRID)
    mask = np.zeros(raster.shape, dtype=bool)
    for o in scene.objects:
        if not is_thin(o):
            mask |= raster.mask(convex_hull_2d(o.corners()[:, :2]))
    return mask


def test_variants_are_written_like_the_base_and_are_valid(run: Path) -> None:
    report = json.loads((run / "report.json").read_text())
    assert report["status"] == "ok" and report["variants_written"] == 3
    base_files = sorted(p.relative_to(run / "base").as_posix() for p in (run / "base").rglob("*") if p.is_file() and "assets" not in p.parts)
    for i in (1, 2, 3):
        folder = run / f"variant_{i}"
        files = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() and "assets" not in p.parts)
        assert files == base_files
        scene = read_scene(folder)
        assert check_collisions(scene, folder).pairs == [] and check_out_of_bounds(scene).objects == []


def test_the_variants_differ_from_the_base_and_each_other_as_selected(run: Path) -> None:
    report = json.loads((run / "report.json").read_text())
    compose = next(s for s in report["stages"] if s["name"] == "compose")["detail"]
    scenes = [read_scene(run / "base"), *(read_scene(run / f"variant_{i}") for i in (1, 2, 3))]
    ids = [o.id for o in scenes[0].objects]
    arr = [Arrangement.of(s, ids) for s in scenes]
    occ = [_occupancy(s) for s in scenes]

    def footprint(a: np.ndarray, b: np.ndarray) -> float:
        return OCCUPANCY_WEIGHT * (1.0 - float((a & b).sum()) / float((a | b).sum()))

    # each pick's minimum distance to what came before (N and the footprint term), recomputed
    # from the written files
    for k in (1, 2, 3):
        d = min(novelty_distance(arr[j], arr[k]) + footprint(occ[j], occ[k]) for j in range(k))
        assert d == pytest.approx(compose["min_distances"][k - 1], abs=1e-3)
        assert d > 0.05
    assert compose["min_distances"] == sorted(compose["min_distances"], reverse=True)
    assert len({json.dumps(p, sort_keys=True) for p in compose["selected"]}) == 3
    assert compose["pool_size"] >= 4 and compose["considered"] == compose["pool_size"] - 1


def test_no_variants_skips_the_stage(tmp_path: Path) -> None:
    result = generate(LIVING, tmp_path, GenerateConfig())
    compose = next(s for s in result.report["stages"] if s["name"] == "compose")
    assert compose["status"] == "skipped" and not list(tmp_path.glob("variant_*"))


def test_evaluate_prints_the_metrics_of_an_output_folder(run: Path) -> None:
    from typer.testing import CliRunner

    from scenemosaic.cli import app

    result = CliRunner().invoke(app, ["evaluate", str(run)])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert set(data["base"]) == {"COL", "OOB", "NAV", "PLAUS", "PARTS", "parts_blocked", "windows_blocked", "screens_behind"}
    assert len(data["variants"]) == 3
    assert data["diversity"]["pairs"] == 3 and data["semantic_judge"]["POS"] is None
    report = json.loads((run / "report.json").read_text())
    assert data["variants"] == report["metrics"]["variants"]  # the same figures generate wrote
    assert (run / "contact_sheet.png").is_file()

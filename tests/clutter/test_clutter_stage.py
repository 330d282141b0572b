"""The clutter stage through ``generate``: a filled room with variants whose clutter differs, and
the settings' checks."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.pipeline import HOUSE_STAGE_NAMES, STAGES, SettingsError, plan
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, load_priors

BEDROOM = "Bedroom-33922_bedroom.json"
FOUR_ROOMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_4room.json"


@pytest.fixture(scope="module")
def bedroom(tmp_path_factory: pytest.TempPathFactory, repo_data: Path) -> Path:
    out = tmp_path_factory.mktemp("bedroom_fill")
    generate(repo_data / "layouts" / "physcene" / BEDROOM, out, GenerateConfig(clutter="fill", variants=2))
    return out


def _scene(folder: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((folder / "scene.json").read_text())
    return data


def _placements(data: dict[str, Any]) -> dict[str, str]:
    small = set(data["metadata"]["clutter"]["objects"])
    return {
        r["child"]: r["parent"]
        for r in data["relations"]
        if r["kind"] in ("attach", "contain") and r["child"] in small
    }


def test_the_stage_runs_between_compose_and_validate_only_when_asked(bedroom: Path) -> None:
    assert plan(bedroom, GenerateConfig()).stages is STAGES
    names = plan(bedroom, GenerateConfig(clutter="fill")).names
    assert names[names.index("compose") + 1 : names.index("compose") + 3] == ("clutter", "validate")
    house = plan(FOUR_ROOMS, GenerateConfig(clutter="fill"))
    assert house.house and house.names == HOUSE_STAGE_NAMES
    assert [s.name for s in house.room_stages][-2:] == ["compose", "clutter"]
    assert [s.name for s in plan(FOUR_ROOMS, GenerateConfig()).room_stages][-1] == "compose"


def test_variants_place_the_small_objects_on_other_receptacles(bedroom: Path) -> None:
    report = json.loads((bedroom / "report.json").read_text())
    detail = next(s for s in report["stages"] if s["name"] == "clutter")["detail"]
    assert detail["added"] >= 3 * 6
    assert detail["div_small"]["min_receptacle_changed"] >= 0.3
    scenes = [_scene(bedroom / "base"), _scene(bedroom / "variant_1"), _scene(bedroom / "variant_2")]
    for a, b in itertools.combinations(scenes, 2):
        pa, pb = _placements(a), _placements(b)
        shared = set(pa) & set(pb)
        assert len(shared) >= 5
        assert sum(pa[o] != pb[o] for o in shared) >= 0.3 * len(shared)


def test_every_variant_is_valid_and_its_placements_allowed(bedroom: Path) -> None:
    report = json.loads((bedroom / "report.json").read_text())
    assert report["status"] == "ok", report.get("warnings")
    for row in [report["metrics"]["base"], *report["metrics"]["variants"]]:
        assert row["COL"] == 0.0 and row["OOB"] == 0.0 and row["NAV"] >= 0.99
    receptacles = json.loads((PROCTHOR_PRIORS_DIR / "receptacles.json").read_text())
    types = load_priors()
    for folder in ("variant_1", "variant_2"):
        data = _scene(bedroom / folder)
        category = {o["id"]: o["category"] for o in data["objects"]}
        for child, parent in _placements(data).items():
            child_type, parent_type = types.type_of(category[child]), types.type_of(category[parent])
            assert receptacles[str(parent_type)].get(str(child_type), {}).get("count", 0) > 0, (
                folder,
                child,
                parent,
            )


def test_every_variant_rests_in_plain_mujoco(bedroom: Path) -> None:
    for folder in ("variant_1", "variant_2"):
        model = mujoco.MjModel.from_xml_path(str(bedroom / folder / "scene.xml"))
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        free = [
            int(model.jnt_bodyid[j])
            for j in range(model.njnt)
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
        ]
        start = {b: data.xpos[b].copy() for b in free}
        mujoco.mj_step(model, data, nstep=round(2.0 / model.opt.timestep))
        resting = sum(float(np.linalg.norm(data.xpos[b] - start[b])) < 0.01 for b in free)
        assert resting >= 0.99 * len(free), folder


@pytest.mark.parametrize(
    ("settings", "field"),
    [
        ({"clutter": "vary"}, "clutter"),  # vary changes variants: none asked for
        ({"clutter": "fill", "clutter_density": 0}, "clutter_density"),
        ({"clutter": "fill", "clutter_density": 41.0}, "clutter_density"),
        ({"clutter": "heaps"}, "clutter"),
    ],
)
def test_bad_clutter_settings_are_refused(settings: dict[str, Any], field: str) -> None:
    with pytest.raises(SettingsError) as info:
        GenerateConfig(**settings)
    assert field in [f for f, _ in info.value.problems]

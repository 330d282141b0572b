"""The 22-object test bedroom and the SAM3D office, generated with five variants, judged from the
output files as a person would (``tests/plausibility_checks.py``, code apart from the critic's):
seats square to their side, the office chair at its desk within 10 degrees, lamps over their
group, a sofa facing its TV, RelKeep of every kind at least 0.99. The shipped PhyScene rooms get
the same checks in ``tests/evolve/test_physcene_evolution.py``."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.exchange import write_sam3d_example
from scenemosaic.metrics import seat_checks, seat_pairs
from tests.conftest import REPO_ROOT, SAM3D_DIR
from tests.plausibility_checks import delivered, lamp_problems, seat_problems, sofa_tv_problems


def _judge(out: Path) -> None:
    result_report = (out / "report.json").read_text()
    import json

    report = json.loads(result_report)
    kinds = report["metrics"]["RelKeep_by_kind"]
    assert all(v is None or v >= 0.99 for v in kinds.values()), kinds
    base, variants = delivered(out)
    assert len(variants) >= 4
    assert seat_problems(base, [base, *variants]) == []
    assert lamp_problems(base, variants) == []
    assert sofa_tv_problems(base, variants) == []


@pytest.mark.long
def test_the_test_bedroom_variants_are_arranged_as_a_person_would(tmp_path: Path) -> None:
    generate(REPO_ROOT / "tests" / "fixtures" / "bedroom_22.json", tmp_path, GenerateConfig(variants=5))
    _judge(tmp_path)


@pytest.mark.long
def test_the_office_chair_stays_at_its_desk(tmp_path: Path) -> None:
    source = write_sam3d_example(tmp_path / "office", SAM3D_DIR)
    out = tmp_path / "out"
    generate(source, out, GenerateConfig(variants=5))
    _judge(out)
    base, variants = delivered(out)
    pairs = seat_pairs(base)
    chairs = [k for k, t in pairs.items() if "desk" in t]
    assert chairs, pairs
    for scene in [base, *variants]:
        for c in seat_checks(scene, {k: pairs[k] for k in chairs}):
            assert c.off_deg <= 10.0 and c.side == "front" and c.on_side, c

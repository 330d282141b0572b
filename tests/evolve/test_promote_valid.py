"""Rules met, not reported: a unit whose refined original still breaks a rule takes as its base
the valid variant closest to it (``UnitEvolution.promote_valid``), and composition keeps that
base first and drops the broken layout."""

from __future__ import annotations

from scenemosaic.compose import kept_layouts
from scenemosaic.evolve import EvolutionReport, LayoutResult, UnitEvolution
from scenemosaic.evolve._analysis import PhysicalCheck
from scenemosaic.scene import Pose

CLEAN = PhysicalCheck((), ())


def _layout(layout_id: str, xs: dict[str, float], violations: list[str] | None = None, check: PhysicalCheck | None = CLEAN) -> LayoutResult:
    poses = {k: Pose.from_yaw((x, 0.0, 0.0), 0.0) for k, x in xs.items()}
    return LayoutResult("floor", layout_id, local_poses=poses, check=check, violations=violations or [])


def test_the_valid_variant_closest_to_a_broken_original_becomes_the_base() -> None:
    broken = _layout("original", {"chair": 0.0, "table": 1.0}, ["the long sides of table hold 1 and 3 seats"])
    far = _layout("plan_1", {"chair": 3.0, "table": 4.0})
    near = _layout("seated_table", {"chair": 0.4, "table": 1.0})
    colliding = _layout("mirrored_lr", {"chair": 0.1, "table": 1.0}, check=PhysicalCheck((), ("chair",)))
    ev = UnitEvolution("floor", broken, [far, near, colliding], archetypes_asked=True)
    assert ev.promote_valid()
    assert ev.original is near and ev.promoted_from == "original"
    assert ev.variants[0] is broken and {v.layout_id for v in ev.variants} == {"original", "plan_1", "mirrored_lr"}
    kept, dropped = kept_layouts(EvolutionReport(units=[ev]))
    assert kept["floor"].layout_ids[0] == "seated_table"  # the base composition builds on
    assert "original" not in kept["floor"].layout_ids and any(d.startswith("floor/original") for d in dropped)


def test_nothing_is_promoted_when_the_original_keeps_the_rules_or_no_variant_does() -> None:
    fine = UnitEvolution("floor", _layout("original", {"chair": 0.0}), [_layout("plan_1", {"chair": 2.0})])
    assert not fine.promote_valid() and fine.original.layout_id == "original"
    broken = _layout("original", {"chair": 0.0}, ["chair does not face table"])
    alone = UnitEvolution("floor", broken, [_layout("plan_1", {"chair": 2.0}, ["chair does not face table"])])
    assert not alone.promote_valid() and alone.original is broken and alone.promoted_from is None

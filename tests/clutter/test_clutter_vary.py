"""``vary``: seeded passes move small objects between receptacles the priors allow, within the
source's counts, swap assets for similar ones, and rest; the novelty distance sees it."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest

from scenemosaic import GenerateConfig, generate
from scenemosaic.clutter import (
    SWAP_SIZE_RATIO,
    ClutterPriors,
    ClutterReport,
    clutter_distance,
    fill_scene,
    load_clutter_priors,
    motions_over,
    receptacle_surfaces,
    remove_objects,
    resting_place,
    small_objects,
    vary_scene,
)
from scenemosaic.clutter._fill import _off_surface
from scenemosaic.compose import Arrangement, novelty_distance, novelty_with_clutter
from scenemosaic.exchange import read_scene
from scenemosaic.physics import object_shape
from scenemosaic.pipeline._clutter import vary_repeated_rooms
from scenemosaic.scene import PROCTHOR_PRIORS_DIR, ConstraintClause, CrossUnitConstraint, Scene, load_priors

BEDROOM = "Bedroom-33922_bedroom.json"


@pytest.fixture(scope="module")
def priors() -> ClutterPriors:
    return load_clutter_priors()


@pytest.fixture(scope="module")
def filled(tmp_path_factory: pytest.TempPathFactory, repo_data: Path, priors: ClutterPriors) -> Scene:
    """The shipped bedroom as ``generate`` delivers it, then filled (seed 0)."""
    out = tmp_path_factory.mktemp("bedroom")
    generate(repo_data / "layouts" / "physcene" / BEDROOM, out, GenerateConfig())
    scene, report = fill_scene(read_scene(out / "base"), priors=priors, seed=0)
    assert report.added_count >= 10
    return scene


@pytest.fixture(scope="module")
def passes(filled: Scene, priors: ClutterPriors) -> list[tuple[Scene, ClutterReport]]:
    return [vary_scene(filled, priors=priors, seed=s) for s in (1, 2, 3)]


@pytest.fixture(scope="module")
def varied(passes: list[tuple[Scene, ClutterReport]]) -> list[Scene]:
    return [scene for scene, _ in passes]


def _parent(scene: Scene, oid: str) -> str:
    rel = scene.support_of(oid)
    assert rel is not None, oid
    return rel.parent


def test_each_pair_of_varied_scenes_puts_a_third_of_the_small_objects_elsewhere(
    filled: Scene, varied: list[Scene], priors: ClutterPriors
) -> None:
    for a, b in itertools.combinations([filled, *varied], 2):
        shared = [oid for oid in small_objects(a, priors) if oid in {o.id for o in b.objects}]
        assert len(shared) >= 5
        other = sum(_parent(a, oid) != _parent(b, oid) for oid in shared)
        assert other >= 0.3 * len(shared), (other, len(shared))


def test_every_small_object_stays_on_a_receptacle_its_type_may_use(varied: list[Scene]) -> None:
    receptacles = json.loads((PROCTHOR_PRIORS_DIR / "receptacles.json").read_text())
    types = load_priors()
    for scene in varied:
        for oid in small_objects(scene, load_clutter_priors()):
            child = types.type_of(scene.get(oid).category)
            parent = types.type_of(scene.get(_parent(scene, oid)).category)
            assert child is not None and parent in receptacles
            assert receptacles[parent].get(child, {}).get("count", 0) > 0, (oid, child, parent)


def test_counts_change_within_the_source_range_and_nothing_is_lost_silently(
    filled: Scene, passes: list[tuple[Scene, ClutterReport]], priors: ClutterPriors
) -> None:
    def counts(scene: Scene) -> dict[str, int]:
        out: dict[str, int] = {}
        for oid in small_objects(scene, priors):
            out[_parent(scene, oid)] = out.get(_parent(scene, oid), 0) + 1
        return out

    source = counts(filled)
    changed = False
    for scene, report in passes:
        now = counts(scene)
        assert max(now.values()) <= max(source.values())
        changed |= now != source
        # every small object of the source is still there, or reported dropped
        assert sum(now.values()) + len(report.dropped) == sum(source.values())
        assert set(scene.metadata["clutter"]["objects"]) == set(small_objects(scene, priors))
    assert changed


def test_swaps_keep_the_type_and_a_similar_size(
    filled: Scene, varied: list[Scene], priors: ClutterPriors
) -> None:
    swaps = 0
    for scene in varied:
        for oid in small_objects(scene, priors):
            if oid not in {o.id for o in filled.objects}:
                continue
            before, after = filled.get(oid), scene.get(oid)
            if before.asset.extents == after.asset.extents:
                continue
            swaps += 1
            assert before.category == after.category
            for x, y in zip(after.asset.extents, before.asset.extents, strict=True):
                assert abs(x - y) <= SWAP_SIZE_RATIO * y + 1e-9
    assert swaps > 0


def test_vary_is_seeded(filled: Scene, varied: list[Scene], priors: ClutterPriors) -> None:
    again, _ = vary_scene(filled, priors=priors, seed=1)
    assert again.model_dump_json() == varied[0].model_dump_json()
    assert varied[0].model_dump_json() != varied[1].model_dump_json()


def test_varied_small_objects_rest(varied: list[Scene], priors: ClutterPriors) -> None:
    scene = varied[0]
    shapes = {o.id: object_shape(o) for o in scene.objects}
    moved = motions_over(scene, shapes)
    small = small_objects(scene, priors)
    assert all(moved[oid] < 0.01 for oid in small), {oid: moved[oid] for oid in small if moved[oid] >= 0.01}


def test_the_novelty_distance_sees_clutter_only_when_asked(
    filled: Scene, varied: list[Scene], priors: ClutterPriors
) -> None:
    small = small_objects(filled, priors)
    assert novelty_with_clutter(filled, filled, small) == 0.0
    assert clutter_distance(filled, varied[0], small) > 0.3
    furniture = [o.id for o in filled.objects if o.id not in set(small)]
    plain = novelty_distance(Arrangement.of(filled, furniture), Arrangement.of(varied[0], furniture))
    assert (
        novelty_with_clutter(filled, varied[0], small) > plain
    )  # the furniture did not move, the clutter did


def test_dropping_a_small_object_clears_every_reference_to_it(filled: Scene, priors: ClutterPriors) -> None:
    """A dropped object leaves no relation, constraint mention or record behind (the scene checks
    its references on every assignment, so a stale one would raise)."""
    scene = filled.model_copy(deep=True)
    small = small_objects(scene, priors)
    furniture = [o.id for o in scene.objects if o.id not in set(small)]
    clause = {"layout_note": "keep together"}
    scene.constraints = [
        CrossUnitConstraint(
            id="c_mention", kind="placement", description="a mention",
            anchor_a=ConstraintClause(anchor_id=furniture[0], related_objects=[small[0], small[1]], **clause),
            anchor_b=ConstraintClause(anchor_id=furniture[1], **clause),
        ),
        CrossUnitConstraint(
            id="c_anchored", kind="orientation", description="anchored on it",
            anchor_a=ConstraintClause(anchor_id=small[0], **clause), anchor_b=ConstraintClause(anchor_id=furniture[1], **clause),
        ),
    ]  # fmt: skip
    remove_objects(scene, {small[0]})
    scene.validate_references()
    assert [c.id for c in scene.constraints] == ["c_mention"]
    assert scene.constraints[0].anchor_a.related_objects == [small[1]]
    assert small[0] not in scene.metadata["clutter"]["objects"]
    assert all(small[0] not in (r.child, r.parent) for r in scene.relations)


def test_a_room_a_house_shows_twice_gets_its_clutter_varied_anew(
    filled: Scene, varied: list[Scene], priors: ClutterPriors
) -> None:
    """A house whose selection shows one room arrangement in two variants (a room with fewer
    arrangements than the house has variants) does not repeat that room's clutter, and every
    scene of the room keeps the same small objects."""
    scenes = [s.model_copy(deep=True) for s in (filled, varied[0], varied[1])]
    common = set.intersection(*({o.id for o in s.objects} for s in scenes))
    for scene in scenes:  # as in a run: every scene of a room holds the same objects
        remove_objects(scene, {o.id for o in scene.objects} - common)
    base, first, other = scenes
    houses = [[first.model_copy(deep=True)], [first.model_copy(deep=True)], [other.model_copy(deep=True)]]
    picked = [{base.id: "variant_1"}, {base.id: "variant_1"}, {base.id: "variant_2"}]
    done = vary_repeated_rooms([base], houses, picked, priors=priors, seed=0)
    assert done["varied"] == {"variant_2": [base.id]}
    gone = set(done["dropped"].get(base.id, []))
    assert len(gone) <= 0.2 * len(small_objects(first, priors))
    again = houses[1][0]
    small = [o for o in small_objects(first, priors) if o not in gone]
    for scene in (base, houses[0][0], again, houses[2][0]):  # the same objects in every scene
        assert {o.id for o in scene.objects} == {o.id for o in first.objects} - gone
    assert houses[2][0].objects == [o for o in other.objects if o.id not in gone]  # shown once: as selected
    elsewhere = sum(_parent(houses[0][0], o) != _parent(again, o) for o in small)
    assert elsewhere >= 0.3 * len(small)


def test_an_object_settled_off_its_surface_is_not_kept_there(filled: Scene) -> None:
    """Resting is not enough: a pencil that rolled out of a drawer onto the floor rests, but is no
    longer in its receptacle (it is placed again, then dropped)."""
    scene = filled.model_copy(deep=True)
    record = scene.metadata["clutter"]["objects"]
    oid, entry = next((k, v) for k, v in sorted(record.items()) if v["placement"] == "on")
    obj = scene.get(oid)
    x, y, z = (float(v) for v in obj.pose.position)
    shapes = {o.id: object_shape(o) for o in scene.objects}
    tops = [s for s in receptacle_surfaces(scene, entry["receptacle"], shapes) if s.placement == "on"]
    surface = min(tops, key=lambda s: abs(s.height - z))
    assert _off_surface(scene, [oid], {oid: surface}, shapes) == set()
    obj.pose = obj.pose.model_copy(update={"position": (x, y, surface.height - 0.1)})  # fell through
    assert _off_surface(scene, [oid], {oid: surface}, shapes) == {oid}
    obj.pose = obj.pose.model_copy(update={"position": (x + 3.0, y, z)})  # beside it, at its height
    assert _off_surface(scene, [oid], {oid: surface}, shapes) == {oid}


def test_planned_passes_put_a_third_elsewhere_in_every_pair_of_five_variants(
    filled: Scene, priors: ClutterPriors
) -> None:
    """Each pass told the scenes already delivered (``shown``) differs from each of them: over five
    planned variants every pair has at least 30 % of the small objects on another receptacle and
    on another surface (the issue's acceptance for ``vary`` with 5 variants), and none is placed on
    a receptacle type the priors do not allow."""
    chosen: list[Scene] = [filled]
    for k in range(5):
        scene, report = vary_scene(filled, priors=priors, seed=100 + k, shown=chosen)
        assert not report.dropped
        chosen.append(scene)
    variants = chosen[1:]
    small = small_objects(filled, priors)
    for a, b in itertools.combinations(variants, 2):
        other = sum(_parent(a, oid) != _parent(b, oid) for oid in small)
        level = sum(resting_place(a, oid) != resting_place(b, oid) for oid in small)
        assert other >= 0.3 * len(small) and level >= other, (other, level, len(small))
    for scene in variants:
        for oid in small:
            t = priors.object_type(scene.get(oid).category)
            r = priors.receptacle_type(scene.get(_parent(scene, oid)).category)
            assert t is not None and r is not None and priors.allows(t, r), (oid, t, r)


def test_resting_place_tells_levels_of_one_receptacle_apart(filled: Scene) -> None:
    scene = filled.model_copy(deep=True)
    oid = next(iter(scene.metadata["clutter"]["objects"]))
    here = resting_place(scene, oid)
    relation = scene.support_of(oid)
    assert relation is not None and here[:2] == (relation.parent, relation.kind)
    obj = scene.get(oid)
    x, y, z = obj.pose.position
    obj.pose = obj.pose.model_copy(update={"position": (x + 0.2, y, z)})  # elsewhere on the same level
    assert resting_place(scene, oid) == here
    obj.pose = obj.pose.model_copy(update={"position": (x, y, z + 0.3)})  # a shelf above
    assert resting_place(scene, oid)[:2] == here[:2] and resting_place(scene, oid)[2] != here[2]

"""Room plans of a house's rooms (``evolve/_plans.py``): valid for the house by construction.

Each plan is checked on its own placement, before any loop runs, on rooms of shipped houses:
groups move rigidly, fixtures stay, no solid piece enters a door zone, the floor stays connected
with every door reachable, the largest group really moves, and the plans differ from each other.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import Polygon

from scenemosaic import GenerateConfig, agenerate
from scenemosaic.evolve import UnitContext, rule_archetypes, unit_context, unit_obstacles
from scenemosaic.evolve._analysis import layout_faces
from scenemosaic.evolve._plans import (
    MAX_PLANS,
    PLAN_MIN_AREA_M2,
    PLAN_MIN_MOVE_M,
    RIDER_REACH_M,
    _Planner,
    _seated,
    doors_kept,
    fixed_children,
    room_plans,
    walk_check,
)
from scenemosaic.physics import is_thin
from scenemosaic.scene import WALK_MIN_SHARE, Functional, Scene, UnitLayout, is_fixture

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"
ROOMS = [("procthor10k_train4_4room.json", "room|4"), ("procthor10k_train4_4room.json", "room|7"), ("procthor10k_train1_10room.json", "room|3"), ("procthor_6room.json", "room|6")]


async def _floor(house: str | Path, room: str, out: Path) -> tuple[Scene, UnitLayout, UnitContext]:
    """A house room built to its floor unit (``house``: a file of ``HOUSES``, or any path)."""
    scene = (await agenerate(HOUSES / house, out, GenerateConfig(evolve=False, room=room))).scene
    assert isinstance(scene, Scene) and scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    ctx = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), {o.id for o in scene.objects if is_thin(o)})
    return scene, UnitLayout.from_scene(scene, unit, ctx.surface), ctx


@pytest.mark.house  # four house rooms built to their floor unit (~20 s each): make test-houses
@pytest.mark.parametrize(("house", "room"), ROOMS)
async def test_plans_are_valid_for_the_house_by_construction(house: str, room: str, tmp_path: Path) -> None:
    _, layout, ctx = await _floor(house, room, tmp_path)
    assert ctx.in_house and ctx.keep_clear
    plans = room_plans(layout, ctx, 5)
    assert len(plans) >= 3, f"{room}: only {len(plans)} plans"
    fixed = fixed_children(layout, ctx)
    groups = _Planner(layout, ctx).groups
    seated = _seated(layout, ctx)  # where the loop seats the seats: the groups move from there
    base_share, _ = walk_check(layout, ctx, {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids})
    leads = []
    for place in plans:
        trial = layout.copy()
        for k, (u, v, r) in place.items():
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        for k in fixed:  # fixtures and pinned pieces never move
            assert math.dist(trial.center(k), layout.center(k)) < 1e-9
        for g in groups:  # every group moved as one rigid body: its inner distances kept
            pushed = {k for k in g.members if k != g.lead and k in ctx.against_wall and k not in ctx.nightstand_bed and k not in ctx.seat_table}
            for a, b in itertools.combinations(sorted(set(g.members) - pushed), 2):  # a sofa pushed back to its wall aside
                before = math.dist(seated.center(a), seated.center(b))
                assert math.dist(trial.center(a), trial.center(b)) == pytest.approx(before, abs=1e-6)
        region = Polygon(ctx.surface.region).buffer(1e-6)
        loose = Polygon(ctx.surface.region).buffer(RIDER_REACH_M + 1e-6, join_style="mitre")
        for k in trial.ids:
            shape = _carried(layout, trial, ctx, k)  # with what stands on it (a TV on its stand)
            assert region.covers(Polygon(trial.polygon(k))), f"{k} leaves the floor"
            assert loose.covers(shape), f"what stands on {k} reaches past the floor"
            if k not in ctx.thin:
                assert all(shape.intersection(z).area < 1e-6 for z in ctx.keep_clear), f"{k} stands in a door zone"
        share, doors = walk_check(layout, ctx, place)
        assert doors and share >= min(WALK_MIN_SHARE, base_share - 0.005)
        for a, b in sorted(ctx.keep_facing):  # a wall piece still faces what it faced (the loop cannot carry it back)
            if a in ctx.against_wall and layout_faces(layout, a, b):
                assert layout_faces(trial, a, b), f"{a} no longer faces {b}"
        furniture = [g for g in groups if g.area >= PLAN_MIN_AREA_M2 or g is groups[0]]
        moves = [
            math.dist(place[g.lead][:2], layout.center(g.lead)) >= PLAN_MIN_MOVE_M
            or abs(((place[g.lead][2] - layout.rotation(g.lead)) + 180) % 360 - 180) >= 45
            for g in furniture
        ]  # fmt: skip
        assert any(moves), "only small pieces moved"
        leads.append(np.array([place[g.lead][:2] for g in groups]))
    for a, b in itertools.combinations(leads, 2):  # no two plans put every group in the same place
        assert float(np.abs(a - b).max()) > 0.3


def _carried(layout: UnitLayout, trial: UnitLayout, ctx: UnitContext, k: str) -> Polygon:
    """``k``'s outline in ``trial`` with the outlines of what rests on it moved along rigidly."""
    from shapely.geometry import MultiPoint

    a = math.radians(-(trial.rotation(k) - layout.rotation(k)))
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    c0, c1 = np.asarray(layout.center(k)), np.asarray(trial.center(k))
    pts = [np.asarray(trial.polygon(k))] + [c1 + (np.asarray(p)[:, :2] - c0) @ rot.T for p in ctx.riders.get(k, [])]
    return MultiPoint(np.vstack(pts)).convex_hull


async def test_a_group_too_long_for_the_room_is_split_and_keeps_facing(tmp_path: Path) -> None:
    """A narrow living room whose TV stand faces the armchair of a dining table across the room
    (a double door along one side): the three pieces have no other place as one body, so the
    table with its armchair moves on its own and the TV still faces the armchair in every plan."""
    _, layout, ctx = await _floor("procthor10k_house3703_2room.json", "room|3", tmp_path)
    pairs = sorted(ctx.keep_facing)
    assert pairs, "the TV stand faces the armchair"
    planner = _Planner(layout, ctx)
    assert planner.facing == [p for p in pairs if any(p[0] in g.members for g in planner.groups)]
    assert all(not set(p) <= set(g.members) for p in planner.facing for g in planner.groups)  # split
    plans = room_plans(layout, ctx, 5)
    assert len(plans) >= 2
    for place in plans:
        trial = layout.copy()
        for k, (u, v, r) in place.items():
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        assert all(layout_faces(trial, a, b) for a, b in planner.facing)
        assert doors_kept(layout, ctx, place)


async def test_a_wall_unit_keeps_its_doors_and_windows(tmp_path: Path) -> None:
    """A wall unit's context holds its doors and windows; a placement that moves a picture onto
    the door's stretch of wall is refused (``doors_kept``), one that leaves it where it was is not."""
    scene = (await agenerate(HOUSES / "procthor10k_house3703_2room.json", tmp_path, GenerateConfig(evolve=False, room="room|3"))).scene
    assert isinstance(scene, Scene) and scene.room is not None and scene.structure is not None
    wall = next(w for w in scene.room.walls if any(o.kind == "door" for o in w.openings))
    unit = next(u for u in scene.structure.units if u.anchor_id == wall.id)
    ctx = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), set())
    layout = UnitLayout.from_scene(scene, unit, ctx.surface)
    assert ctx.keep_clear and not ctx.in_house
    base = {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids}
    assert doors_kept(layout, ctx, base)
    door = ctx.keep_clear[0]
    k = layout.ids[0]
    u, v = door.centroid.x, layout.center(k)[1]
    assert not doors_kept(layout, ctx, {**base, k: (u, v, layout.rotation(k))})


@pytest.mark.house  # a kitchen built to its floor unit: make test-houses
async def test_plans_come_first_and_fixtures_stay_in_every_archetype(tmp_path: Path) -> None:
    _, layout, ctx = await _floor("procthor10k_train4_4room.json", "room|6", tmp_path)  # the kitchen
    fixed = {k for k in layout.ids if is_fixture(layout.object(k).category)}
    assert fixed, "the kitchen has a counter and a fridge"
    found = rule_archetypes(layout, ctx, 5)
    assert found and found[0].layout_id.startswith("plan_")
    for arch in found:
        place = arch.place(layout, ctx)
        from scenemosaic.evolve._archetypes import _pinned

        kept = _pinned(place, ctx, layout)
        for k in fixed:
            assert math.dist(kept[k][:2], layout.center(k)) < 1e-9


def test_fixture_table() -> None:
    for cat in ("Toilet", "CounterTop", "Fridge", "stove_burner", "Bathtub", "WashingMachine", "sink"):
        assert is_fixture(cat), cat
    for cat in ("bed", "sofa", "dining_table", "desk", "dresser", "wardrobe", "tv_stand", "shelving_unit", "chair"):
        assert not is_fixture(cat), cat
    assert is_fixture("bed", fixtures={"bed"})  # the table is overridable


async def _painting_over_dresser(tmp_path: Path) -> tuple[Scene, list[Functional], Functional]:
    """The shipped 4-room house's bedroom, its functional ``over`` relations, and the one of its
    painting over its dresser."""
    from scenemosaic.scene import functional_relations

    scene = (await agenerate(HOUSES / "procthor_4room.json", tmp_path, GenerateConfig(evolve=False, room="room|4"))).scene
    assert isinstance(scene, Scene) and scene.room is not None
    rels = [r for r in functional_relations(scene) if r.follows and r.kind == "over"]
    over = next(r for r in rels if scene.get(r.subject).category == "painting" and scene.get(r.leader).category == "dresser")
    return scene, rels, over


async def test_a_wall_piece_is_rehung_on_the_wall_its_group_moves_to(tmp_path: Path) -> None:
    """The painting over the dresser of a shipped bedroom follows the dresser to another wall:
    same height, flush on the new wall, facing the room, its support relation naming that wall,
    and RelKeep counts it kept (``scene.follow_leaders``, ``metrics.relkeep``)."""
    from scenemosaic.metrics import relation_holds, relkeep
    from scenemosaic.scene import (
        Pose,
        follow_leaders,
        functional_holds,
        quat_from_yaw,
        with_world_poses,
    )

    scene, rels, over = await _painting_over_dresser(tmp_path)
    painting, dresser = scene.get(over.subject), scene.get(over.leader)
    old_wall = scene.support_of(painting.id)
    assert old_wall is not None
    target = next(w for w in scene.room.walls if w.id != old_wall.parent and not w.openings and w.length > 3.0)
    n = np.asarray(target.inward_normal)
    yaw = math.atan2(float(n[0]), float(-n[1]))  # front (local -Y) along the wall's inward normal
    mid = (np.asarray(target.start) + np.asarray(target.end)) / 2
    trial = dresser.model_copy(update={"pose": Pose(position=(float(mid[0]), float(mid[1]), dresser.pose.position[2]), quaternion=quat_from_yaw(yaw), scale=dresser.pose.scale)})
    back = 0.01 - target.gap(trial.corners())
    pos = mid + n * back
    moved = with_world_poses(scene, {dresser.id: trial.pose.model_copy(update={"position": (float(pos[0]), float(pos[1]), dresser.pose.position[2])})})
    followed = follow_leaders(scene, moved, rels)
    assert followed is not None
    hung = followed.get(painting.id)
    now = followed.support_of(painting.id)
    assert now is not None and now.parent == target.id
    assert hung.pose.position[2] == pytest.approx(painting.pose.position[2], abs=1e-9)
    assert abs(target.gap(hung.corners())) < 0.02  # flush on the new wall, in the room
    assert functional_holds(followed, over)
    assert not relation_holds(followed, old_wall) and relkeep(scene, followed) == pytest.approx(1.0)
    assert followed.structure is not None and any(painting.id in u.children for u in followed.structure.units if u.anchor_id == target.id)


@pytest.mark.house  # a living room built to its floor unit: make test-houses
async def test_a_sofa_facing_a_wall_tv_keeps_facing_it_in_every_plan(tmp_path: Path) -> None:
    """A held-out living room whose sofa faces the TV hung on the wall across the room (another
    unit's piece): the plans move the sofa only where it still faces the TV (compose would refuse
    any other), and there are several such plans."""
    from scenemosaic.scene import points_at

    _, layout, ctx = await _floor(HOUSES.parent / "schema_forms" / "cc_kitchen_living_schema_0_0_1.json", "room_3", tmp_path)
    assert ctx.faces_outside, "the sofa faces the wall TV"
    plans = room_plans(layout, ctx, 5)
    assert len(plans) >= 3
    for place in plans:
        for piece, outline, centre in ctx.faces_outside:
            u, v, r = place[piece]
            front = np.array([-math.sin(math.radians(r)), -math.cos(math.radians(r))])
            assert points_at(np.array([u, v]), front, outline, np.asarray(centre)), f"{piece} turned away"


@pytest.mark.house  # a living room built to its floor unit: make test-houses
async def test_a_piece_facing_a_pinned_stand_keeps_facing_it_in_every_plan(tmp_path: Path) -> None:
    """A held-out living room whose TV stand stays where it is (pinned by a clause across units)
    and faces an armchair: the armchair moves only where the stand still faces it (a plan that
    turned it away was refused later, leaving one plan of eight), and there are several plans."""
    _, layout, ctx = await _floor(HOUSES.parent / "schema_forms" / "ai2thor_746_schema_0_0_1.json", "room_7", tmp_path)
    fixed = fixed_children(layout, ctx)
    pairs = [(a, b) for a, b in sorted(ctx.keep_facing) if a in ctx.against_wall and (a in fixed) != (b in fixed)]
    assert pairs, "a pinned wall piece faces one that may move"
    plans = room_plans(layout, ctx, 5)
    assert len(plans) >= 3
    kept = rule_archetypes(layout, ctx, 5)
    assert sum(a.layout_id.startswith("plan_") for a in kept) >= 3  # the plans survive the loop's own checks
    for place in plans:
        trial = layout.copy()
        for k, (u, v, r) in place.items():
            trial.set_rotation(k, r)
            trial.set_center(k, u, v)
        assert all(layout_faces(trial, a, b) for a, b in pairs)


@pytest.mark.house  # a house room built to its floor unit twice: make test-houses
async def test_plans_asked_a_few_at_a_time_are_those_of_one_search(tmp_path: Path) -> None:
    """The search goes on where it stopped when more plans are asked for (the archetypes ask for
    one more until the limit is filled): the first k plans do not hang on the limit."""
    scene, layout, ctx = await _floor("procthor10k_train4_4room.json", "room|4", tmp_path / "a")
    assert scene.structure is not None
    unit = next(u for u in scene.structure.units if u.anchor_id == "floor")
    whole = room_plans(layout, ctx, MAX_PLANS)
    assert len(whole) >= 4
    fresh = unit_context(scene, unit, unit_obstacles(scene, unit, scene.structure.units), {o.id for o in scene.objects if is_thin(o)})
    stepwise = [room_plans(layout, fresh, k) for k in (1, 2, 4, MAX_PLANS)]
    assert [len(p) for p in stepwise[:3]] == [1, 2, 4]
    assert all(p == whole[: len(p)] for p in stepwise) and stepwise[-1] == whole
    assert len(fresh.plan_cache) == 1  # one search, resumed: not one per limit


async def test_a_wall_piece_beside_its_group_goes_to_the_other_side_when_its_side_runs_off_the_wall(tmp_path: Path) -> None:
    """A painting hung beside a dresser's end (not centred over it) follows the dresser into a
    corner of another wall, where its own side would run past the wall's end: it is hung on the
    dresser's other side instead (before: no wall took it, and every plan moving the dresser was
    refused in composition, so the room never varied)."""
    from scenemosaic.scene import (
        Pose,
        follow_leaders,
        functional_holds,
        functional_relations,
        quat_from_yaw,
        with_world_poses,
    )

    scene, rels, over = await _painting_over_dresser(tmp_path)
    painting, dresser = scene.get(over.subject), scene.get(over.leader)
    wall = scene.room.wall(scene.support_of(painting.id).parent)  # type: ignore[union-attr]
    t = np.asarray(wall.direction)
    # slide the painting along its wall to just past the dresser's end (still over it, by the margin)
    ends = (dresser.corners()[:, :2] - np.asarray(wall.start)) @ t
    width = float(painting.size[0])
    along = float(ends.max()) + 0.25 - width / 2
    shift = along - float((np.asarray(painting.pose.position[:2]) - np.asarray(wall.start)) @ t)
    p = np.asarray(painting.pose.position, dtype=np.float64).copy()
    p[:2] += t * shift
    scene = with_world_poses(scene, {painting.id: painting.pose.model_copy(update={"position": tuple(float(v) for v in p)})})
    rels = [r for r in functional_relations(scene) if r.follows and r.kind == "over"]
    over = next(r for r in rels if r.subject == painting.id)
    # the dresser to another long bare wall, its end in that wall's corner on the painting's side
    target = next(w for w in scene.room.walls if w.id != wall.id and not w.openings and w.length > 3.0)
    n, t1 = np.asarray(target.inward_normal), np.asarray(target.direction)
    yaw = math.atan2(float(n[0]), float(-n[1]))
    half = float(dresser.size[0]) / 2
    trial = dresser.model_copy(update={"pose": Pose(position=(0.0, 0.0, dresser.pose.position[2]), quaternion=quat_from_yaw(yaw), scale=dresser.pose.scale)})
    for end in (half + 0.05, target.length - half - 0.05):  # one of the two corners is on the painting's side
        centre = np.asarray(target.start) + t1 * end
        probe = trial.model_copy(update={"pose": trial.pose.model_copy(update={"position": (float(centre[0]), float(centre[1]), dresser.pose.position[2])})})
        centre = centre + n * (0.01 - target.gap(probe.corners()))
        pose = probe.pose.model_copy(update={"position": (float(centre[0]), float(centre[1]), dresser.pose.position[2])})
        moved = with_world_poses(scene, {dresser.id: pose})
        side = float((np.asarray(centre) - np.asarray(target.start)) @ t1)
        followed = follow_leaders(scene, moved, [over])
        assert followed is not None, f"the painting found no place beside the dresser at {side:.2f} m along {target.id}"
        hung = followed.get(painting.id)
        assert followed.support_of(painting.id).parent == target.id  # type: ignore[union-attr]
        a = (hung.corners()[:, :2] - np.asarray(target.start)) @ t1
        assert a.min() >= -1e-3 and a.max() <= target.length + 1e-3  # on the wall, not past its end
        assert functional_holds(followed, over)


async def test_a_room_too_full_to_regroup_whole_still_gets_plans(tmp_path: Path) -> None:
    """The dining room of the Holodeck house (eight chairs at a 2.2 m table, a buffet with two
    more, a sideboard, two bookcases, a bar cart in 24 m²): the whole-room search finds no
    arrangement; plans then move its groups one by one, each where it clears the others, keeps
    the floor as open as the base and every door reachable (before: no plan, and the room never
    varied)."""
    from scenemosaic.scene import kept_floor_share
    from tests.holodeck_helpers import holodeck_house

    house = holodeck_house(tmp_path / "house.json")
    _, layout, ctx = await _floor(house, "depressed_dining_room", tmp_path / "run")
    plans = room_plans(layout, ctx, 4)
    assert len(plans) >= 3
    planner = _Planner(layout, ctx)
    base_share, _ = walk_check(layout, ctx, {k: (*layout.center(k), layout.rotation(k)) for k in layout.ids})
    for place in plans:
        share, doors = walk_check(layout, ctx, place)
        assert doors and share >= kept_floor_share(base_share) - 1e-9
        moved = [g for g in planner.groups if math.dist(place[g.lead][:2], layout.center(g.lead)) >= PLAN_MIN_MOVE_M]
        assert any(g.area >= PLAN_MIN_AREA_M2 for g in moved)

"""Property tests: whatever an agent's ``check`` accepts leaves a shipped room valid.

A model's reply is the rule solver's answer, damaged the way a small model damages answers
(numbers shifted or replaced by extremes, ids swapped, list items dropped, repeated or
reversed, flags flipped); hypothesis draws the damage. A damaged reply that still parses as the
agent's output type and that the agent's check accepts is applied to the room, and the scene
must then hold every invariant the agent answers for. Derandomized: the same cases every run.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError
from shapely.geometry import Polygon

from scenemosaic.agents import SceneState, TaskAgent, run_agent
from scenemosaic.exchange import load_scene
from scenemosaic.models import RulesModel
from scenemosaic.scene import Scene, nested_pairs
from scenemosaic.structure import DEFAULT_AGENTS, ManagerAgent
from scenemosaic.structure._facts import object_facts, parent_cycles
from scenemosaic.structure._manager import REQUIRED_AGENTS
from scenemosaic.structure._semantics import _front_facts, front_problem

REPO = Path(__file__).resolve().parents[2]
ROOMS = {
    "living": REPO / "data" / "layouts" / "physcene" / "LivingDiningRoom-124277_livingroom.json",
    "bedroom": REPO / "tests" / "fixtures" / "bedroom_22.json",
}
"""A 16-object PhyScene living-dining room (input room, floor furniture, lamps) and the 22-object
test bedroom (recovered room, books in a shelf, a painting on a wall, a desk with a monitor)."""

PROPERTY_SETTINGS = settings(
    max_examples=40, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


def _before(room: str, name: str) -> SceneState:
    """The room with every agent that runs before ``name`` applied (rule solvers)."""
    state = SceneState(load_scene(ROOMS[room]))
    order = list(DEFAULT_AGENTS)

    async def run() -> None:
        for agent in order:
            if agent.name == name:
                return
            await run_agent(agent, state, RulesModel())

    asyncio.run(run())
    return state


def _copy(state: SceneState) -> SceneState:
    return SceneState(state.scene.model_copy(deep=True), outputs=dict(state.outputs))


@st.composite
def damaged(draw: st.DrawFn, value: Any, ids: list[str]) -> Any:
    """``value`` (an answer as JSON data) with a few leaves and lists damaged."""
    if isinstance(value, dict):
        return {k: draw(damaged(v, ids)) for k, v in value.items()}
    if isinstance(value, list):
        items = [draw(damaged(v, ids)) for v in value]
        op = draw(st.sampled_from(["keep", "keep", "keep", "drop", "repeat", "reverse"]))
        if items and op == "drop":
            del items[draw(st.integers(0, len(items) - 1))]
        elif items and op == "repeat":
            items.append(items[draw(st.integers(0, len(items) - 1))])
        elif op == "reverse":
            items.reverse()
        return items
    if draw(st.integers(0, 7)) != 7:  # most leaves are left alone (and shrinking heads for no damage)
        return value
    if isinstance(value, bool):
        return not value
    if isinstance(value, int | float):
        if draw(st.booleans()):
            return round(value + draw(st.floats(-2.0, 2.0, allow_nan=False)), 3)
        return draw(st.sampled_from([0, -1, 90, -90, 180, 0.01, 50]))
    if isinstance(value, str):
        return draw(st.sampled_from([*ids, "floor", "ceiling", "wall_0", "wall_9", "not_an_id"]))
    return value


def _accepted(agent: TaskAgent[SceneState, Any, Any], state: SceneState, data: Any) -> Any | None:
    """The damaged answer as an output, if it parses and the agent's check accepts it."""
    try:
        output = agent.output_type.model_validate(data)
    except ValidationError:
        return None  # a schema-invalid reply never reaches check (the model layer repairs it)
    return output if not agent.problems(output, state) else None


def _room_ok(before: Scene, after: Scene) -> None:
    assert after.room is not None
    floor = Polygon(after.room.floor)
    assert floor.is_valid and floor.exterior.is_ccw
    grown = floor.buffer(0.03)
    for o in after.objects:
        assert grown.contains(Polygon(o.footprint())), f"{o.id} outside the room"
    walls = after.room.walls
    assert walls and all(w.length >= 0.3 for w in walls)
    assert sum(w.length for w in walls) >= 0.95 * floor.exterior.length
    for w in walls:
        assert min(math.dist(w.end, v.start) for v in walls) <= 0.05  # a closed ring
    assert after.room.ceiling_height >= max(o.aabb()[1][2] for o in after.objects if o.category != "pendant_lamp") - 0.05


def _supports_ok(before: Scene, after: Scene) -> None:
    parents = {r.child: r.parent for r in after.relations if r.is_support}
    assert set(parents) == {o.id for o in after.objects}
    assert parent_cycles(parents) == []


def _fronts_ok(before: Scene, after: Scene) -> None:
    def facing_walls(scene: Scene) -> int:
        facts = object_facts(scene)
        cats = {o.id: o.category for o in facts}
        return sum(front_problem(cats[f.id], f) == "faces_wall" for f in _front_facts(scene, facts))

    assert facing_walls(after) <= facing_walls(before)


def _constraints_ok(before: Scene, after: Scene) -> None:
    parents = {r.child: r.parent for r in after.relations if r.is_support}
    carriers = set(parents.values())
    for c in after.constraints:
        for clause in (c.anchor_a, c.anchor_b):
            assert clause.anchor_id in carriers
            assert all(parents.get(o) == clause.anchor_id for o in clause.related_objects)
    for r in after.relations:
        if r.kind in ("faces", "beside"):
            assert parents[r.child] == parents[r.parent]


def _verified_ok(before: Scene, after: Scene) -> None:
    _supports_ok(before, after)
    assert len(nested_pairs(after)) <= len(nested_pairs(before))
    assert after.structure is not None


INVARIANTS: dict[str, Callable[[Scene, Scene], None]] = {
    "room": _room_ok,
    "support": _supports_ok,
    "containment": _supports_ok,
    "walls": _supports_ok,
    "semantics": _fronts_ok,
    "attributes": lambda before, after: None,  # mass bounds are the check itself; validation below
    "constraints": _constraints_ok,
    "verify": _verified_ok,
}


@pytest.mark.parametrize("name", list(INVARIANTS))
@pytest.mark.parametrize("room", list(ROOMS))
def test_an_accepted_damaged_answer_leaves_the_room_valid(room: str, name: str) -> None:
    agent = next(a for a in DEFAULT_AGENTS if a.name == name)
    base = _before(room, name)
    answer = agent.solve(agent.gather(base)).model_dump(mode="json")
    ids = [o.id for o in base.scene.objects]
    accepted = rejected = 0

    @PROPERTY_SETTINGS
    @given(data=damaged(answer, ids))
    def check(data: Any) -> None:
        nonlocal accepted, rejected
        state = _copy(base)
        output = _accepted(agent, state, data)
        if output is None:
            rejected += 1
            return
        accepted += 1
        before = state.scene.model_copy(deep=True)
        agent.apply(output, state)
        after = Scene.model_validate(state.scene.model_dump())  # still a valid scene
        INVARIANTS[name](before, after)

    check()
    assert accepted > 0  # the solver's own answer, at least, passes
    if answer != agent.output_type().model_dump(mode="json") if _has_defaults(agent) else True:
        assert rejected > 0  # not vacuous: damage was drawn, and the check caught some of it


def _has_defaults(agent: TaskAgent[SceneState, Any, Any]) -> bool:
    """Whether the agent's output type can be built empty (then an empty answer has nothing to damage)."""
    try:
        agent.output_type()
    except ValidationError:
        return False
    return True


def test_an_accepted_damaged_plan_schedules_what_the_scene_needs() -> None:
    manager = ManagerAgent()
    base = SceneState(load_scene(ROOMS["living"]))
    answer = manager.solve(manager.gather(base)).model_dump(mode="json")
    names = [a.name for a in DEFAULT_AGENTS]
    summary = manager.gather(base)

    @PROPERTY_SETTINGS
    @given(data=damaged(answer, names))
    def check(data: Any) -> None:
        output = _accepted(manager, base, data)
        if output is None:
            return
        planned = {a.name for a in output.agents}
        assert planned >= REQUIRED_AGENTS
        assert not planned & {a.name for a in output.skipped}
        if summary.wall_candidates:
            assert "walls" in planned
        if summary.functional_pairs:
            assert "constraints" in planned

    check()

"""Evolution benchmark: how long the Critic-Actor stage takes, offline and with a slow model.

Figures (the last line is one JSON object):

* ``rules_room16_cold_s`` — ``scenemosaic generate`` of the 16-object PhyScene living room
  (LivingDiningRoom-124277) with ``--variants 5`` (base + every unit variant) on the rules model,
  as a fresh process with an empty hull cache (interpreter start and imports included);
* ``rules_room16_warm_s`` — the same run again inside this process (imports done, cache warm);
  ``rules_room16_variants5_s`` is the same figure under the name issue 12 gives it (the whole
  ``generate --variants 5``: evolve, compose, evaluate and the five variants' exports);
* ``rules_room16_layouts`` — evolved layouts in that run (originals + variants);
* with a model that answers every request with the asking agent's rule solver after sleeping
  5 s (a stand-in for a slow VLM with the same answers), on the base scene (``--variants 0``):
  ``sim_vlm_calls`` (requests made), ``sim_vlm_critical_path_s`` (5 s times the longest chain of
  requests that must wait for each other: the structuring agents along their dependency graph,
  then the longest evolving layout's requests, which run one after another),
  ``sim_vlm_base_wall_s`` (wall time of the run) and ``sim_vlm_wall_over_critical`` (their ratio;
  1.0 would be perfect overlap of everything that can overlap); the same figures prefixed
  ``sim_vlm_bedroom22_`` for the 22-object test bedroom (9 units, books in a shelf, a painting);
* ``rules_perturbed_valid`` / ``rules_perturbed_total`` — robustness of the offline loop: the
  floor unit of every PhyScene room and of the test bedroom, stabilized, then disturbed 8 times
  each (seeded: every object moved up to 0.4 m along each axis and turned up to 25 degrees), then
  evolved: how many end with no collision, nothing out of bounds and every rule kept;
* ``rules_archetypes_valid`` / ``rules_archetypes_total`` — every rule archetype the offline agent
  could offer for every unit of those rooms (not only the first 1-3 it does offer), instantiated
  and evolved: how many end valid;
* ``seconds`` — wall time of the whole benchmark.

Targets (issue 11): warm rules run <= 20 s on a 2-core machine; simulated base <= 180 s; the
ratio <= 1.10.

Run: ``.venv/bin/python benchmarks/evolution.py``.
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from scenemosaic import GenerateConfig, agenerate, generate
from scenemosaic.agents import TaskAgent, agent_dependencies
from scenemosaic.evolve import ActorAgent, ArchetypeAgent, CriticAgent, PoseAgent
from scenemosaic.models import FunctionModel, Message, RequestContext
from scenemosaic.structure import DEFAULT_AGENTS, ManagerAgent

REPO = Path(__file__).resolve().parents[1]
ROOM16 = REPO / "data" / "layouts" / "physcene" / "LivingDiningRoom-124277_livingroom.json"
BEDROOM22 = REPO / "tests" / "fixtures" / "bedroom_22.json"
"""A harder case: 22 objects in 9 units (floor, a wall, the ceiling, object tops, a bookshelf)."""
LATENCY_S = 5.0
STRUCTURING = [ManagerAgent(), *DEFAULT_AGENTS]
SOLVERS: dict[str, TaskAgent[Any, Any, Any]] = {
    a.name: a for a in (*STRUCTURING, CriticAgent(), ActorAgent(), ArchetypeAgent(), PoseAgent())
}


def _cold(out: Path, cache: Path) -> float:
    env = {**os.environ, "SCENEMOSAIC_CACHE": str(cache), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    started = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "scenemosaic.cli", "generate", str(ROOM16), "--out", str(out), "--variants", "5"],
        check=True, capture_output=True, env=env,
    )  # fmt: skip
    return time.perf_counter() - started


def _structure_critical_calls(calls: dict[str, int]) -> int:
    """Longest chain of structuring requests: the manager's, then the agents along their dependencies."""
    agents = [a for a in DEFAULT_AGENTS if a.name in calls]
    deps = agent_dependencies(agents)
    memo: dict[str, int] = {}

    def longest(name: str) -> int:
        if name not in memo:
            memo[name] = calls.get(name, 0) + max((longest(d) for d in deps.get(name, ())), default=0)
        return memo[name]

    return calls.get("manager", 0) + max((longest(a.name) for a in agents), default=0)


async def _simulated(out: Path, source: Path = ROOM16, prefix: str = "sim_vlm") -> dict[str, Any]:
    calls: dict[str, int] = {}

    async def answer(messages: list[Message], context: RequestContext) -> BaseModel:
        assert context.evidence is not None
        calls[context.agent] = calls.get(context.agent, 0) + 1
        await asyncio.sleep(LATENCY_S)
        result: BaseModel = SOLVERS[context.agent].solve(context.evidence)
        return result

    model = FunctionModel(answer, name="sim-vlm-5s", vision=False)
    started = time.perf_counter()
    result = await agenerate(source, out, GenerateConfig(model=model, overwrite=True))
    wall = time.perf_counter() - started
    evolve = next(s for s in result.report["stages"] if s["name"] == "evolve")
    layout_calls = max((lay["requests"] for lay in evolve["detail"]["layouts"]), default=0)
    structure_calls = {k: v for k, v in calls.items() if k in {a.name for a in STRUCTURING}}
    critical = (_structure_critical_calls(structure_calls) + layout_calls) * LATENCY_S
    return {
        f"{prefix}_calls": sum(calls.values()),
        f"{prefix}_calls_by_agent": dict(sorted(calls.items())),
        f"{prefix}_critical_path_s": round(critical, 1),
        f"{prefix}_base_wall_s": round(wall, 1),
        f"{prefix}_wall_over_critical": round(wall / critical, 3) if critical else None,
        f"{prefix}_status": result.status,
    }


PERTURB_TRIALS = 8


@dataclass
class _Room:
    """A stabilized room ready for the loop: its scene, collision shapes and unit contexts."""

    name: str
    scene: Any
    shapes: dict[str, Any]
    contexts: dict[str, Any]


def _rooms(root: Path) -> list[_Room]:
    """Every PhyScene room and the test bedroom, structured and stabilized (no evolve), once."""
    from scenemosaic.evolve import unit_context, unit_obstacles
    from scenemosaic.physics import is_thin, object_shape

    out = []
    for source in [*sorted((REPO / "data" / "layouts" / "physcene").glob("*.json")), BEDROOM22]:
        scene = generate(source, root / source.stem, GenerateConfig(evolve=False)).scene
        assert scene.structure is not None
        units = scene.structure.units
        thin = {o.id for o in scene.objects if is_thin(o)}
        contexts = {u.anchor_id: unit_context(scene, u, unit_obstacles(scene, u, units), thin) for u in units}
        shapes = {o.id: object_shape(o, root / source.stem / "base") for o in scene.objects}
        out.append(_Room(source.stem, scene, shapes, contexts))
    return out


def _perturbed(rooms: list[_Room]) -> dict[str, Any]:
    """Seeded disturbances of stabilized floor units, each evolved by the rules."""
    import random

    from scenemosaic.evolve import evolve_layout
    from scenemosaic.models import parse_model
    from scenemosaic.scene import UnitLayout

    rng = random.Random(0)
    valid = total = 0
    failures: list[str] = []
    for room in rooms:
        ctx = room.contexts["floor"]
        for trial in range(PERTURB_TRIALS):
            layout = UnitLayout.from_scene(room.scene, ctx.unit)
            for k in layout.ids:
                u, v = layout.center(k)
                layout.set_center(k, u + rng.uniform(-0.4, 0.4), v + rng.uniform(-0.4, 0.4))
                layout.set_rotation(k, layout.rotation(k) + rng.uniform(-25, 25))
            result = asyncio.run(
                evolve_layout(room.scene, ctx, layout, room.shapes, parse_model("rules"), layout_id=f"disturbed_{trial}")
            )
            total += 1
            if result.valid and not result.violations:
                valid += 1
            else:
                failures.append(f"{room.name}#{trial}: {'; '.join(result.violations)[:120]}")
    return {"rules_perturbed_valid": valid, "rules_perturbed_total": total, "rules_perturbed_failures": failures}


def _all_archetypes(rooms: list[_Room]) -> dict[str, Any]:
    """Every rule archetype of every unit, instantiated and evolved."""
    from scenemosaic.evolve import Archetype, evolve_layout, rule_archetypes
    from scenemosaic.models import parse_model
    from scenemosaic.scene import UnitLayout

    valid = total = 0
    failures: list[str] = []
    for room in rooms:
        for anchor, ctx in room.contexts.items():
            layout = UnitLayout.from_scene(room.scene, ctx.unit)
            for cand in rule_archetypes(layout, ctx):
                arch = Archetype(layout_id=cand.layout_id, layout_style_name=cand.style_name, layout_reasoning=cand.reasoning)
                result = asyncio.run(
                    evolve_layout(room.scene, ctx, layout, room.shapes, parse_model("rules"), layout_id=cand.layout_id, archetype=arch)
                )
                total += 1
                if result.valid and not result.violations:
                    valid += 1
                else:
                    failures.append(f"{room.name}/{anchor}/{cand.layout_id}")
    return {"rules_archetypes_valid": valid, "rules_archetypes_total": total, "rules_archetypes_failures": failures}


def main() -> None:
    t0 = time.perf_counter()
    figures: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        figures["rules_room16_cold_s"] = round(_cold(root / "cold", root / "cache"), 2)
        generate(ROOM16, root / "warmup", GenerateConfig(variants=5, cache_dir=root / "cache"))
        started = time.perf_counter()
        warm = generate(ROOM16, root / "warm", GenerateConfig(variants=5, cache_dir=root / "cache"))
        figures["rules_room16_warm_s"] = round(time.perf_counter() - started, 2)
        figures["rules_room16_variants5_s"] = figures["rules_room16_warm_s"]  # the same run: --variants 5, warm
        evolve = next(s for s in warm.report["stages"] if s["name"] == "evolve")
        figures["rules_room16_layouts"] = evolve["detail"]["layout_count"]
        figures["rules_room16_evolve_s"] = round(evolve["seconds"], 2)
        figures["rules_room16_valid_layouts"] = evolve["detail"]["valid_layouts"]
        figures.update(asyncio.run(_simulated(root / "sim")))
        figures.update(asyncio.run(_simulated(root / "sim_bed", BEDROOM22, "sim_vlm_bedroom22")))
        rooms = _rooms(root / "rooms")
        figures.update(_perturbed(rooms))
        figures.update(_all_archetypes(rooms))
    figures["seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()

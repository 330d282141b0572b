"""Prompt-size benchmark: tokens each structuring agent sends, and the run's critical path.

Every agent's prompt is built the way a model run builds it (the agents before it answered
with their rule solvers, as a model that agrees with them would, and their answers applied as a
run applies them, ``run_agent``), then counted:

* with ``--tokenize-url http://127.0.0.1:8089`` by a llama.cpp server itself (its chat
  template applied by ``/apply-template``, then ``/tokenize``);
* otherwise by the library's estimate (``scenemosaic.models.estimate_tokens``: 3.5 characters
  a token). The estimate undercounts these number-dense tables: on the shared Qwen2.5 server,
  whose tokenizer splits every digit, the real counts were 25-45 % higher. Quote server counts.

Figures (the last line is one JSON object):

* ``max_prompt_tokens_room16`` — largest prompt of the 16-object PhyScene living-dining room;
* ``max_prompt_tokens_room60`` — largest prompt of a 60-object room: the ProcTHOR house
  bedroom (40 objects) with the 22-object test bedroom's contents beside it (62 objects);
* ``critical_path_calls_room16`` — model calls one after another on the longest dependency
  chain of the room16 plan (manager included), when every first answer is usable;
* ``prompt_tokens_room16`` / ``prompt_tokens_room60`` — per agent (the largest chunk's prompt
  when an agent asks about a large scene in chunks of ``CHUNK_OBJECTS`` objects).

Run: ``.venv/bin/python benchmarks/prompts.py [--tokenize-url URL]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from pathlib import Path
from typing import Any

import httpx

from scenemosaic.agents import SceneState, agent_dependencies, run_agent
from scenemosaic.exchange import load_scene, load_scenes
from scenemosaic.models import Message, RulesModel, TextPart, estimate_tokens
from scenemosaic.scene import Pose, Scene
from scenemosaic.structure import ManagerAgent, plan_structuring

REPO = Path(__file__).resolve().parents[1]
ROOM16 = REPO / "data" / "layouts" / "physcene" / "LivingDiningRoom-124277_livingroom.json"
HOUSE = REPO / "data" / "houses" / "procthor" / "procthor_1room_bedroom.json"
BEDROOM = REPO / "tests" / "fixtures" / "bedroom_22.json"


def room60() -> Scene:
    """The ProcTHOR bedroom (40 objects) with the test bedroom's 22 objects placed beside it."""
    [house] = load_scenes(HOUSE)
    extra = load_scene(BEDROOM)
    assert house.room is not None
    xs = [p[0] for p in house.room.floor]
    ys = [p[1] for p in house.room.floor]
    dx, dy = max(xs) + 0.5, min(ys)
    objects = list(house.objects)
    for o in extra.objects:
        x, y, z = o.pose.position
        moved = o.pose.model_copy(update={"position": (x + dx, y + dy, z)})
        objects.append(o.model_copy(update={"id": f"b_{o.id}", "pose": Pose.model_validate(moved.model_dump())}))
    return Scene(id="room60", objects=objects)


class Counter:
    """Counts a prompt's tokens: the server's tokenizer when given, else the estimate."""

    def __init__(self, url: str | None) -> None:
        self.url = url.rstrip("/") if url else None
        self.client = httpx.Client(timeout=60) if url else None

    def __call__(self, messages: list[Message]) -> int:
        if self.client is None or self.url is None:
            return estimate_tokens(messages)
        wire = [
            {"role": m.role, "content": "\n\n".join(p.text for p in m.parts if isinstance(p, TextPart))}
            for m in messages
        ]
        prompt = self.client.post(f"{self.url}/apply-template", json={"messages": wire}).json()["prompt"]
        return len(self.client.post(f"{self.url}/tokenize", json={"content": prompt}).json()["tokens"])


async def prompt_sizes(scene: Scene, count: Counter) -> tuple[dict[str, int], int]:
    """Tokens of each agent's first prompt (text-only model), and the plan's critical path in calls."""
    manager = ManagerAgent()
    state = SceneState(scene)
    sizes = {"manager": count(manager.messages(manager.gather(state), state, vision=False))}
    chunks: dict[str, int] = {}
    _plan, agents = plan_structuring(scene)
    deps = agent_dependencies(agents)
    model = RulesModel()
    done: set[str] = set()
    pending = list(agents)
    while pending:  # dependency order: an agent's prompt sees what its predecessors wrote
        ready = [a for a in pending if set(deps[a.name]) <= done]
        for agent in ready:
            evidence = agent.gather(state)
            if agent.answer_without_model(evidence) is None:
                parts = agent.split(evidence, agent.chunk_size) if agent.chunk_size else [([], evidence)]
                sizes[agent.name] = max(count(agent.messages(part, state, vision=False)) for _, part in parts)
                chunks[agent.name] = len(parts)
            await run_agent(agent, state, model)
            done.add(agent.name)
            pending.remove(agent)
    calls: dict[str, int] = {}

    def depth(name: str) -> int:
        if name not in calls:
            own = chunks.get(name, 0)  # chunks are asked one after another
            calls[name] = own + max((depth(d) for d in deps[name]), default=0)
        return calls[name]

    path = 1 + max(depth(a.name) for a in agents)  # + the manager's call
    return sizes, path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tokenize-url", default=None, help="llama.cpp server root, e.g. http://127.0.0.1:8089")
    args = parser.parse_args(argv)
    count = Counter(args.tokenize_url)
    room16 = load_scene(ROOM16)
    assert isinstance(room16, Scene)
    small, path16 = asyncio.run(prompt_sizes(room16, count))
    large, _ = asyncio.run(prompt_sizes(room60(), count))
    figures: dict[str, Any] = {
        "counter": "server /tokenize" if args.tokenize_url else "estimate (3.5 chars/token)",
        "max_prompt_tokens_room16": max(small.values()),
        "max_prompt_tokens_room60": max(large.values()),
        "critical_path_calls_room16": path16,
        "prompt_tokens_room16": small,
        "prompt_tokens_room60": large,
    }
    print(json.dumps(figures, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())

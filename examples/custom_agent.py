"""A one-file agent plugin run by ``generate`` beside the built-in agents: ``python examples/custom_agent.py
[ROOM.json] [OUT]`` writes ``OUT/base/scene.json`` with ``metadata.crowding``. On a whole house (a ProcTHOR
``house.json``) the agent runs in every room: each ``OUT/base/rooms/<room>/scene.json`` holds its room's
crowding. A real VLM gets ``PROMPT``."""

# %%
from __future__ import annotations

import sys
from pathlib import Path
from typing import ClassVar

from pydantic import BaseModel, Field
from shapely.geometry import Polygon

import scenemosaic as sm

PROMPT = """You judge how crowded a room's floor is. The evidence lists each object's id and
footprint area in square metres, and the floor area. Reply with the covered fraction
(sum of footprints / floor area) and the ids of the three largest objects.
"""


class Footprints(BaseModel):
    floor_m2: float
    objects: dict[str, float]


class Crowding(sm.AgentOutput):
    covered_fraction: float = Field(ge=0)
    largest: list[str] = Field(max_length=3)


class CrowdingAgent(sm.TaskAgent[sm.SceneState, Footprints, Crowding]):
    name: ClassVar[str] = "crowding"
    depends_on: ClassVar[tuple[str, ...]] = ("room",)  # needs the recovered floor
    prompt: ClassVar[str] = PROMPT
    object_id_fields: ClassVar[tuple[str, ...]] = ("largest",)  # the base check: known ids, each once

    def gather(self, state: sm.SceneState) -> Footprints:
        floor = Polygon(state.scene.room.floor).area if state.scene.room else 1.0
        return Footprints(floor_m2=floor, objects={o.id: float(o.size[0] * o.size[1]) for o in state.scene.objects})

    def solve(self, evidence: Footprints) -> Crowding:
        largest = sorted(evidence.objects, key=lambda oid: -evidence.objects[oid])[:3]
        return Crowding(covered_fraction=round(sum(evidence.objects.values()) / evidence.floor_m2, 3), largest=largest)

    def apply(self, output: Crowding, state: sm.SceneState) -> None:
        state.scene.metadata["crowding"] = output.model_dump()


if __name__ == "__main__":
    room = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parents[1] / "data/layouts/physcene/DiningRoom-19325_diningroom.json"
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("out/custom_agent")
    result = sm.generate(room, out, sm.GenerateConfig(agents=[*sm.DEFAULT_AGENTS, CrowdingAgent()]))
    for scene in result.house.rooms:  # a house: the agent ran in each room; a room run is a house of one
        print(f"crowding of {scene.id}:", scene.metadata["crowding"])

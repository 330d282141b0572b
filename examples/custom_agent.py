"""Write your own task agent and run it next to the built-in ones, offline.

A task agent declares its evidence, its output type, a rule solver (the offline path) and how
its output changes the scene. The same agent talks to a real VLM when you pass an
``openai:...`` model instead of the rules model.

Run: ``python examples/custom_agent.py``
"""

from __future__ import annotations

import asyncio
from typing import ClassVar

from pydantic import BaseModel, Field

import scenemosaic as sm


class Footprints(BaseModel):
    """Evidence: each object's id, category and footprint area in square metres."""

    objects: list[tuple[str, str, float]]


class CrowdingReport(BaseModel):
    """Output: the share of the floor covered by furniture and the largest objects."""

    covered_fraction: float = Field(ge=0)
    largest: list[str] = Field(max_length=3)


class CrowdingAgent(sm.TaskAgent[Footprints, CrowdingReport]):
    """Measures how crowded the floor is; a plugin needs nothing but this class."""

    name: ClassVar[str] = "crowding"
    prompt: ClassVar[str] = "verify"  # any prompt file under prompts/ (write your own for a real VLM)
    output_type: ClassVar[type[BaseModel]] = CrowdingReport

    def gather(self, state: sm.SceneState) -> Footprints:
        objs = state.scene.objects
        return Footprints(objects=[(o.id, o.category, float(o.size[0] * o.size[1])) for o in objs])

    def solve(self, evidence: Footprints) -> CrowdingReport:
        room_area = 4.5 * 4.0
        total = sum(area for _, _, area in evidence.objects)
        largest = sorted(evidence.objects, key=lambda item: -item[2])[:3]
        return CrowdingReport(covered_fraction=round(total / room_area, 3), largest=[oid for oid, _, _ in largest])

    def check(self, output: CrowdingReport, state: sm.SceneState) -> list[str]:
        known = {o.id for o in state.scene.objects}
        return [f"unknown object id {oid!r}" for oid in output.largest if oid not in known]

    def apply(self, output: CrowdingReport, state: sm.SceneState) -> None:
        state.scene.metadata["crowding"] = output.model_dump()


async def main() -> None:
    state = sm.SceneState(scene=sm.demo_scene())
    outputs = await sm.run_agents([CrowdingAgent()], state, sm.RulesModel())
    report = outputs["crowding"]
    assert isinstance(report, CrowdingReport)
    print(f"floor covered: {report.covered_fraction:.0%}; largest: {', '.join(report.largest)}")


if __name__ == "__main__":
    asyncio.run(main())

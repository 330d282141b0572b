"""The semantic judge: POS and ROT plausibility of a scene, asked of a vision model.

No public judge exists (LayoutVLM never released its scorer), so the prompt and the scoring rule
are ours: the model sees the top-down render of the scene and a table of its objects and says, for
every object, whether its position and its rotation are plausible. **POS** is the percentage of
objects whose position it calls plausible, **ROT** the percentage whose rotation it does.

The judge has no rule solver: with the offline rules model, a text-only model, or a model whose
answers stay unusable, POS and ROT are reported as not measured (``None``, with the reason),
never made up.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentLog, AgentOutput, AgentPolicy, SceneState, TaskAgent, run_agent
from scenemosaic.exceptions import AgentOutputError, ModelError
from scenemosaic.models import ImagePart, Model, ModelSettings
from scenemosaic.render import render_topdown
from scenemosaic.scene import Scene

__all__ = ["JUDGE_VIEW_PX", "JudgeAgent", "JudgeOutput", "ObjectVerdict", "judge_scene"]

JUDGE_VIEW_PX = 768
"""Side of the floor plan the judge sees, pixels."""


class JudgeRow(AgentOutput):
    """One object as the judge reads it."""

    id: str
    category: str
    center: tuple[float, float] = Field(description="Centre x, y on the floor plan, metres.")
    size: tuple[float, float, float] = Field(description="Width, depth, height, metres.")
    yaw: float = Field(description="Heading in degrees: 0 faces -y (down on the plan), 90 faces +x.")
    on: str = Field(description="What it rests on: floor, ceiling, a wall id or an object id.")


class JudgeEvidence(AgentOutput):
    """The scene the judge rates."""

    room: tuple[float, float] = Field(description="Room extent along x and y, metres.")
    objects: list[JudgeRow] = Field(max_length=MAX_ITEMS)


class ObjectVerdict(AgentOutput):
    """The judge's call on one object."""

    object_id: str
    position_plausible: bool
    rotation_plausible: bool
    note: str = Field(default="", max_length=200)


class JudgeOutput(AgentOutput):
    """One verdict per object."""

    objects: list[ObjectVerdict] = Field(max_length=MAX_ITEMS)


class JudgeAgent(TaskAgent[SceneState, JudgeEvidence, JudgeOutput]):
    """Rates every object's position and rotation from the scene's floor plan."""

    name: ClassVar[str] = "judge"
    prompt: ClassVar[str] = "judge"
    reply_tokens: ClassVar[tuple[int, int] | None] = (100, 40)
    object_id_fields: ClassVar[tuple[str, ...]] = ("objects.object_id",)

    def gather(self, state: SceneState) -> JudgeEvidence:
        scene = state.scene
        import math

        import numpy as np

        floor = np.asarray(scene.room.floor) if scene.room is not None else np.zeros((1, 2))
        rows = []
        for o in scene.objects:
            rel = scene.support_of(o.id)
            rows.append(
                JudgeRow(
                    id=o.id, category=o.category, center=(o.pose.position[0], o.pose.position[1]),
                    size=tuple(float(v) for v in o.size), yaw=math.degrees(o.pose.yaw),  # type: ignore[arg-type]
                    on=rel.parent if rel is not None else "floor",
                )
            )
        span = floor.max(axis=0) - floor.min(axis=0)
        return JudgeEvidence(room=(float(span[0]), float(span[1])), objects=rows)

    def solve(self, evidence: JudgeEvidence) -> JudgeOutput:
        raise AgentOutputError("the semantic judge has no rule solver: it is reported as not measured", agent=self.name)

    def images(self, evidence: JudgeEvidence, state: SceneState) -> list[ImagePart]:
        png = render_topdown(state.scene, base_dir=state.base_dir, size_px=JUDGE_VIEW_PX)
        return [ImagePart(png=png, label="top-down floor plan: +x right, +y up, grid in metres, arrows along each object's front")]

    def check(self, output: JudgeOutput, state: SceneState) -> list[str]:
        missing = sorted({o.id for o in state.scene.objects} - {v.object_id for v in output.objects})
        return [f"give a verdict for every object; missing: {', '.join(missing)}"] if missing else []


async def judge_scene(
    scene: Scene,
    model: Model,
    *,
    settings: ModelSettings | None = None,
    base_dir: Any = None,
    agent_log: AgentLog | None = None,
) -> dict[str, Any]:
    """``{"POS": %, "ROT": %, "objects": n}`` from a vision model, or ``None`` scores and the reason
    they were not measured. ``agent_log``, when given, receives the judge's result (its requests)."""
    if model.uses_rule_solvers:
        return {"POS": None, "ROT": None, "note": "not measured: the judge needs a vision model, not the rules"}
    if not model.vision:
        return {"POS": None, "ROT": None, "note": f"not measured: {model.name} has no vision (the judge rates renders)"}
    if not scene.objects:
        return {"POS": None, "ROT": None, "note": "not measured: the scene has no objects"}
    state = SceneState(scene=scene, base_dir=base_dir, policy=AgentPolicy(solver_fallback=False))
    try:
        result = await run_agent(JudgeAgent(), state, model, settings, log=agent_log)
        output, usage = result.output, result.usage
    except (ModelError, AgentOutputError) as exc:
        return {"POS": None, "ROT": None, "note": f"not measured: {type(exc).__name__}: {str(exc)[:200]}"}
    n = len(output.objects)
    return {
        "POS": round(100.0 * sum(v.position_plausible for v in output.objects) / n, 2),
        "ROT": round(100.0 * sum(v.rotation_plausible for v in output.objects) / n, 2),
        "objects": n,
        "requests": usage.requests,
    }

"""Vision models see the floor plan; text-only models get the same facts as text, never an image."""

from __future__ import annotations

import io

from agent_solvers import solver_answer
from PIL import Image
from pydantic import BaseModel

from scenemosaic import FunctionModel, Scene, demo_scene
from scenemosaic.models import ImagePart, Message, RequestContext
from scenemosaic.structure import structure_scene
from scenemosaic.structure._views import FLOOR_PLAN_PX

AGENTS_WITH_PLANS = {"room", "support", "containment", "walls", "semantics", "constraints"}


def _recording_model(vision: bool, seen: dict[str, list[ImagePart]]) -> FunctionModel:
    def answer(messages: list[Message], context: RequestContext) -> BaseModel:
        seen[context.agent] = [p for m in messages for p in m.parts if isinstance(p, ImagePart)]
        return solver_answer(messages, context)

    return FunctionModel(answer, vision=vision)


async def test_vision_models_receive_the_floor_plan() -> None:
    seen: dict[str, list[ImagePart]] = {}
    scene: Scene = demo_scene().model_copy(update={"room": None})  # the room agent has a room to recover
    await structure_scene(scene, _recording_model(True, seen))
    assert set(seen) >= AGENTS_WITH_PLANS
    for agent in AGENTS_WITH_PLANS:
        (image,) = seen[agent]
        picture = Image.open(io.BytesIO(image.png))
        assert picture.size == (FLOOR_PLAN_PX, FLOOR_PLAN_PX)
        assert image.label and "front" in image.label


async def test_text_only_models_get_no_images_but_the_same_facts() -> None:
    seen: dict[str, list[ImagePart]] = {}
    await structure_scene(demo_scene().model_copy(update={"room": None}), _recording_model(False, seen))
    assert set(seen) >= AGENTS_WITH_PLANS
    assert all(images == [] for images in seen.values())

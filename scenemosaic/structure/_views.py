"""Image evidence for vision models: the current scene's floor plan.

Text-only models get the same facts as structured text (each agent's evidence JSON:
footprints, heights, yaws), so a model without vision loses nothing but the picture.
"""

from __future__ import annotations

from typing import Any

from scenemosaic.agents import SceneState
from scenemosaic.models import ImagePart
from scenemosaic.render import render_topdown

__all__ = ["FLOOR_PLAN_PX", "FloorPlanImages", "floor_plan_image"]

FLOOR_PLAN_PX = 768
"""Side of the floor-plan image sent to vision models, pixels (a VLM tile size, small enough to be cheap)."""

def floor_plan_image(state: SceneState) -> ImagePart:
    """Top-down PNG of ``state.scene``: footprints, ids, facing arrows, walls and a metric grid."""
    png = render_topdown(state.scene, base_dir=state.base_dir, size_px=FLOOR_PLAN_PX)
    return ImagePart(
        png=png,
        label="top-down floor plan: +x right, +y up, grid in metres, arrows point along each object's front",
    )


class FloorPlanImages:
    """Mixin for task agents: vision models also receive the floor plan of the current scene."""

    def images(self, evidence: Any, state: SceneState) -> list[ImagePart]:
        """One image: :func:`floor_plan_image` of the scene as it is when the agent runs."""
        return [floor_plan_image(state)]

"""The field's scene metrics: COL, OOB and NAV (SceneEval's physical metrics), and the diversity of
selected variants (Div-IoU, Div-N, RelKeep). Each is a documented function; :func:`evaluate`
gathers them for a base scene and its variants (``scenemosaic evaluate`` prints it as JSON).
:func:`judge_scene` asks a vision model for the semantic POS and ROT scores (never faked: not
measured without one).
"""

from scenemosaic.metrics._judge import JUDGE_VIEW_PX, JudgeAgent, JudgeOutput, ObjectVerdict, judge_scene
from scenemosaic.metrics._metrics import (
    COL_SEPARATION_M,
    DIV_GRID,
    NAV_GRID,
    NAV_MAX_HEIGHT,
    NAV_ROBOT_RADIUS,
    OOB_EDGE_M,
    OOB_INSIDE,
    OOB_SAMPLES,
    RELATION_TOLERANCE_M,
    col,
    div_iou,
    div_n,
    evaluate,
    house_diversity,
    house_occupancy,
    nav,
    occupancy,
    oob,
    relation_holds,
    relkeep,
    scene_metrics,
)

__all__ = [
    "COL_SEPARATION_M",
    "DIV_GRID",
    "JUDGE_VIEW_PX",
    "NAV_GRID",
    "NAV_MAX_HEIGHT",
    "NAV_ROBOT_RADIUS",
    "OOB_EDGE_M",
    "OOB_INSIDE",
    "OOB_SAMPLES",
    "RELATION_TOLERANCE_M",
    "JudgeAgent",
    "JudgeOutput",
    "ObjectVerdict",
    "col",
    "div_iou",
    "div_n",
    "evaluate",
    "house_diversity",
    "house_occupancy",
    "judge_scene",
    "nav",
    "occupancy",
    "oob",
    "relation_holds",
    "relkeep",
    "scene_metrics",
]

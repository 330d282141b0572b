"""The field's scene metrics: COL, OOB and NAV (SceneEval's physical metrics), and the diversity of
selected variants (Div-IoU, Div-N, RelKeep). Each is a documented function; :func:`evaluate`
gathers them for a base scene and its variants (``scenemosaic evaluate`` prints it as JSON);
:func:`evaluate` takes a whole house and its variants as readily, room by room and house-wide
(:func:`house_checks`: door clearance, reachability, walls).
:func:`judge_scene` asks a vision model for the semantic POS and ROT scores (never faked: not
measured without one).
"""

from scenemosaic.metrics._evaluate import evaluate
from scenemosaic.metrics._house import (
    FURNITURE_M2,
    HOUSE_BASE_FIGURES,
    MOVED_M,
    TURNED_DEG,
    furniture,
    house_checks,
    moved_furniture,
)
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
    blocked_parts,
    col,
    div_iou,
    div_n,
    house_diversity,
    house_occupancy,
    nav,
    occupancy,
    oob,
    parts_free,
    relation_holds,
    relkeep,
    relkeep_by_kind,
    relkeep_summary,
    scene_metrics,
)
from scenemosaic.metrics._plausibility import PLAUSIBILITY_RULES, plausibility
from scenemosaic.metrics._seating import (
    SEAT_SQUARE_DEG,
    SeatCheck,
    seat_checks,
    seat_pairs,
    seating_figures,
    table_balance,
)

__all__ = [
    "COL_SEPARATION_M",
    "DIV_GRID",
    "FURNITURE_M2",
    "HOUSE_BASE_FIGURES",
    "JUDGE_VIEW_PX",
    "MOVED_M",
    "NAV_GRID",
    "NAV_MAX_HEIGHT",
    "NAV_ROBOT_RADIUS",
    "OOB_EDGE_M",
    "OOB_INSIDE",
    "OOB_SAMPLES",
    "PLAUSIBILITY_RULES",
    "RELATION_TOLERANCE_M",
    "SEAT_SQUARE_DEG",
    "TURNED_DEG",
    "WINDOW_REACH_M",
    "JudgeAgent",
    "JudgeOutput",
    "ObjectVerdict",
    "SeatCheck",
    "blocked_parts",
    "blocked_windows",
    "col",
    "div_iou",
    "div_n",
    "evaluate",
    "furniture",
    "house_checks",
    "house_diversity",
    "house_occupancy",
    "judge_scene",
    "moved_furniture",
    "nav",
    "occupancy",
    "oob",
    "parts_free",
    "plausibility",
    "relation_holds",
    "relkeep",
    "relkeep_by_kind",
    "relkeep_summary",
    "scene_metrics",
    "seat_checks",
    "seat_pairs",
    "seating_figures",
    "table_balance",
]

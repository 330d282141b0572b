"""The whole structuring DAG replayed from a cassette built from hand-written replies."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from scenemosaic.models import FunctionModel, Message, ReplayModel, RequestContext
from scenemosaic.scene import FLOOR, Scene
from scenemosaic.structure import DEFAULT_AGENTS, structure_scene

AGENT_NAMES = [a.name for a in DEFAULT_AGENTS]
REPLIES = Path(__file__).resolve().parents[1] / "fixtures" / "cassettes" / "structuring_sam3d_replies.json"


def scripted() -> FunctionModel:
    replies: dict[str, Any] = json.loads(REPLIES.read_text(encoding="utf-8"))["replies"]

    def answer(messages: list[Message], context: RequestContext | None) -> Any:
        assert context is not None
        return replies[context.agent]

    return FunctionModel(answer, name="scripted-vlm", vision=False)


async def test_cassette_covers_every_schema() -> None:
    replies = json.loads(REPLIES.read_text(encoding="utf-8"))["replies"]
    assert set(replies) == {"manager", *AGENT_NAMES}


async def test_replay_through_the_whole_dag(sam3d_scene: Scene, tmp_path: Path, procthor_dir: Path) -> None:
    cassette = tmp_path / "structuring.json"
    recorded = await structure_scene(
        sam3d_scene, ReplayModel(scripted(), cassette, mode="record"), priors_dir=procthor_dir
    )
    data = json.loads(cassette.read_text(encoding="utf-8"))
    # the verification pass finds nothing to fix in this scene, so it answers without a call
    assert {e["agent"] for e in data["entries"].values()} == {"manager", *AGENT_NAMES} - {"verify"}

    # replay only: no wrapped model, so any request not in the cassette fails
    replayed = await structure_scene(sam3d_scene, ReplayModel(None, cassette, mode="replay"), priors_dir=procthor_dir)
    assert replayed.to_json() == recorded.to_json()

    # the hand-written content is what ended up in the scene
    assert replayed.get("printer").sim.mass_kg == 14.5
    assert replayed.get("desk").description.startswith("wide wooden work desk")
    assert replayed.get("desk").category == "desk"
    assert replayed.room is not None and replayed.room.ceiling_height == 2.7
    [c] = replayed.constraints
    assert c.id == "chair_faces_desk" and {c.anchor_a.anchor_id, c.anchor_b.anchor_id} == {FLOOR, "desk"}
    assert replayed.structure is not None
    assert {u.anchor_id: set(u.children) for u in replayed.structure.units}["desk"] == {"printer", "mug"}

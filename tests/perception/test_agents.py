"""The perception agents: a vision model's inventory (checked, repaired), the verification rounds
(requests applied, memory, round cap) and the rule verifier."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from scenemosaic.models import FunctionModel, ImagePart, Message, RequestContext, RulesModel
from scenemosaic.perception import (
    MAX_VERIFY_ROUNDS,
    DetectedObject,
    Inventory,
    ObjectMask,
    VerifyEvidence,
    VerifyOutput,
    mask_rows,
    perceive,
    solve_verify,
    support_candidate,
)


@pytest.fixture
def photo(tmp_path: Path) -> Path:
    rng = np.random.default_rng(3)
    p = tmp_path / "room.png"
    Image.fromarray(rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)).save(p)
    return p


BED = {"id": "bed", "label": "double_bed", "box": [150, 250, 500, 460]}
DESK = {"id": "desk", "label": "desk", "box": [20, 220, 180, 380]}
MUG = {"id": "mug", "label": "mug", "box": [60, 200, 80, 226]}


def _texts(messages: list[Message]) -> str:
    return "\n".join(p.text for m in messages for p in m.parts if hasattr(p, "text"))


async def test_inventory_agent_repairs_a_box_outside_the_image(photo: Path) -> None:
    asked: list[list[Message]] = []

    def inventory(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        asked.append(messages)
        if len(asked) == 1:
            return {"objects": [BED, {"id": "desk", "label": "desk", "box": [20, 220, 700, 380]}]}
        return {"objects": [BED, DESK, MUG]}

    def verify(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        return {"requests": []}

    model = FunctionModel({"perception": inventory, "perception_verify": verify})
    result = await perceive(photo, model, segmenter="box", reconstructor="box-lifter")
    assert [o.id for o in result.inventory] == ["bed", "desk", "mug"]
    assert any(isinstance(p, ImagePart) for p in asked[0][-1].parts)  # the photograph was shown
    assert "lies outside the 640x480 image" in _texts(asked[1])  # sent back with the problem
    assert result.report["inventory"]["answered_by"] == "model"
    assert result.report["placements"]["mug"] == "on desk"  # nested: from the boxes
    assert {o.id for o in result.scene.objects} == {"bed", "desk", "mug"}


async def test_verification_rounds_apply_requests_and_remember_them(photo: Path) -> None:
    rounds: list[str] = []

    def inventory(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        dup = {"id": "bed_2", "label": "double_bed", "box": [152, 251, 499, 459]}
        return {"objects": [BED, dup, DESK]}

    def verify(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        text = _texts(messages)
        rounds.append(text)
        if len(rounds) == 1:
            return {
                "requests": [
                    {"action": "remove", "object_id": "bed_2", "reason": "same bed twice"},
                    {"action": "add", "object_id": "nightstand", "label": "nightstand", "box": [505, 300, 600, 420]},
                ]
            }
        if len(rounds) == 2:  # asks the same thing again: refused by the check, then answers nothing
            return {"requests": [{"action": "add", "object_id": "nightstand", "label": "nightstand", "box": [505, 300, 600, 420]}]}
        return {"requests": []}

    model = FunctionModel({"perception": inventory, "perception_verify": verify})
    result = await perceive(photo, model, segmenter="box", reconstructor="box-lifter")
    assert [o.id for o in result.inventory] == ["bed", "desk", "nightstand"]
    assert "remove bed_2" in rounds[1]  # the memory of round 1 is in round 2's evidence
    assert "id 'nightstand' is taken" in rounds[2] or "asked in an earlier round" in rounds[2]
    report = result.report["verification"]
    assert report[0]["requests"] == ["remove bed_2", "add nightstand box [505, 300, 600, 420]"]
    assert report[-1]["requests"] == []
    assert set(result.masks) == {"bed", "desk", "nightstand"}


async def test_verification_stops_at_the_round_cap(photo: Path) -> None:
    count = {"n": 0}

    def verify(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        count["n"] += 1
        box = [20, 220, 180 - count["n"], 380]  # a new box each time: never the same request twice
        return {"requests": [{"action": "resegment", "object_id": "desk", "box": box}]}

    model = FunctionModel({"perception": lambda m, c: {"objects": [BED, DESK]}, "perception_verify": verify})
    result = await perceive(photo, model, segmenter="box", reconstructor="box-lifter")
    assert len(result.report["verification"]) == MAX_VERIFY_ROUNDS
    desk = next(o for o in result.inventory if o.id == "desk")
    assert desk.box == (20.0, 220.0, 180.0 - MAX_VERIFY_ROUNDS, 380.0)


def test_rule_verifier_finds_duplicates_empty_masks_and_nesting() -> None:
    objs = [DetectedObject.model_validate(d) for d in (BED, DESK, MUG)]
    objs.append(DetectedObject(id="bed_b", label="bed", box=(151, 250, 501, 460)))
    masks = {o.id: ObjectMask((int(o.box[0]), int(o.box[1])), np.ones((10, 10), dtype=bool)) for o in objs}
    masks["desk"] = ObjectMask((0, 0), np.zeros((0, 0), dtype=bool))
    ev = VerifyEvidence(image_width=640, image_height=480, round=1, objects=mask_rows(objs, masks))
    words = [r.words() for r in solve_verify(ev).requests]
    assert "resegment desk box [20, 220, 180, 380]" in words
    assert "set_support mug on desk" in words
    # 'double_bed' and 'bed' are different categories: no duplicate unless the category matches
    assert not any(w.startswith("remove") for w in words)
    objs[-1] = DetectedObject(id="bed_b", label="double_bed", box=(151, 250, 501, 460))
    ev = VerifyEvidence(image_width=640, image_height=480, round=1, objects=mask_rows(objs, masks))
    words = [r.words() for r in solve_verify(ev).requests]
    assert "remove bed_b" in words
    # nothing asked before is asked again
    again = VerifyEvidence(image_width=640, image_height=480, round=2, objects=ev.objects, memory=words)
    assert solve_verify(again) == VerifyOutput(requests=[])


def test_support_candidate_needs_a_supporting_box_holding_the_lower_edge() -> None:
    desk = DetectedObject.model_validate(DESK)
    mug = DetectedObject.model_validate(MUG)
    assert support_candidate(mug, [desk, mug]) == "desk"
    floor_mug = mug.model_copy(update={"box": (300, 440, 320, 470)})
    assert support_candidate(floor_mug, [desk, floor_mug]) is None
    wall_mug = mug.model_copy(update={"placement": "wall"})
    assert support_candidate(wall_mug, [desk, wall_mug]) is None


def test_rules_model_answers_from_the_detections(photo: Path, tmp_path: Path) -> None:
    det = tmp_path / "inv.json"
    det.write_text(Inventory(objects=[DetectedObject.model_validate(d) for d in (BED, DESK, MUG)]).model_dump_json())
    out = tmp_path / "out"
    result = asyncio.run(perceive(photo, RulesModel(), detections=det, segmenter="box", reconstructor="box-lifter", out_dir=out))
    assert result.report["inventory"] == {"objects": 3, "answered_by": "rules", "hints": 3}
    folder = out / "perception"
    assert sorted(p.name for p in (folder / "masks").iterdir()) == ["bed.png", "desk.png", "mug.png"]
    assert (folder / "photo.png").read_bytes() == photo.read_bytes()
    # the inventory written there reads back as detections
    again = asyncio.run(
        perceive(photo, RulesModel(), detections=folder / "inventory.json", segmenter="box", reconstructor="box-lifter")
    )
    assert [o.model_dump() for o in again.inventory] == [o.model_dump() for o in result.inventory]


async def test_agents_see_a_downscaled_picture_and_boxes_scale_back(tmp_path: Path) -> None:
    """A 2048 x 1536 photograph is shown at 1024 x 768 (``VIEW_MAX_SIDE``): the model answers in
    those pixels, and the inventory comes back in the photograph's."""
    rng = np.random.default_rng(5)
    big = tmp_path / "big.png"
    Image.fromarray(rng.integers(0, 255, (1536, 2048, 3), dtype=np.uint8)).save(big)
    seen: dict[str, Any] = {}

    def inventory(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        assert context is not None
        seen["evidence"] = context.evidence
        image = next(p for p in messages[-1].parts if isinstance(p, ImagePart))
        seen["size"] = Image.open(__import__("io").BytesIO(image.png)).size
        return {"objects": [{"id": "bed", "label": "double_bed", "box": [100, 300, 600, 700]}]}

    def verify(messages: list[Message], context: RequestContext | None) -> dict[str, Any]:
        assert context is not None
        seen.setdefault("rows", context.evidence.objects)  # type: ignore[union-attr]
        if len(seen.setdefault("verify", [])) == 0:
            seen["verify"].append(1)
            return {"requests": [{"action": "add", "object_id": "rug", "label": "rug", "box": [200, 650, 500, 760]}]}
        return {"requests": []}

    model = FunctionModel({"perception": inventory, "perception_verify": verify})
    result = await perceive(big, model, segmenter="box", reconstructor="box-lifter")
    assert seen["size"] == (1024, 768)
    assert (seen["evidence"].image_width, seen["evidence"].image_height) == (1024, 768)
    assert seen["rows"][0].box == (100.0, 300.0, 600.0, 700.0)  # the verifier sees the picture's pixels too
    boxes = {o.id: o.box for o in result.inventory}
    assert boxes == {"bed": (200.0, 600.0, 1200.0, 1400.0), "rug": (400.0, 1300.0, 1000.0, 1520.0)}


async def test_a_loop_of_supports_from_the_model_is_cut(photo: Path) -> None:
    """A model that says the vase is on the box and the box on the vase: the loop is cut, so at
    most one of them rests on the other."""
    objs = [
        {"id": "box", "label": "box", "box": [300, 200, 360, 260], "on": "vase"},
        {"id": "vase", "label": "vase", "box": [310, 150, 340, 200], "on": "box"},
        {"id": "book", "label": "book", "box": [320, 120, 335, 150], "on": "vase"},
        BED,
    ]
    model = FunctionModel({"perception": lambda m, c: {"objects": objs}, "perception_verify": lambda m, c: {"requests": []}})
    result = await perceive(photo, model, segmenter="box", reconstructor="box-lifter")
    places = result.report["placements"]
    assert not (places["box"] == "on vase" and places["vase"] == "on box")
    assert places["book"] == "on vase"  # a chain without a loop is kept
    assert {o.id for o in result.scene.objects} == {"box", "vase", "book", "bed"}

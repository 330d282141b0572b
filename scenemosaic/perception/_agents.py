"""The perception agents: the object inventory of a photograph, then rounds of verifying its masks.

Both are ordinary :class:`~scenemosaic.agents.TaskAgent` s over a :class:`PerceptionState`:

* **perception** (:class:`InventoryAgent`) — a vision model lists every object with an id, a
  label, a few words and a pixel box; the answer is checked against the image
  (:func:`~scenemosaic.perception.inventory_problems`) and sent back with the problems when it
  fails. Its offline solver is the detections file (``--detections``): without one, and
  without a vision model, nothing can list the objects and the run stops before any work.
* **perception_verify** (:class:`VerifyAgent`) — shown the masks over the photograph, it asks
  for re-segmentation (an ambiguous or empty mask), a missing instance, the removal of a
  duplicate, or the support of a nested object (a mug on a desk). Its rule solver finds
  duplicates, empty masks and nested objects geometrically. The rounds are capped
  (:data:`MAX_VERIFY_ROUNDS`) and a memory keeps what was asked before, so nothing is asked twice.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field

from scenemosaic.agents import MAX_ITEMS, AgentOutput, SceneState, TaskAgent
from scenemosaic.exceptions import UsageError
from scenemosaic.models import ImagePart
from scenemosaic.perception._image import SceneImage
from scenemosaic.perception._inventory import DetectedObject, Inventory, box_iou, clipped, inventory_problems
from scenemosaic.perception._segment import ObjectMask
from scenemosaic.scene import traits

__all__ = [
    "DUPLICATE_IOU",
    "MAX_VERIFY_ROUNDS",
    "MIN_MASK_COVERAGE",
    "VIEW_MAX_SIDE",
    "InventoryAgent",
    "InventoryEvidence",
    "MaskRow",
    "PerceptionState",
    "VerifyAgent",
    "VerifyEvidence",
    "VerifyOutput",
    "VerifyRequest",
    "mask_overlay",
    "mask_rows",
    "solve_verify",
    "support_candidate",
]

VIEW_MAX_SIDE = 1024
"""Longest side (pixels) of the pictures the perception agents are shown. Boxes in their evidence
and replies are in the pixels of that picture and are scaled back to the photograph's."""
MAX_VERIFY_ROUNDS = 3
"""Most verification rounds over the masks."""
MIN_MASK_COVERAGE = 0.08
"""A mask filling less of its box than this is taken as a failed segmentation."""
DUPLICATE_IOU = 0.7
"""Two objects of one category whose boxes overlap this much (IoU) are one object seen twice."""

Box = tuple[float, float, float, float]

_PHOTO_LABEL = "the photograph"
_MASKS_LABEL = "the photograph with each object's mask tinted and its id written at its box's top-left corner"


@dataclass
class PerceptionState(SceneState):
    """What the perception agents share: the image, the hints, the inventory, masks and memory."""

    image: SceneImage | None = None
    hints: list[DetectedObject] = field(default_factory=list)
    """Detections given with the photograph (``--detections``): the inventory's offline answer."""
    inventory: list[DetectedObject] = field(default_factory=list)
    masks: dict[str, ObjectMask] = field(default_factory=dict)
    memory: list[str] = field(default_factory=list)
    """Requests of earlier verification rounds, in words."""
    requests: list[VerifyRequest] = field(default_factory=list)
    round: int = 0

    def need_image(self) -> SceneImage:
        """The photograph (set before any agent runs)."""
        assert self.image is not None
        return self.image

    def view_size(self) -> tuple[int, int]:
        """Size of the picture the agents see (:data:`VIEW_MAX_SIDE`)."""
        return self.need_image().view_size(VIEW_MAX_SIDE)

    def to_view(self, box: Box) -> Box:
        """A photograph box in the agents' picture's pixels."""
        image = self.need_image()
        vw, vh = self.view_size()
        sx, sy = vw / image.width, vh / image.height
        return (round(box[0] * sx, 1), round(box[1] * sy, 1), round(box[2] * sx, 1), round(box[3] * sy, 1))

    def from_view(self, box: Box) -> Box:
        """A box of the agents' picture in the photograph's pixels."""
        image = self.need_image()
        vw, vh = self.view_size()
        sx, sy = image.width / vw, image.height / vh
        return (box[0] * sx, box[1] * sy, box[2] * sx, box[3] * sy)


# -- inventory ----------------------------------------------------------------------------------


class InventoryEvidence(AgentOutput):
    """What the inventory agent is told besides the photograph."""

    image_width: int
    image_height: int
    hints: list[DetectedObject] = Field(default_factory=list, max_length=MAX_ITEMS)


class InventoryAgent(TaskAgent[PerceptionState, InventoryEvidence, Inventory]):
    """Lists every object of the photograph (see the module's docstring)."""

    name: ClassVar[str] = "perception"
    prompt: ClassVar[str] = "inventory"
    reply_tokens: ClassVar[tuple[int, int] | None] = (4000, 0)

    def gather(self, state: PerceptionState) -> InventoryEvidence:
        image = state.need_image()
        vw, vh = state.view_size()
        hints = [h.model_copy(update={"box": state.to_view(h.box)}) for h in state.hints] if (vw, vh) != (image.width, image.height) else state.hints
        return InventoryEvidence(image_width=vw, image_height=vh, hints=hints)

    def solve(self, evidence: InventoryEvidence) -> Inventory:
        if not evidence.hints:
            raise UsageError(
                "no object inventory for the photograph: the offline path has no detector of its own; pass "
                "detections (--detections boxes.json, COCO or an inventory JSON) or a vision model "
                "(--model openai:<model> with the `vision` setting on)"
            )
        return Inventory(objects=list(evidence.hints))

    def images(self, evidence: InventoryEvidence, state: PerceptionState) -> list[ImagePart]:
        return [ImagePart(png=state.need_image().png_bytes(max_side=VIEW_MAX_SIDE), label=_PHOTO_LABEL)]

    def check(self, output: Inventory, state: PerceptionState) -> list[str]:
        return inventory_problems(output.objects, *state.view_size())

    def apply(self, output: Inventory, state: PerceptionState) -> None:
        image = state.need_image()
        if state.view_size() == (image.width, image.height):
            state.inventory = [clipped(o, image.width, image.height) for o in output.objects]
        else:
            state.inventory = [clipped(o.model_copy(update={"box": state.from_view(o.box)}), image.width, image.height) for o in output.objects]


# -- verification -------------------------------------------------------------------------------


class MaskRow(AgentOutput):
    """One object's mask as the verifier sees it."""

    id: str
    label: str
    box: tuple[float, float, float, float]
    mask_box: tuple[float, float, float, float] | None = Field(description="Tight box of the mask; null when the mask is empty.")
    coverage: float = Field(description="Share of the box the mask fills (0-1).")
    on: str | None = None
    overlaps: list[str] = Field(default_factory=list, description="Objects of the same label whose boxes overlap this one by IoU >= 0.7.")
    inside: str | None = Field(default=None, description="A supporting object whose box holds this one's lower edge, when this one may rest on it.")


class VerifyEvidence(AgentOutput):
    """The masks of the current round and what earlier rounds asked."""

    image_width: int
    image_height: int
    round: int
    objects: list[MaskRow] = Field(max_length=MAX_ITEMS)
    memory: list[str] = Field(default_factory=list)


Action = Literal["resegment", "add", "remove", "set_support"]


class VerifyRequest(AgentOutput):
    """One correction of the inventory or its masks."""

    action: Action = Field(description="resegment (a wrong or empty mask), add (a missing instance), remove (a duplicate), set_support (a nested object).")
    object_id: str | None = Field(default=None, max_length=64, description="The object concerned (the new one's id for add).")
    label: str | None = Field(default=None, max_length=64, description="For add: the category.")
    box: tuple[float, float, float, float] | None = Field(default=None, description="For add, or resegment with a better box: [x0, y0, x1, y1].")
    on: str | None = Field(default=None, max_length=64, description="For set_support: the object it rests on.")
    reason: str = Field(default="", max_length=200)

    def words(self) -> str:
        """The request in one line (for the memory and the report)."""
        parts = [self.action, self.object_id or ""]
        if self.on:
            parts.append(f"on {self.on}")
        if self.box:
            parts.append("box [" + ", ".join(f"{v:.0f}" for v in self.box) + "]")
        return " ".join(p for p in parts if p)


class VerifyOutput(AgentOutput):
    """The corrections of one round; none means the masks are right."""

    requests: list[VerifyRequest] = Field(default_factory=list, max_length=MAX_ITEMS)


def support_candidate(obj: DetectedObject, others: list[DetectedObject]) -> str | None:
    """The object ``obj`` most likely rests on, from boxes alone: a small object (its category
    usually rests on surfaces) whose box's lower edge lies inside the box of furniture that
    supports things, above that box's own lower edge, and which is smaller than it. ``None``:
    it stands on the floor."""
    c = obj.category
    if obj.placement not in (None, "surface") or traits(c).placement != "surface":
        return None
    x0, y0, x1, y1 = obj.box
    foot_u, foot_v = (x0 + x1) / 2, y1
    best: tuple[float, str] | None = None
    for o in others:
        if o.id == obj.id or not traits(o.category).supports:
            continue
        a0, b0, a1, b1 = o.box
        area = (a1 - a0) * (b1 - b0)
        if not (a0 <= foot_u <= a1 and b0 <= foot_v <= b1 - 0.1 * (b1 - b0)):
            continue
        if area <= (x1 - x0) * (y1 - y0):
            continue
        if best is None or area < best[0]:
            best = (area, o.id)
    return best[1] if best else None


def mask_rows(inventory: list[DetectedObject], masks: dict[str, ObjectMask], view: Callable[[Box], Box] | None = None) -> list[MaskRow]:
    """The verifier's view of every object's mask; ``view`` maps photograph boxes to the picture
    the verifier sees (identity by default)."""
    to_view = view or (lambda b: b)
    rows = []
    for o in inventory:
        m = masks.get(o.id)
        box_area = max(1.0, (o.box[2] - o.box[0]) * (o.box[3] - o.box[1]))
        dupes = [p.id for p in inventory if p.id != o.id and p.category == o.category and box_iou(p.box, o.box) >= DUPLICATE_IOU]
        rows.append(
            MaskRow(
                id=o.id,
                label=o.label,
                box=tuple(round(v, 1) for v in to_view(o.box)),  # type: ignore[arg-type]
                mask_box=(tuple(round(v, 1) for v in to_view(m.bbox)) if m is not None and m.bbox else None),  # type: ignore[arg-type]
                coverage=round((m.area if m is not None else 0) / box_area, 3),
                on=o.on,
                overlaps=dupes,
                inside=None if o.on else support_candidate(o, inventory),
            )
        )
    return rows


def solve_verify(evidence: VerifyEvidence) -> VerifyOutput:
    """The rule verifier: remove the later of two same-label objects seen twice, segment again
    by box an object whose mask is (nearly) empty, and set the support of a nested object;
    nothing asked before is asked again."""
    asked = set(evidence.memory)
    out: list[VerifyRequest] = []
    removed: set[str] = set()
    for row in evidence.objects:
        if row.id in removed:
            continue
        for other in row.overlaps:
            if other not in removed and [r.id for r in evidence.objects].index(other) > [r.id for r in evidence.objects].index(row.id):
                removed.add(other)
                out.append(VerifyRequest(action="remove", object_id=other, reason=f"the same {row.label} as {row.id}"))
    for row in evidence.objects:
        if row.id in removed:
            continue
        if row.coverage < MIN_MASK_COVERAGE:
            out.append(VerifyRequest(action="resegment", object_id=row.id, box=row.box, reason=f"the mask fills {row.coverage:.0%} of the box"))
        if row.inside and not row.on:
            out.append(VerifyRequest(action="set_support", object_id=row.id, on=row.inside, reason=f"its lower edge lies on {row.inside}"))
    return VerifyOutput(requests=[r for r in out if r.words() not in asked])


class VerifyAgent(TaskAgent[PerceptionState, VerifyEvidence, VerifyOutput]):
    """Checks the masks of one round and asks for corrections (see the module's docstring)."""

    name: ClassVar[str] = "perception_verify"
    prompt: ClassVar[str] = "verify"
    reply_tokens: ClassVar[tuple[int, int] | None] = (300, 60)

    def gather(self, state: PerceptionState) -> VerifyEvidence:
        image = state.need_image()
        vw, vh = state.view_size()
        return VerifyEvidence(
            image_width=vw,
            image_height=vh,
            round=state.round,
            objects=mask_rows(state.inventory, state.masks, None if (vw, vh) == (image.width, image.height) else state.to_view),
            memory=list(state.memory),
        )

    def solve(self, evidence: VerifyEvidence) -> VerifyOutput:
        return solve_verify(evidence)

    def images(self, evidence: VerifyEvidence, state: PerceptionState) -> list[ImagePart]:
        return [ImagePart(png=mask_overlay(state.need_image(), state.inventory, state.masks), label=_MASKS_LABEL)]

    def check(self, output: VerifyOutput, state: PerceptionState) -> list[str]:
        width, height = state.view_size()
        ids = {o.id for o in state.inventory}
        problems = []
        for i, r in enumerate(output.requests):
            where = f"requests[{i}] ({r.action})"
            if r.action == "add":
                if not r.label or r.box is None:
                    problems.append(f"{where}: an added object needs a label and a box")
                    continue
                new = DetectedObject(id=r.object_id or "new", label=r.label, box=r.box)
                problems += [f"{where}: {p}" for p in inventory_problems([new], width, height)]
                if r.object_id in ids:
                    problems.append(f"{where}: id {r.object_id!r} is taken; choose a new id")
                continue
            if r.object_id not in ids:
                problems.append(f"{where}: {r.object_id!r} is not an object of the inventory; ids are {sorted(ids)[:40]}")
            if r.action == "set_support" and (r.on not in ids or r.on == r.object_id):
                problems.append(f"{where}: 'on' must name another object of the inventory")
            if r.box is not None:
                probe = DetectedObject(id="probe", label="probe", box=r.box)
                problems += [f"{where}: {p}" for p in inventory_problems([probe], width, height)]
            if r.words() in state.memory:
                problems.append(f"{where}: this was asked in an earlier round already ({r.words()}); ask for something else or nothing")
        return problems

    def apply(self, output: VerifyOutput, state: PerceptionState) -> None:
        """Keep the round's requests, boxes in the verifier's picture's pixels (as the memory has
        them); the caller scales them back when it applies them."""
        state.requests = list(output.requests)


_TINTS = np.array(
    [[230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200], [245, 130, 48], [145, 30, 180], [70, 240, 240], [240, 50, 230]],
    dtype=np.float64,
)


def mask_overlay(image: SceneImage, inventory: list[DetectedObject], masks: dict[str, ObjectMask], max_side: int = 1024) -> bytes:
    """The photograph with each mask tinted, each box outlined and labelled by id (PNG bytes)."""
    from PIL import Image, ImageDraw

    px = image.pixels.astype(np.float64)
    for i, o in enumerate(inventory):
        m = masks.get(o.id)
        if m is None or m.area == 0:
            continue
        x, y = m.origin
        h, w = m.pixels.shape
        region = px[y : y + h, x : x + w]
        tint = _TINTS[i % len(_TINTS)]
        region[m.pixels[: region.shape[0], : region.shape[1]]] = 0.55 * region[m.pixels[: region.shape[0], : region.shape[1]]] + 0.45 * tint
    img = Image.fromarray(px.clip(0, 255).astype(np.uint8))
    draw = ImageDraw.Draw(img)
    for i, o in enumerate(inventory):
        colour = tuple(int(v) for v in _TINTS[i % len(_TINTS)])
        draw.rectangle(o.box, outline=colour, width=max(1, image.width // 400))
        draw.text((o.box[0] + 3, o.box[1] + 2), o.id, fill=colour)
    if image.view_size(max_side) != img.size:
        img = img.resize(image.view_size(max_side), Image.Resampling.LANCZOS)
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()



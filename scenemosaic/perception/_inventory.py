"""The object inventory of a photograph: ids, labels, descriptions and pixel boxes.

One model for what a detector file holds and what the perception agent answers
(:class:`DetectedObject`), one check of it against the image (:func:`inventory_problems`), and
the reader of detection files (:func:`read_detections`): COCO (``images`` / ``categories`` /
``annotations`` with ``bbox`` = [x, y, w, h]) or the inventory's own JSON
(``{"objects": [{"id", "label", "box": [x0, y0, x1, y1]}]}``, what ``perception/inventory.json`` holds).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError

from scenemosaic.agents import MAX_ITEMS, AgentOutput
from scenemosaic.exceptions import ImportFormatError
from scenemosaic.scene import MAX_OBJECTS, normalize_category, sanitize_id, unique_id

__all__ = [
    "BOX_TOLERANCE_PX",
    "MIN_BOX_PX",
    "DetectedObject",
    "Inventory",
    "Placement",
    "box_iou",
    "clipped",
    "inventory_problems",
    "read_detections",
]

BOX_TOLERANCE_PX = 1.0
"""How far (pixels) a box may reach past the image's edge and still count as inside it (then clipped)."""
MIN_BOX_PX = 2.0
"""Narrowest box side (pixels) that can hold an object."""

Placement = Literal["floor", "surface", "wall", "ceiling"]


class DetectedObject(AgentOutput):
    """One object seen in the photograph."""

    id: str = Field(pattern=r"^[A-Za-z0-9_.\-]+$", max_length=64, description="Stable id, e.g. 'bed' or 'chair_2'.")
    label: str = Field(min_length=1, max_length=64, description="Category name, e.g. 'double_bed', 'office_chair'.")
    description: str = Field(default="", max_length=200, description="A few words telling it apart from the others.")
    box: tuple[float, float, float, float] = Field(
        description="Pixel box [x0, y0, x1, y1]: x to the right, y down, from the image's top-left corner."
    )
    placement: Placement | None = Field(
        default=None, description="Where it rests: floor, surface (on another object), wall or ceiling; null: usual for its label."
    )
    on: str | None = Field(default=None, max_length=64, description="Id of the object it stands on, when placement is 'surface'.")

    @property
    def category(self) -> str:
        """The normalized category of the label."""
        return normalize_category(self.label)


class Inventory(AgentOutput):
    """Every object of one photograph."""

    objects: list[DetectedObject] = Field(max_length=MAX_ITEMS)


def inventory_problems(objects: list[DetectedObject], width: int, height: int) -> list[str]:
    """What makes an inventory unusable on a ``width`` x ``height`` image, one sentence each
    (sent back to a model as they are): no objects, repeated ids, boxes that are not finite,
    inverted, thinner than :data:`MIN_BOX_PX` or outside the image (beyond :data:`BOX_TOLERANCE_PX`),
    ``on`` naming an unknown object or the object itself."""
    problems: list[str] = []
    if not objects:
        return ["the inventory is empty: list every piece of furniture and object you can see"]
    if len(objects) > MAX_OBJECTS:
        problems.append(f"{len(objects)} objects listed; at most {MAX_OBJECTS} are accepted")
    if all(max(abs(v) for v in o.box) <= 1.0 for o in objects):
        problems.append(
            f"every box lies within [0, 1]: boxes are pixel coordinates of the {width}x{height} image, not fractions of it"
        )
    ids = [o.id for o in objects]
    seen: set[str] = set()
    for oid in ids:
        if oid in seen:
            problems.append(f"id {oid!r} is used twice; give every object its own id")
        seen.add(oid)
    tol = BOX_TOLERANCE_PX
    for o in objects:
        x0, y0, x1, y1 = o.box
        where = f"object {o.id!r} ({o.label})"
        if not all(math.isfinite(v) for v in o.box):
            problems.append(f"{where}: box {list(o.box)} holds a value that is not a finite number")
            continue
        if x1 - x0 < MIN_BOX_PX or y1 - y0 < MIN_BOX_PX:
            problems.append(
                f"{where}: box {_fmt(o.box)} is inverted or thinner than {MIN_BOX_PX:g} pixels; boxes are [x0, y0, x1, y1] with x0 < x1, y0 < y1"
            )
        if x0 < -tol or y0 < -tol or x1 > width + tol or y1 > height + tol:
            problems.append(f"{where}: box {_fmt(o.box)} lies outside the {width}x{height} image")
        if o.on is not None and (o.on == o.id or o.on not in seen):
            problems.append(f"{where}: 'on' names {o.on!r}, which is not another object of the inventory")
    return problems


def box_iou(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> float:
    """Intersection over union of two pixel boxes [x0, y0, x1, y1]."""
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def clipped(obj: DetectedObject, width: int, height: int) -> DetectedObject:
    """``obj`` with its box clipped to the image (a box within the tolerance may reach past it)."""
    x0, y0, x1, y1 = obj.box
    box = (max(0.0, x0), max(0.0, y0), min(float(width), x1), min(float(height), y1))
    return obj if box == obj.box else obj.model_copy(update={"box": box})


def _fmt(box: tuple[float, float, float, float]) -> str:
    return "[" + ", ".join(f"{v:.1f}" for v in box) + "]"


def read_detections(path: str | Path, width: int, height: int, *, image_name: str | None = None) -> list[DetectedObject]:
    """Read a detection file for a ``width`` x ``height`` image (named ``image_name`` in a COCO file
    that lists several images) and check it whole: every problem is reported at once, as an
    :class:`~scenemosaic.exceptions.ImportFormatError` naming the file. Ids come from an
    annotation's ``attributes.object_id`` (or ``id``/``label`` in the inventory form), made unique."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise ImportFormatError("detections file not found", path=str(p)) from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ImportFormatError(f"not a readable JSON file ({exc})", path=str(p)) from exc
    if isinstance(data, dict) and "annotations" in data:
        objects = _from_coco(data, p, width, height, image_name)
    elif isinstance(data, dict) and "objects" in data:
        try:
            objects = Inventory.model_validate(data).objects
        except ValidationError as exc:
            raise ImportFormatError(_first_errors(exc), path=str(p)) from exc
    else:
        raise ImportFormatError(
            "expected COCO detections (an object with 'annotations') or an inventory (an object with 'objects')",
            path=str(p),
        )
    problems = inventory_problems(objects, width, height)
    if problems:
        raise ImportFormatError("; ".join(problems[:10]) + ("" if len(problems) <= 10 else f" (and {len(problems) - 10} more)"), path=str(p))
    return [clipped(o, width, height) for o in objects]


def _first_errors(exc: ValidationError) -> str:
    parts = []
    for err in exc.errors()[:5]:
        loc = ".".join(str(x) for x in err["loc"])
        parts.append(f"{loc}: {err['msg']}")
    return "; ".join(parts)


def _from_coco(data: dict[str, Any], path: Path, width: int, height: int, image_name: str | None) -> list[DetectedObject]:
    def fail(field: str, message: str) -> ImportFormatError:
        return ImportFormatError(message, path=str(path), field=field)

    images = data.get("images") or []
    if not isinstance(images, list):
        raise fail("images", "must be a list")
    image_id: Any = None
    if images:
        chosen = [im for im in images if isinstance(im, dict) and image_name and Path(str(im.get("file_name", ""))).name == image_name]
        if not chosen and len(images) == 1 and isinstance(images[0], dict):
            chosen = images
        if not chosen:
            raise fail("images", f"{len(images)} images listed and none is named {image_name!r}")
        entry = chosen[0]
        image_id = entry.get("id")
        w, h = entry.get("width"), entry.get("height")
        if (w is not None and w != width) or (h is not None and h != height):
            raise fail(
                "images", f"the detections describe a {w}x{h} image, but the photograph is {width}x{height}"
            )
    categories: dict[Any, str] = {}
    for i, c in enumerate(data.get("categories") or []):
        if not isinstance(c, dict) or "id" not in c or not isinstance(c.get("name"), str) or not c["name"].strip():
            raise fail(f"categories[{i}]", "each category needs an 'id' and a non-empty 'name'")
        categories[c["id"]] = c["name"].strip()
    annotations = data["annotations"]
    if not isinstance(annotations, list):
        raise fail("annotations", "must be a list")
    if len(annotations) > MAX_OBJECTS:
        raise fail("annotations", f"{len(annotations)} annotations; at most {MAX_OBJECTS} objects are accepted")
    taken: set[str] = set()
    out: list[DetectedObject] = []
    for i, a in enumerate(annotations):
        field = f"annotations[{i}]"
        if not isinstance(a, dict):
            raise fail(field, "must be an object")
        if image_id is not None and a.get("image_id", image_id) != image_id:
            continue
        label = categories.get(a.get("category_id")) if "category_id" in a else a.get("label")
        if not isinstance(label, str):
            raise fail(field, f"category_id {a.get('category_id')!r} is not among the file's categories")
        bbox = a.get("bbox")
        if (
            not isinstance(bbox, list)
            or len(bbox) != 4
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in bbox)
        ):
            raise fail(f"{field}.bbox", "must be [x, y, width, height] in pixels")
        x, y, w, h = (float(v) for v in bbox)
        raw_attrs = a.get("attributes")
        attrs: dict[str, Any] = raw_attrs if isinstance(raw_attrs, dict) else {}
        raw_id = str(attrs.get("object_id") or f"{normalize_category(label)}_{a.get('id', i)}")
        oid = unique_id(sanitize_id(raw_id), taken)
        placement = attrs.get("placement")
        try:
            out.append(
                DetectedObject(
                    id=oid,
                    label=label[:64],
                    description=str(attrs.get("description") or "")[:200],
                    box=(x, y, x + w, y + h),
                    placement=placement if placement in ("floor", "surface", "wall", "ceiling") else None,
                    on=attrs.get("on") if isinstance(attrs.get("on"), str) else None,
                )
            )
        except ValidationError as exc:
            raise fail(field, _first_errors(exc)) from exc
    if not out and images:
        raise fail("annotations", "no annotation belongs to the photograph: nothing to reconstruct")
    return out

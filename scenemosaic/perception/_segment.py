"""Segmenters: (image, text prompt, box) -> the object's mask.

:class:`Segmenter` is the protocol; adapters:

* ``grabcut`` (:class:`GrabCutSegmenter`) — OpenCV's GrabCut seeded by the box: classical,
  offline, CPU only (extra ``perception``: ``pip install 'scenemosaic[perception]'``);
* ``box`` (:class:`BoxSegmenter`) — the box itself (no dependency; a last resort);
* ``sam3`` (:class:`Sam3Segmenter`) — SAM 3 in-process, when the ``sam3`` package and its
  weights are installed (``pip install 'scenemosaic[sam3]'``);
* ``http://...`` (:class:`HTTPSegmenter`) — a SAM 3 (or any) server speaking the small JSON
  protocol of ``docs/perception.md``.

:func:`segmenter_for` builds one from its name.
"""

from __future__ import annotations

import base64
import io
from collections.abc import Awaitable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import structlog

from scenemosaic.exceptions import BackendError, MissingExtraError, UsageError
from scenemosaic.models import CallClock
from scenemosaic.perception._image import SceneImage
from scenemosaic.perception._inventory import box_iou

__all__ = [
    "PERCEPTION_INSTALL",
    "SAM3_INSTALL",
    "SEGMENTER_NAMES",
    "BoxSegmenter",
    "GrabCutSegmenter",
    "HTTPSegmenter",
    "ObjectMask",
    "Sam3Segmenter",
    "Segmenter",
    "segmenter_for",
]

log = structlog.get_logger(__name__)

PERCEPTION_INSTALL = "pip install 'scenemosaic[perception]'"
SAM3_INSTALL = "pip install 'scenemosaic[sam3]'"
SEGMENTER_NAMES = ("auto", "grabcut", "box", "sam3", "http://HOST:PORT/segment")
"""What ``--segmenter`` accepts."""

Box = tuple[float, float, float, float]


@dataclass(frozen=True)
class ObjectMask:
    """A binary mask stored as its tight crop: ``pixels`` (bool, rows x columns) placed at
    ``origin`` = (x, y) in the image. An empty mask has a 0 x 0 crop."""

    origin: tuple[int, int]
    pixels: np.ndarray

    @classmethod
    def from_full(cls, full: np.ndarray, offset: tuple[int, int] = (0, 0)) -> ObjectMask:
        """The tight crop of a boolean mask whose top-left pixel lies at ``offset`` in the image
        (a full-image mask by default)."""
        full = np.asarray(full, dtype=bool)
        ys, xs = np.nonzero(full)
        if len(xs) == 0:
            return cls((0, 0), np.zeros((0, 0), dtype=bool))
        x0, x1, y0, y1 = int(xs.min()), int(xs.max()) + 1, int(ys.min()), int(ys.max()) + 1
        return cls((offset[0] + x0, offset[1] + y0), full[y0:y1, x0:x1].copy())

    @property
    def area(self) -> int:
        """Pixels in the mask."""
        return int(self.pixels.sum())

    @property
    def bbox(self) -> Box | None:
        """The tight box [x0, y0, x1, y1] of the mask's pixels (``None`` when empty)."""
        if self.area == 0:
            return None
        ys, xs = np.nonzero(self.pixels)
        x, y = self.origin
        return (float(x + xs.min()), float(y + ys.min()), float(x + xs.max() + 1), float(y + ys.max() + 1))

    def full(self, width: int, height: int) -> np.ndarray:
        """The mask as a full ``height`` x ``width`` boolean image."""
        out = np.zeros((height, width), dtype=bool)
        x, y = self.origin
        h, w = self.pixels.shape
        out[y : y + h, x : x + w] = self.pixels[: max(0, height - y), : max(0, width - x)]
        return out

    def png(self, width: int, height: int) -> bytes:
        """The full mask as a one-channel PNG (255 = object)."""
        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(self.full(width, height).astype(np.uint8) * 255).save(buf, format="PNG")
        return buf.getvalue()

    def overlap(self, other: ObjectMask) -> int:
        """Pixels both masks hold."""
        ax, ay = self.origin
        bx, by = other.origin
        ah, aw = self.pixels.shape
        bh, bw = other.pixels.shape
        x0, y0 = max(ax, bx), max(ay, by)
        x1, y1 = min(ax + aw, bx + bw), min(ay + ah, by + bh)
        if x1 <= x0 or y1 <= y0:
            return 0
        a = self.pixels[y0 - ay : y1 - ay, x0 - ax : x1 - ax]
        b = other.pixels[y0 - by : y1 - by, x0 - bx : x1 - bx]
        return int(np.logical_and(a, b).sum())


@runtime_checkable
class Segmenter(Protocol):
    """Anything that cuts one object out of an image, given its label and a box around it.

    ``segment`` is a plain function (perception runs it in a worker thread) or a coroutine
    function (awaited on the event loop, as the HTTP client is: a signal interrupts it at once)."""

    name: str

    def segment(self, image: SceneImage, prompt: str, box: Box) -> ObjectMask | Awaitable[ObjectMask]:
        """The object's mask; an empty mask when nothing was found."""
        ...


def _box_pixels(box: Box, width: int, height: int) -> tuple[int, int, int, int]:
    x0, y0, x1, y1 = box
    return (
        max(0, min(width - 1, int(np.floor(x0)))),
        max(0, min(height - 1, int(np.floor(y0)))),
        max(1, min(width, int(np.ceil(x1)))),
        max(1, min(height, int(np.ceil(y1)))),
    )


class BoxSegmenter:
    """The box as the mask: no dependency, no refinement (the reconstructors only need the box)."""

    name = "box"

    def segment(self, image: SceneImage, prompt: str, box: Box) -> ObjectMask:
        x0, y0, x1, y1 = _box_pixels(box, image.width, image.height)
        return ObjectMask((x0, y0), np.ones((max(1, y1 - y0), max(1, x1 - x0)), dtype=bool))


class GrabCutSegmenter:
    """OpenCV GrabCut seeded by the box: the box's outside is background, its inside probably
    foreground; colour models of both are refined for ``iterations`` rounds. The crop around
    the box (with a ``margin`` of background) is scaled so its longer side is at most
    ``max_side`` pixels, which bounds the time per object (0.1-0.25 s on the shipped renders
    here, ``benchmarks/perception.py``)."""

    name = "grabcut"

    def __init__(self, iterations: int = 4, margin: float = 0.15, max_side: int = 384, seed: int = 0) -> None:
        try:
            import cv2
        except ImportError as exc:
            raise MissingExtraError(
                f"the grabcut segmenter needs OpenCV, which is not installed: {PERCEPTION_INSTALL} "
                "(or choose --segmenter box, sam3 or http://...)"
            ) from exc
        self._cv2 = cv2
        self.iterations = iterations
        self.margin = margin
        self.max_side = max_side
        self.seed = seed

    def segment(self, image: SceneImage, prompt: str, box: Box) -> ObjectMask:
        cv2 = self._cv2
        w, h = image.width, image.height
        bx0, by0, bx1, by1 = _box_pixels(box, w, h)
        mx, my = int((bx1 - bx0) * self.margin) + 2, int((by1 - by0) * self.margin) + 2
        cx0, cy0, cx1, cy1 = max(0, bx0 - mx), max(0, by0 - my), min(w, bx1 + mx), min(h, by1 + my)
        crop = np.ascontiguousarray(image.pixels[cy0:cy1, cx0:cx1, ::-1])  # OpenCV wants BGR
        scale = min(1.0, self.max_side / max(crop.shape[:2]))
        if scale < 1.0:
            crop = cv2.resize(crop, (max(1, round(crop.shape[1] * scale)), max(1, round(crop.shape[0] * scale))), interpolation=cv2.INTER_AREA)
        rx0, ry0 = int((bx0 - cx0) * scale), int((by0 - cy0) * scale)
        rw = max(1, min(crop.shape[1] - rx0, int(np.ceil((bx1 - bx0) * scale))))
        rh = max(1, min(crop.shape[0] - ry0, int(np.ceil((by1 - by0) * scale))))
        mask = np.zeros(crop.shape[:2], np.uint8)
        if rw < 3 or rh < 3 or (rw >= crop.shape[1] and rh >= crop.shape[0]) or float(crop.std()) < 2.0:
            # too small to model, no background around it (the box covers the whole image), or no
            # colour to tell object from background (GrabCut's colour models degenerate, slowly)
            return BoxSegmenter().segment(image, prompt, box)
        bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
        cv2.setRNGSeed(self.seed)  # GrabCut seeds its colour models by k-means: same input, same mask
        try:
            cv2.grabCut(crop, mask, (rx0, ry0, rw, rh), bgd, fgd, self.iterations, cv2.GC_INIT_WITH_RECT)
        except cv2.error as exc:  # e.g. a uniform crop: no colour model can be fitted
            log.warning("grabcut_failed_box_kept", prompt=prompt, error=str(exc).splitlines()[-1][:200])
            return BoxSegmenter().segment(image, prompt, box)
        fg = (mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)
        if scale < 1.0:
            fg = cv2.resize(fg.astype(np.uint8), (cx1 - cx0, cy1 - cy0), interpolation=cv2.INTER_NEAREST).astype(bool)
        inside = fg[by0 - cy0 : by1 - cy0, bx0 - cx0 : bx1 - cx0]  # nothing outside the box belongs to it
        return ObjectMask.from_full(inside, offset=(bx0, by0))


def _as_numpy(value: Any) -> np.ndarray:
    if hasattr(value, "detach"):
        value = value.detach()
    if hasattr(value, "cpu"):
        value = value.cpu()
    return np.asarray(value)


class Sam3Segmenter:
    """SAM 3 in-process (``sam3`` package, its weights from Hugging Face): the label is the text
    prompt, and of the instances found the one whose box overlaps the given box most is kept."""

    name = "sam3"

    def __init__(self, processor: Any = None) -> None:
        if processor is None:
            try:
                from sam3.model.sam3_image_processor import Sam3Processor
                from sam3.model_builder import build_sam3_image_model
            except ImportError as exc:
                raise MissingExtraError(
                    f"the sam3 segmenter needs the SAM 3 package and weights, which are not installed: {SAM3_INSTALL} "
                    "(weights: accept the licence of facebook/sam3 on Hugging Face, then `hf auth login`), or point to a "
                    "server with --segmenter http://HOST:PORT/segment, or use --segmenter grabcut"
                ) from exc
            processor = Sam3Processor(build_sam3_image_model())
        self._processor = processor
        self._state: tuple[SceneImage, Any] | None = None

    def segment(self, image: SceneImage, prompt: str, box: Box) -> ObjectMask:
        from PIL import Image

        if self._state is None or self._state[0] is not image:
            self._state = (image, self._processor.set_image(Image.fromarray(image.pixels)))
        output = self._processor.set_text_prompt(state=self._state[1], prompt=prompt.replace("_", " "))
        masks = _as_numpy(output["masks"])
        boxes = _as_numpy(output["boxes"]).reshape(-1, 4)
        if masks.ndim == 4:
            masks = masks[:, 0]
        if len(boxes) == 0:
            return ObjectMask((0, 0), np.zeros((0, 0), dtype=bool))
        best = max(range(len(boxes)), key=lambda i: box_iou(tuple(float(v) for v in boxes[i]), box))  # type: ignore[arg-type]
        return ObjectMask.from_full(masks[best] > 0.5)


class HTTPSegmenter:
    """A segmentation server: ``POST url`` with ``{"image": <base64 PNG>, "prompt", "box": [x0, y0,
    x1, y1]}``, answered by ``{"mask": <base64 PNG, nonzero = object>}`` or ``{"masks": [...],
    "scores": [...]}`` (the best score is kept). Retries 429/5xx and time-outs under the run's clock
    (``clock``: its request time-out and deadline; ``docs/perception.md``)."""

    name = "http"

    def __init__(self, url: str, *, timeout_s: float = 60.0, clock: CallClock | None = None, transport: Any = None) -> None:
        from scenemosaic.perception._http import JSONService

        self.url = url
        self._service = JSONService(url, what="segmenter", timeout_s=timeout_s, clock=clock, transport=transport)
        self._image_b64: tuple[SceneImage, str] | None = None

    async def segment(self, image: SceneImage, prompt: str, box: Box) -> ObjectMask:
        """The mask the server answers for ``prompt`` inside ``box``."""
        if self._image_b64 is None or self._image_b64[0] is not image:
            self._image_b64 = (image, base64.b64encode(image.png_bytes()).decode("ascii"))
        reply = await self._service.post({"image": self._image_b64[1], "prompt": prompt, "box": [round(v, 2) for v in box]})
        encoded = reply.get("mask")
        candidates = reply.get("masks")
        if encoded is None and isinstance(candidates, list) and candidates:
            scores = reply.get("scores")
            if isinstance(scores, list) and len(scores) == len(candidates):
                encoded = candidates[int(np.argmax([float(s) for s in scores]))]
            else:
                encoded = candidates[0]
        if not isinstance(encoded, str):
            raise BackendError(f"segmenter {self.url} answered without a 'mask' (base64 PNG): keys {sorted(reply)[:10]}")
        full = _decode_mask(encoded, self.url)
        if full.shape != (image.height, image.width):
            raise BackendError(
                f"segmenter {self.url} answered a {full.shape[1]}x{full.shape[0]} mask for a {image.width}x{image.height} image"
            )
        return ObjectMask.from_full(full)

    async def aclose(self) -> None:
        """Close the HTTP client."""
        await self._service.aclose()


def _decode_mask(encoded: str, source: str) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(base64.b64decode(encoded, validate=True))) as img:
            return np.asarray(img.convert("L")) > 0
    except (ValueError, UnidentifiedImageError, OSError) as exc:
        raise BackendError(f"{source} answered a mask that is not a base64 PNG ({exc})") from exc


def segmenter_for(spec: str | Segmenter, *, clock: CallClock | None = None) -> Segmenter:
    """A segmenter from its name (``auto``, ``grabcut``, ``box``, ``sam3`` or an ``http(s)://`` URL)
    or the object itself. ``auto``: SAM 3 when installed, else GrabCut when OpenCV is, else the box.
    ``clock``: the run's clock, which bounds an HTTP segmenter's calls."""
    if not isinstance(spec, str):
        return spec
    name = spec.strip()
    if name.startswith(("http://", "https://")):
        return HTTPSegmenter(name, clock=clock)
    if name == "grabcut":
        return GrabCutSegmenter()
    if name == "box":
        return BoxSegmenter()
    if name == "sam3":
        return Sam3Segmenter()
    if name == "auto":
        for make in (Sam3Segmenter, GrabCutSegmenter):
            try:
                return make()
            except MissingExtraError:
                continue
        log.warning("segmenter_fallback_box", hint=PERCEPTION_INSTALL)
        return BoxSegmenter()
    raise UsageError(f"unknown segmenter {spec!r}; choose one of: {', '.join(SEGMENTER_NAMES)}")

"""The input photograph: checked before any work is done, and the pinhole camera it was taken with."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenemosaic.exceptions import ImportFormatError
from scenemosaic.scene import FloatArray

__all__ = [
    "DEFAULT_HFOV_DEG",
    "IMAGE_SUFFIXES",
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "MIN_IMAGE_SIDE",
    "Camera",
    "SceneImage",
    "is_image_path",
    "load_image",
]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff"})
"""File suffixes ``generate`` treats as a photograph of a room (the image front end)."""
MIN_IMAGE_SIDE = 32
"""Shortest side (pixels) of an image worth reading: below it no object can be made out."""
MAX_IMAGE_SIDE = 8192
"""Longest side (pixels) accepted; a larger photograph should be downscaled first."""
MAX_IMAGE_PIXELS = 40_000_000
"""Most pixels accepted (40 MP): checked from the file's header, before anything is decoded."""
DEFAULT_HFOV_DEG = 60.0
"""Horizontal field of view assumed when the file says nothing of its lens (no EXIF focal
length): a phone's main camera is 65-75 degrees, a render's default 60 (see ``docs/perception.md``)."""

_EXIF_IFD = 0x8769
_FOCAL_35MM = 0xA405  # FocalLengthIn35mmFilm
_FILM_WIDTH_MM = 36.0


def is_image_path(path: str | Path) -> bool:
    """Whether ``path`` names a photograph by its suffix (``.png``, ``.jpg``...)."""
    return Path(path).suffix.lower() in IMAGE_SUFFIXES


@dataclass(frozen=True)
class Camera:
    """A pinhole camera in OpenCV's frame: x right, y down, z forward; pixels from the top-left corner.

    ``source`` says where the focal length came from: ``exif``, ``default`` (the assumed field
    of view) or ``given``.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    source: str = "default"

    @classmethod
    def from_hfov(cls, width: int, height: int, hfov_deg: float, source: str = "given") -> Camera:
        """Square pixels, principal point at the image centre, horizontal field of view ``hfov_deg``."""
        if not 5.0 <= hfov_deg <= 170.0:
            raise ImportFormatError(f"horizontal field of view must lie in [5, 170] degrees, got {hfov_deg}")
        f = 0.5 * width / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(width, height, f, f, width / 2.0, height / 2.0, source)

    @property
    def hfov_deg(self) -> float:
        """Horizontal field of view, degrees."""
        return math.degrees(2.0 * math.atan(0.5 * self.width / self.fx))

    @property
    def matrix(self) -> FloatArray:
        """The 3x3 intrinsic matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def ray(self, u: float, v: float) -> FloatArray:
        """Direction (not normalized, z = 1) of the ray through pixel position (u, v)."""
        return np.array([(u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0])

    def project(self, points: FloatArray) -> FloatArray:
        """Pixel positions (n, 2) of camera-frame points (n, 3) in front of the camera."""
        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        z = np.maximum(p[:, 2], 1e-9)
        return np.stack([self.fx * p[:, 0] / z + self.cx, self.fy * p[:, 1] / z + self.cy], axis=1)


@dataclass
class SceneImage:
    """A checked photograph: its file, size, the lens its EXIF names, and (on first use) its pixels."""

    path: Path
    width: int
    height: int
    focal_35mm: float | None = None
    """EXIF ``FocalLengthIn35mmFilm`` (millimetres), when the file has it."""
    _pixels: np.ndarray | None = field(default=None, repr=False)

    @property
    def pixels(self) -> np.ndarray:
        """RGB pixels, shape (height, width, 3), uint8 (decoded once)."""
        if self._pixels is None:
            self._pixels = _decode(self.path)
        return self._pixels

    def camera(self, hfov_deg: float | None = None) -> Camera:
        """The camera: ``hfov_deg`` when given, else from the EXIF focal length, else :data:`DEFAULT_HFOV_DEG`."""
        if hfov_deg is not None:
            return Camera.from_hfov(self.width, self.height, hfov_deg, "given")
        if self.focal_35mm:
            # the 35 mm equivalent refers to a 36 mm wide frame along the image's longer side
            long_side = max(self.width, self.height)
            hfov_long = 2.0 * math.atan(_FILM_WIDTH_MM / (2.0 * self.focal_35mm))
            f = 0.5 * long_side / math.tan(hfov_long / 2.0)
            return Camera(self.width, self.height, f, f, self.width / 2.0, self.height / 2.0, "exif")
        return Camera.from_hfov(self.width, self.height, DEFAULT_HFOV_DEG, "default")

    def view_size(self, max_side: int | None) -> tuple[int, int]:
        """Width and height of the image downscaled so its longer side is at most ``max_side``."""
        s = 1.0 if max_side is None else min(1.0, max_side / max(self.width, self.height))
        return max(1, round(self.width * s)), max(1, round(self.height * s))

    def png_bytes(self, max_side: int | None = None) -> bytes:
        """The image as PNG bytes, downscaled to :meth:`view_size` of ``max_side``."""
        import io

        from PIL import Image

        img = Image.fromarray(self.pixels)
        if self.view_size(max_side) != img.size:
            img = img.resize(self.view_size(max_side), Image.Resampling.LANCZOS)
        buf = io.BytesIO()
        img.save(buf, format="PNG")
        return buf.getvalue()


def load_image(path: str | Path) -> SceneImage:
    """Open and check a photograph, reading only its header: the size must lie within
    [:data:`MIN_IMAGE_SIDE`, :data:`MAX_IMAGE_SIDE`] pixels per side and :data:`MAX_IMAGE_PIXELS`
    in all. A file that is not an image, or that is cut short, raises
    :class:`~scenemosaic.exceptions.ImportFormatError` naming it; so does any size out of range.
    The pixels are decoded (and checked whole) here too, so a corrupt file fails before any work."""
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    if not p.is_file():
        raise ImportFormatError("image not found", path=str(p))
    limits = f"the limit is {MAX_IMAGE_SIDE} pixels per side and {MAX_IMAGE_PIXELS // 1_000_000} MP in all: downscale it first"
    try:
        with Image.open(p) as img:
            width, height = img.size
            focal = _exif_focal_35mm(img)
    except Image.DecompressionBombError as exc:  # Pillow refuses sizes far past ours before we see them
        raise ImportFormatError(f"image is far too large ({exc}); {limits}", path=str(p)) from exc
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise ImportFormatError(f"not a readable image ({type(exc).__name__}: {exc})", path=str(p)) from exc
    if min(width, height) < MIN_IMAGE_SIDE:
        raise ImportFormatError(
            f"image is {width}x{height} pixels; at least {MIN_IMAGE_SIDE} pixels per side are needed to make out objects",
            path=str(p),
        )
    if max(width, height) > MAX_IMAGE_SIDE or width * height > MAX_IMAGE_PIXELS:
        raise ImportFormatError(f"image is {width}x{height} pixels; {limits}", path=str(p))
    image = SceneImage(p, width, height, focal)
    image._pixels = _decode(p)
    return image


def _exif_focal_35mm(img: object) -> float | None:
    try:
        exif = img.getexif()  # type: ignore[attr-defined]
        value = exif.get_ifd(_EXIF_IFD).get(_FOCAL_35MM) or exif.get(_FOCAL_35MM)
        focal = float(value) if value else None
    except Exception:
        return None
    return focal if focal is not None and 5.0 <= focal <= 2000.0 else None


def _decode(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            img.load()
            rgb = np.asarray(img.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise ImportFormatError(f"image data is corrupt ({type(exc).__name__}: {exc})", path=str(path)) from exc
    return rgb

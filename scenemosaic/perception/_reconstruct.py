"""Reconstructors: (image, masks, inventory) -> each object's box or mesh and pose in the camera frame.

:class:`Reconstructor` is the protocol; its result is a :class:`Reconstruction` in OpenCV's
camera frame (x right, y down, z forward, metres), which :func:`~scenemosaic.perception.recover_frame`
turns into a Z-up world. Adapters:

* ``box-lifter`` (:class:`~scenemosaic.perception.BoxLifter`, ``_lift.py``) — offline
  single-view metrology: a coarse prior from boxes and category sizes;
* ``sam3d`` (:class:`Sam3dReconstructor`) — SAM 3D Objects in-process (its ``inference``
  module and checkpoints, installed from its repository: :data:`SAM3D_INSTALL`);
* ``http://...`` (:class:`HTTPReconstructor`) — a SAM 3D server speaking the JSON protocol of
  ``docs/perception.md``.
"""

from __future__ import annotations

import base64
import io
import os
from collections.abc import Awaitable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from scenemosaic.exceptions import BackendError, MissingExtraError, UsageError
from scenemosaic.models import CallClock
from scenemosaic.perception._image import Camera, SceneImage
from scenemosaic.perception._inventory import DetectedObject, Placement
from scenemosaic.perception._segment import ObjectMask
from scenemosaic.scene import FloatArray

__all__ = [
    "RECONSTRUCTOR_NAMES",
    "SAM3D_INSTALL",
    "HTTPReconstructor",
    "LiftedObject",
    "Reconstruction",
    "Reconstructor",
    "Sam3dReconstructor",
    "SeenObject",
]

SAM3D_INSTALL = (
    "SAM 3D Objects is not on PyPI: install it from https://github.com/facebookresearch/sam-3d-objects "
    "(its environment and checkpoints) and put its notebook/ folder on PYTHONPATH"
)
RECONSTRUCTOR_NAMES = ("auto", "box-lifter", "sam3d[:CONFIG.yaml]", "http://HOST:PORT/reconstruct")
"""What ``--reconstructor`` accepts."""

# PyTorch3D's camera (x left, y up, z forward), used by SAM 3D's pose output, to OpenCV's.
_P3D_TO_CV = np.diag([-1.0, -1.0, 1.0])
# glTF / SAM 3D meshes are Y-up with the front along +Z; the scene's objects are Z-up, front -Y.
_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class SeenObject:
    """One object as perception saw it: the inventory entry, its mask, where it rests."""

    detection: DetectedObject
    mask: ObjectMask
    placement: Placement
    parent: str | None = None


@dataclass(frozen=True)
class LiftedObject:
    """One reconstructed object in the camera frame.

    ``position``: its bottom centre; ``rotation``: camera-from-object (the object's local frame
    is the scene's: Z up, front along -Y); ``extents``: its local size (w, d, h) in metres;
    ``mesh``: mesh bytes (GLB) in that local frame, bottom centre at the origin, or ``None`` for a
    procedural model of the category.
    """

    id: str
    category: str
    placement: Placement
    position: FloatArray
    rotation: FloatArray
    extents: tuple[float, float, float]
    parent: str | None = None
    description: str = ""
    mesh: bytes | None = None


@dataclass
class Reconstruction:
    """A reconstructor's result: every object in the camera frame, the floor plane when the
    reconstructor knows it (``floor_up``: unit normal pointing up, in camera coordinates;
    ``camera_height``: the camera's distance to the floor), and figures for the report."""

    objects: list[LiftedObject]
    floor_up: FloatArray | None = None
    camera_height: float | None = None
    yaw_hint: float | None = None
    """The room's dominant horizontal direction in the floor frame the reconstructor used
    (radians, modulo 90 degrees), when it measured one."""
    report: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class Reconstructor(Protocol):
    """Anything that lifts the segmented objects of a photograph into 3D."""

    name: str

    def reconstruct(
        self, image: SceneImage, camera: Camera, objects: Sequence[SeenObject]
    ) -> Reconstruction | Awaitable[Reconstruction]:
        """Every object's box or mesh and pose in the camera frame (a plain function runs in a
        worker thread; a coroutine function is awaited on the event loop, as the HTTP client is)."""
        ...


def _quat_matrix(q: Sequence[float]) -> FloatArray:
    w, x, y, z = (float(v) for v in q)
    n = np.sqrt(w * w + x * x + y * y + z * z)
    if not np.isfinite(n) or n < 1e-9:
        raise BackendError(f"rotation quaternion {list(q)} is not a rotation")
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _lifted_from_pose(
    seen: SeenObject, glb_yup: bytes, translation: Sequence[float], rotation: Sequence[float], scale: Sequence[float] | float, source: str
) -> LiftedObject:
    """A SAM 3D style answer (Y-up mesh, pose in PyTorch3D's camera frame) as a :class:`LiftedObject`."""
    import trimesh

    values = [*translation, *rotation, *(scale if isinstance(scale, Sequence) else [scale])]
    if not all(np.isfinite(float(v)) for v in values):
        raise BackendError(f"{source} answered a pose with values that are not finite numbers: {values}")
    s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
    if s.min() <= 0:
        raise BackendError(f"{source} answered a non-positive scale {s.tolist()}")
    try:
        mesh: Any = trimesh.load(io.BytesIO(glb_yup), file_type="glb", force="mesh")
    except Exception as exc:
        raise BackendError(f"{source} answered a mesh that is not a readable GLB ({type(exc).__name__}: {exc})") from exc
    verts = np.asarray(mesh.vertices, dtype=np.float64) * s  # object frame, Y up, scaled
    r_cam_obj = _P3D_TO_CV @ _quat_matrix(rotation)  # camera(OpenCV) <- object(Y up)
    t_cam = _P3D_TO_CV @ np.asarray(translation, dtype=np.float64)
    z_up = verts @ _Y_UP_TO_Z_UP.T  # object frame, Z up
    lo, hi = z_up.min(axis=0), z_up.max(axis=0)
    bottom = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    local = trimesh.Trimesh(z_up - bottom, np.asarray(mesh.faces), process=False)
    r_cam_local = r_cam_obj @ _Y_UP_TO_Z_UP.T
    position = t_cam + r_cam_local @ bottom
    size = hi - lo
    return LiftedObject(
        id=seen.detection.id,
        category=seen.detection.category,
        placement=seen.placement,
        position=position,
        rotation=r_cam_local,
        extents=(float(size[0]), float(size[1]), float(size[2])),
        parent=seen.parent,
        description=seen.detection.description,
        mesh=_glb_bytes(local),
    )


def _glb_bytes(mesh: Any) -> bytes:
    data = mesh.export(file_type="glb")
    if not isinstance(data, bytes):
        raise BackendError("the reconstructed mesh could not be written as GLB")
    return data


class Sam3dReconstructor:
    """SAM 3D Objects in-process: ``Inference(config)(image, mask, seed)`` per object, whose
    ``glb`` mesh and ``translation`` / ``rotation`` (w, x, y, z) / ``scale`` pose (PyTorch3D's
    camera frame) become a :class:`LiftedObject`. ``config``: the checkpoint's ``pipeline.yaml``
    (``$SCENEMOSAIC_SAM3D_CONFIG``, default ``checkpoints/hf/pipeline.yaml``)."""

    name = "sam3d"

    def __init__(self, config: str | None = None, *, inference: Any = None, seed: int = 0) -> None:
        self.seed = seed
        if inference is None:
            path = config or os.environ.get("SCENEMOSAIC_SAM3D_CONFIG") or "checkpoints/hf/pipeline.yaml"
            try:
                from inference import Inference  # SAM 3D Objects' notebook/inference.py
            except ImportError as exc:
                raise MissingExtraError(
                    f"the sam3d reconstructor needs SAM 3D Objects and its checkpoints, which are not installed. {SAM3D_INSTALL}; "
                    "or point to a server with --reconstructor http://HOST:PORT/reconstruct, or use --reconstructor box-lifter"
                ) from exc
            if not Path(path).is_file():
                raise UsageError(f"SAM 3D checkpoint config {path} not found; set SCENEMOSAIC_SAM3D_CONFIG or pass sam3d:<pipeline.yaml>")
            inference = Inference(path, compile=False)
        self._inference = inference

    def reconstruct(self, image: SceneImage, camera: Camera, objects: Sequence[SeenObject]) -> Reconstruction:
        out = []
        for seen in objects:
            mask = seen.mask.full(image.width, image.height)
            result = self._inference(image.pixels, mask, seed=self.seed)
            glb = result["glb"]
            data = glb if isinstance(glb, bytes) else glb.export(file_type="glb")
            out.append(
                _lifted_from_pose(
                    seen, data, _flat(result["translation"]), _flat(result["rotation"]), _flat(result["scale"]), "sam3d"
                )
            )
        return Reconstruction(out, report={"reconstructor": self.name})


def _flat(value: Any) -> list[float]:
    if hasattr(value, "detach"):
        value = value.detach().cpu().numpy()
    return [float(v) for v in np.asarray(value, dtype=np.float64).reshape(-1)]


class HTTPReconstructor:
    """A reconstruction server: ``POST url`` with ``{"image": <base64 PNG>, "mask": <base64 PNG>,
    "label", "box"}`` per object, answered by ``{"glb": <base64 GLB, Y up>, "translation": [3],
    "rotation": [w, x, y, z], "scale": [3] or number}`` in PyTorch3D's camera frame (SAM 3D's
    convention). Retries 429/5xx and time-outs under the run's clock (``clock``: its request
    time-out and deadline)."""

    name = "http"

    def __init__(self, url: str, *, timeout_s: float = 300.0, clock: CallClock | None = None, transport: Any = None) -> None:
        from scenemosaic.perception._http import JSONService

        self.url = url
        self._service = JSONService(url, what="reconstructor", timeout_s=timeout_s, clock=clock, transport=transport)

    async def reconstruct(self, image: SceneImage, camera: Camera, objects: Sequence[SeenObject]) -> Reconstruction:
        """Every object as the server lifts it, one request per object."""
        picture = base64.b64encode(image.png_bytes()).decode("ascii")
        out = []
        for seen in objects:
            mask = base64.b64encode(seen.mask.png(image.width, image.height)).decode("ascii")
            reply = await self._service.post(
                {"image": picture, "mask": mask, "label": seen.detection.label, "box": list(seen.detection.box)}
            )
            try:
                glb = base64.b64decode(str(reply["glb"]), validate=True)
                translation, rotation, scale = reply["translation"], reply["rotation"], reply.get("scale", 1.0)
                if len(translation) != 3 or len(rotation) != 4:
                    raise ValueError("translation needs 3 numbers and rotation 4 (w, x, y, z)")
                t = [float(v) for v in translation]
                r = [float(v) for v in rotation]
                s: list[float] | float = [float(v) for v in scale] if isinstance(scale, list) else float(scale)
            except (KeyError, TypeError, ValueError) as exc:
                raise BackendError(f"reconstructor {self.url} answered for {seen.detection.id!r} without a usable glb/translation/rotation/scale: {exc}") from exc
            out.append(_lifted_from_pose(seen, glb, t, r, s, f"reconstructor {self.url}"))
        return Reconstruction(out, report={"reconstructor": self.name, "url": self.url})

    async def aclose(self) -> None:
        """Close the HTTP client."""
        await self._service.aclose()

"""Contract tests of the segmentation and reconstruction adapters, with fakes and httpx.MockTransport."""

from __future__ import annotations

import base64
import io
import json
import math
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import trimesh
from PIL import Image

from scenemosaic.exceptions import BackendError
from scenemosaic.perception import (
    BoxSegmenter,
    DetectedObject,
    GrabCutSegmenter,
    HTTPReconstructor,
    HTTPSegmenter,
    ObjectMask,
    Sam3dReconstructor,
    Sam3Segmenter,
    SceneImage,
    SeenObject,
    load_image,
    recover_frame,
)


@pytest.fixture
def image(tmp_path: Path) -> SceneImage:
    """A grey wall with a dark red block standing in front of it (the object)."""
    px = np.full((120, 160, 3), 200, dtype=np.uint8)
    px[40:100, 50:110] = (150, 20, 20)
    rng = np.random.default_rng(1)
    px = np.clip(px.astype(int) + rng.integers(-6, 6, px.shape), 0, 255).astype(np.uint8)
    p = tmp_path / "block.png"
    Image.fromarray(px).save(p)
    return load_image(p)


def _png(mask: np.ndarray) -> str:
    buf = io.BytesIO()
    Image.fromarray(mask.astype(np.uint8) * 255).save(buf, format="PNG")
    return base64.b64encode(buf.getvalue()).decode()


def test_object_mask_crop_round_trip() -> None:
    full = np.zeros((30, 40), dtype=bool)
    full[5:10, 7:20] = True
    m = ObjectMask.from_full(full)
    assert m.origin == (7, 5) and m.pixels.shape == (5, 13)
    assert m.area == 65 and m.bbox == (7.0, 5.0, 20.0, 10.0)
    assert np.array_equal(m.full(40, 30), full)
    other = ObjectMask.from_full(np.roll(full, 3, axis=1))
    assert m.overlap(other) == 5 * 10


def test_grabcut_finds_the_block_inside_a_loose_box(image: SceneImage) -> None:
    mask = GrabCutSegmenter().segment(image, "cabinet", (40, 30, 120, 110))
    truth = np.zeros((120, 160), dtype=bool)
    truth[40:100, 50:110] = True
    got = mask.full(160, 120)
    iou = (got & truth).sum() / (got | truth).sum()
    assert iou > 0.85, iou
    # the box alone would be much worse: GrabCut did cut the background away
    box = BoxSegmenter().segment(image, "cabinet", (40, 30, 120, 110)).full(160, 120)
    assert (box & truth).sum() / (box | truth).sum() < 0.6


async def test_http_segmenter_retries_a_busy_server_then_reads_the_mask(image: SceneImage) -> None:
    seen: list[dict[str, Any]] = []
    want = np.zeros((120, 160), dtype=bool)
    want[40:100, 50:110] = True

    def handler(request: httpx.Request) -> httpx.Response:
        body = json.loads(request.content)
        seen.append(body)
        if len(seen) == 1:
            return httpx.Response(503, headers={"Retry-After": "0"}, text="loading weights")
        assert body["prompt"] == "cabinet" and body["box"] == [40.0, 30.0, 120.0, 110.0]
        Image.open(io.BytesIO(base64.b64decode(body["image"]))).verify()  # the photograph, as PNG
        return httpx.Response(200, json={"masks": [_png(~want), _png(want)], "scores": [0.2, 0.9]})

    seg = HTTPSegmenter("http://sam3.test/segment", transport=httpx.MockTransport(handler))
    mask = await seg.segment(image, "cabinet", (40, 30, 120, 110))
    assert len(seen) == 2
    assert np.array_equal(mask.full(160, 120), want)


@pytest.mark.parametrize(
    ("reply", "message"),
    [
        (httpx.Response(200, text="<html>oops</html>"), "not JSON"),
        (httpx.Response(200, json={"masks": []}), "without a 'mask'"),
        (httpx.Response(200, json={"mask": "@@notbase64@@"}), "not a base64 PNG"),
        (httpx.Response(200, json={"mask": _png(np.ones((10, 10), dtype=bool))}), "10x10 mask for a 160x120 image"),
        (httpx.Response(404, text="no such route"), "HTTP 404"),
    ],
)
async def test_http_segmenter_bad_replies_are_backend_errors(image: SceneImage, reply: httpx.Response, message: str) -> None:
    seg = HTTPSegmenter("http://sam3.test/segment", transport=httpx.MockTransport(lambda request: reply))
    with pytest.raises(BackendError, match=message):
        await seg.segment(image, "cabinet", (40, 30, 120, 110))


async def test_http_segmenter_gives_up_on_a_server_that_stays_down(image: SceneImage) -> None:
    calls = []

    def handler(request: httpx.Request) -> httpx.Response:
        calls.append(1)
        return httpx.Response(500, headers={"Retry-After": "0"}, text="crashed")

    seg = HTTPSegmenter("http://sam3.test/segment", transport=httpx.MockTransport(handler))
    with pytest.raises(BackendError, match=r"failed after 4 attempts: HTTP 500"):
        await seg.segment(image, "cabinet", (40, 30, 120, 110))
    assert len(calls) == 4


class _FakeSam3Processor:
    """The ``Sam3Processor`` interface: set_image, then set_text_prompt -> masks, boxes, scores."""

    def __init__(self) -> None:
        self.prompts: list[str] = []
        self.images = 0

    def set_image(self, image: Image.Image) -> dict[str, Any]:
        self.images += 1
        return {"size": image.size}

    def set_text_prompt(self, *, state: dict[str, Any], prompt: str) -> dict[str, Any]:
        self.prompts.append(prompt)
        w, h = state["size"]
        a = np.zeros((1, h, w), dtype=np.float32)
        a[0, 0:20, 0:20] = 1.0
        b = np.zeros((1, h, w), dtype=np.float32)
        b[0, 40:100, 50:110] = 0.9
        return {"masks": np.stack([a, b]), "boxes": np.array([[0, 0, 20, 20], [50, 40, 110, 100]]), "scores": np.array([0.95, 0.8])}


def test_sam3_adapter_keeps_the_instance_matching_the_box(image: SceneImage) -> None:
    proc = _FakeSam3Processor()
    seg = Sam3Segmenter(processor=proc)
    mask = seg.segment(image, "tv_stand", (45, 35, 115, 105))
    assert mask.bbox == (50.0, 40.0, 110.0, 100.0)
    seg.segment(image, "chair", (0, 0, 25, 25))
    assert proc.prompts == ["tv stand", "chair"]
    assert proc.images == 1  # the image is encoded once per photograph


def _box_glb_yup(width: float, height: float, depth: float) -> bytes:
    """A box mesh in glTF's frame (Y up), centred on its middle, as SAM 3D emits."""
    data = trimesh.creation.box(extents=(width, height, depth)).export(file_type="glb")
    assert isinstance(data, bytes)
    return data


def _seen(oid: str = "cabinet", placement: str = "floor") -> SeenObject:
    det = DetectedObject(id=oid, label="cabinet", box=(50, 40, 110, 100))
    return SeenObject(det, ObjectMask((50, 40), np.ones((60, 60), dtype=bool)), placement)  # type: ignore[arg-type]


def _check_lifted_box(lifted: Any) -> None:
    # PyTorch3D translation (0.5, 0.2, 3) is OpenCV (-0.5, -0.2, 3); the box's bottom is 1 m lower (+y)
    assert np.allclose(lifted.position, [-0.5, 0.8, 3.0], atol=1e-6)
    assert np.allclose(lifted.extents, [1.0, 0.5, 2.0], atol=1e-6)
    assert np.allclose(lifted.rotation[:, 2], [0.0, -1.0, 0.0], atol=1e-9)  # local up = camera up (-y)
    mesh = trimesh.load(io.BytesIO(lifted.mesh), file_type="glb", force="mesh")
    assert np.allclose(mesh.bounds, [[-0.5, -0.25, 0.0], [0.5, 0.25, 2.0]], atol=1e-6)


async def test_http_reconstructor_answer_becomes_a_camera_frame_object(image: SceneImage) -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        body = json.loads(request.content)
        assert body["label"] == "cabinet" and set(body) == {"image", "mask", "label", "box"}
        glb = base64.b64encode(_box_glb_yup(1.0, 2.0, 0.5)).decode()
        return httpx.Response(200, json={"glb": glb, "translation": [0.5, 0.2, 3.0], "rotation": [1, 0, 0, 0], "scale": 1.0})

    rec = HTTPReconstructor("http://sam3d.test/reconstruct", transport=httpx.MockTransport(handler))
    result = await rec.reconstruct(image, image.camera(), [_seen()])
    _check_lifted_box(result.objects[0])


@pytest.mark.parametrize(
    "reply",
    [
        {"glb": "", "translation": [0, 0, 1], "rotation": [1, 0, 0, 0]},
        {"glb": base64.b64encode(b"glTF-but-not-really").decode(), "translation": [0, 0, 1], "rotation": [1, 0, 0, 0]},
        {"glb": base64.b64encode(_box_glb_yup(1, 1, 1)).decode(), "translation": [0, 0], "rotation": [1, 0, 0, 0]},
        {"glb": base64.b64encode(_box_glb_yup(1, 1, 1)).decode(), "translation": [0, float("nan"), 1], "rotation": [1, 0, 0, 0]},
        {"glb": base64.b64encode(_box_glb_yup(1, 1, 1)).decode(), "translation": [0, 0, 1], "rotation": [0, 0, 0, 0]},
    ],
)
async def test_http_reconstructor_bad_answers_are_backend_errors(image: SceneImage, reply: dict[str, Any]) -> None:
    rec = HTTPReconstructor("http://sam3d.test/reconstruct", transport=httpx.MockTransport(lambda r: httpx.Response(200, text=json.dumps(reply))))
    with pytest.raises(BackendError):
        await rec.reconstruct(image, image.camera(), [_seen()])


def test_sam3d_adapter_with_a_fake_inference(image: SceneImage) -> None:
    calls: list[tuple[tuple[int, ...], int]] = []

    def inference(pixels: np.ndarray, mask: np.ndarray, seed: int) -> dict[str, Any]:
        calls.append((mask.shape, int(mask.sum())))
        return {
            "glb": trimesh.load(io.BytesIO(_box_glb_yup(1.0, 2.0, 0.5)), file_type="glb", force="mesh"),
            "translation": np.array([[0.5, 0.2, 3.0]]),
            "rotation": np.array([[1.0, 0.0, 0.0, 0.0]]),
            "scale": np.array([[1.0, 1.0, 1.0]]),
        }

    result = Sam3dReconstructor(inference=inference).reconstruct(image, image.camera(), [_seen()])
    assert calls == [((120, 160), 3600)]
    _check_lifted_box(result.objects[0])


def test_frame_recovery_of_mesh_objects_puts_them_upright_on_the_floor(image: SceneImage) -> None:
    """Three boxes on a floor 1.4 m below a camera pitched 25 degrees down: gravity from their up
    axes, the floor from their bottoms, one identity per object."""
    pitch = math.radians(25.0)
    s, c = math.sin(pitch), math.cos(pitch)
    cam_from_floor = np.array([[1.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]])
    lifted = []
    from scenemosaic.perception import LiftedObject

    truth = {"a": (0.0, 3.0, 0.0), "b": (1.0, 4.0, 0.3), "c": (-1.2, 2.5, -0.4)}
    for oid, (x, y, yaw) in truth.items():
        rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
        p = cam_from_floor @ (np.array([x, y, 0.0]) - [0, 0, 1.4])
        lifted.append(LiftedObject(oid, "cabinet", "floor", p, cam_from_floor @ rz, (0.8, 0.4, 1.0), mesh=_box_glb_yup(1, 1, 1)))
    from scenemosaic.perception import Reconstruction

    scene = recover_frame(Reconstruction(lifted), image.camera(), mesh_uris={o.id: f"meshes/{o.id}.glb" for o in lifted})
    assert [o.id for o in scene.objects] == ["a", "b", "c"]
    assert all(abs(o.pose.position[2]) < 1e-9 for o in scene.objects)
    assert all(o.asset.kind == "mesh" and o.asset.uri == f"meshes/{o.id}.glb" for o in scene.objects)
    assert scene.metadata["camera"]["height_m"] == pytest.approx(1.4, abs=1e-6)
    assert scene.metadata["camera"]["floor_from"] == "objects"
    # distances between objects are kept; the room holds every object and the camera's foot
    pa, pb = (np.array(scene.objects[i].pose.position[:2]) for i in (0, 1))
    assert np.linalg.norm(pa - pb) == pytest.approx(math.hypot(1.0, 1.0), abs=1e-6)
    poly = np.array(scene.room.floor)
    cam = np.array(scene.metadata["camera"]["world_from_camera"]).reshape(4, 4)[:2, 3]
    for p in [*(np.array(o.pose.position[:2]) for o in scene.objects), cam]:
        assert poly[:, 0].min() < p[0] < poly[:, 0].max() and poly[:, 1].min() < p[1] < poly[:, 1].max()


def test_grabcut_gives_the_same_mask_every_time(image: SceneImage) -> None:
    """GrabCut starts its colour models with k-means: seeded, the same input gives the same mask
    (a replayed run sends the same mask overlay to the verifier)."""
    first = GrabCutSegmenter().segment(image, "cabinet", (40, 30, 120, 110))
    for _ in range(3):
        again = GrabCutSegmenter().segment(image, "cabinet", (40, 30, 120, 110))
        assert again.origin == first.origin and np.array_equal(again.pixels, first.pixels)

"""Bad photographs and detections fail early with a clear error and lose nothing."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from scenemosaic.exceptions import ImportFormatError, MissingExtraError, ModelConfigError, UsageError
from scenemosaic.models import FunctionModel, RulesModel
from scenemosaic.perception import (
    MAX_IMAGE_SIDE,
    DetectedObject,
    GrabCutSegmenter,
    Sam3dReconstructor,
    Sam3Segmenter,
    inventory_problems,
    load_image,
    perceive,
    read_detections,
    reconstructor_for,
    segmenter_for,
)
from scenemosaic.pipeline import GenerateConfig, generate


def _png_header_only(path: Path, width: int, height: int) -> None:
    """A PNG whose header claims ``width`` x ``height`` (its pixel data is a stub)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\x00" * 16)) + chunk(b"IEND", b""))


@pytest.fixture
def photo(tmp_path: Path) -> Path:
    rng = np.random.default_rng(0)
    p = tmp_path / "room.png"
    Image.fromarray(rng.integers(0, 255, (240, 320, 3), dtype=np.uint8)).save(p)
    return p


def _coco(path: Path, boxes: list[list[float]], *, width: int = 320, height: int = 240) -> Path:
    data = {
        "images": [{"id": 1, "file_name": "room.png", "width": width, "height": height}],
        "categories": [{"id": 1, "name": "chair"}, {"id": 2, "name": "desk"}],
        "annotations": [{"id": i + 1, "image_id": 1, "category_id": 1 + i % 2, "bbox": b} for i, b in enumerate(boxes)],
    }
    path.write_text(json.dumps(data))
    return path


def test_corrupt_image_names_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "broken.jpg"
    bad.write_bytes(b"\xff\xd8\xff\xe0 this is not really a jpeg")
    with pytest.raises(ImportFormatError, match=r"broken\.jpg.*not a readable image"):
        load_image(bad)


def test_truncated_image_fails_before_work(tmp_path: Path, photo: Path) -> None:
    cut = tmp_path / "cut.png"
    cut.write_bytes(photo.read_bytes()[:2000])
    with pytest.raises(ImportFormatError, match=r"cut\.png"):
        load_image(cut)


def test_one_pixel_image_is_refused(tmp_path: Path) -> None:
    p = tmp_path / "dot.png"
    Image.new("RGB", (1, 1)).save(p)
    with pytest.raises(ImportFormatError, match=r"1x1 pixels; at least 32"):
        load_image(p)


def test_huge_image_is_refused_from_its_header(tmp_path: Path) -> None:
    p = tmp_path / "huge.png"
    _png_header_only(p, 20000, 20000)  # 400 MP: Pillow itself refuses to open it
    with pytest.raises(ImportFormatError, match=rf"huge\.png: image is far too large.*the limit is {MAX_IMAGE_SIDE} pixels per side"):
        load_image(p)
    _png_header_only(p, 9000, 3000)  # 27 MP, but one side past the limit: refused from the header
    with pytest.raises(ImportFormatError, match=rf"9000x3000 pixels; the limit is {MAX_IMAGE_SIDE}"):
        load_image(p)


def test_box_outside_the_image(tmp_path: Path, photo: Path) -> None:
    det = _coco(tmp_path / "boxes.json", [[10, 10, 50, 50], [300, 200, 80, 80]])
    with pytest.raises(ImportFormatError, match=r"desk.*lies outside the 320x240 image"):
        read_detections(det, 320, 240, image_name="room.png")


def test_inverted_and_nan_boxes_are_named() -> None:
    objs = [
        DetectedObject(id="a", label="chair", box=(50, 50, 10, 60)),
        DetectedObject(id="b", label="desk", box=(1, 1, float("nan"), 20)),
    ]
    problems = inventory_problems(objs, 320, 240)
    assert any("'a'" in p and "inverted" in p for p in problems)
    assert any("'b'" in p and "not a finite number" in p for p in problems)


def test_normalized_boxes_are_named() -> None:
    objs = [DetectedObject(id="a", label="chair", box=(0.1, 0.2, 0.3, 0.5))]
    assert any("not fractions" in p for p in inventory_problems(objs, 320, 240))


def test_empty_inventory_is_an_error(tmp_path: Path) -> None:
    empty = tmp_path / "empty.json"
    empty.write_text(json.dumps({"objects": []}))
    with pytest.raises(ImportFormatError, match="inventory is empty"):
        read_detections(empty, 320, 240)
    coco = _coco(tmp_path / "none.json", [])
    with pytest.raises(ImportFormatError, match="nothing to reconstruct"):
        read_detections(coco, 320, 240, image_name="room.png")


def test_detections_for_another_image_size(tmp_path: Path) -> None:
    det = _coco(tmp_path / "boxes.json", [[10, 10, 50, 50]], width=640, height=480)
    with pytest.raises(ImportFormatError, match=r"640x480 image, but the photograph is 320x240"):
        read_detections(det, 320, 240, image_name="room.png")


def test_unknown_category_and_bad_bbox(tmp_path: Path) -> None:
    det = tmp_path / "b.json"
    det.write_text(json.dumps({"categories": [], "annotations": [{"id": 1, "category_id": 7, "bbox": [0, 0, 5, 5]}]}))
    with pytest.raises(ImportFormatError, match=r"annotations\[0\].*category_id 7"):
        read_detections(det, 320, 240)
    det.write_text(json.dumps({"categories": [{"id": 1, "name": "chair"}], "annotations": [{"id": 1, "category_id": 1, "bbox": "wide"}]}))
    with pytest.raises(ImportFormatError, match=r"bbox.*\[x, y, width, height\]"):
        read_detections(det, 320, 240)


def test_coco_ids_come_from_attributes_and_stay_unique(tmp_path: Path) -> None:
    det = tmp_path / "b.json"
    det.write_text(
        json.dumps(
            {
                "categories": [{"id": 1, "name": "Office Chair"}],
                "annotations": [
                    {"id": 4, "category_id": 1, "bbox": [0, 0, 50, 60], "attributes": {"object_id": "chair"}},
                    {"id": 5, "category_id": 1, "bbox": [60, 0, 50, 60], "attributes": {"object_id": "chair"}},
                    {"id": 6, "category_id": 1, "bbox": [120, 0, 50, 60]},
                ],
            }
        )
    )
    objs = read_detections(det, 320, 240)
    assert [o.id for o in objs] == ["chair", "chair_2", "office_chair_6"]
    assert objs[0].category == "office_chair"
    assert objs[1].box == (60.0, 0.0, 110.0, 60.0)


async def test_rules_model_without_detections_fails_before_work(photo: Path, tmp_path: Path) -> None:
    with pytest.raises(UsageError, match=r"--detections"):
        await perceive(photo, RulesModel(), out_dir=tmp_path / "out")
    assert not (tmp_path / "out").exists()


async def test_text_only_model_fails_before_work_naming_vision(photo: Path, tmp_path: Path) -> None:
    calls: list[str] = []

    def never(messages: object, context: object) -> dict[str, object]:
        calls.append("asked")
        return {"objects": []}

    model = FunctionModel(never, vision=False)
    with pytest.raises(ModelConfigError, match=r"`vision` setting"):
        await perceive(photo, model, out_dir=tmp_path / "out")
    assert calls == []
    assert not (tmp_path / "out").exists()


def test_missing_backends_name_the_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(__import__("sys").modules, "sam3", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'scenemosaic\[sam3\]'.*--segmenter http://"):
        Sam3Segmenter()
    monkeypatch.setitem(__import__("sys").modules, "inference", None)
    with pytest.raises(MissingExtraError, match=r"github.com/facebookresearch/sam-3d-objects.*PYTHONPATH.*--reconstructor http://"):
        Sam3dReconstructor()
    monkeypatch.setitem(__import__("sys").modules, "cv2", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'scenemosaic\[perception\]'"):
        GrabCutSegmenter()
    # auto falls back to what is there, and says which it took
    assert segmenter_for("auto").name == "box"
    assert reconstructor_for("auto").name == "box-lifter"
    with pytest.raises(UsageError, match="unknown segmenter 'sam4'"):
        segmenter_for("sam4")
    with pytest.raises(UsageError, match="unknown reconstructor"):
        reconstructor_for("nerf")


def test_generate_keeps_the_report_and_the_input_on_bad_detections(photo: Path, tmp_path: Path) -> None:
    det = _coco(tmp_path / "boxes.json", [[300, 200, 80, 80]])
    before = det.read_bytes(), photo.read_bytes()
    out = tmp_path / "run"
    with pytest.raises(ImportFormatError, match="outside"):
        generate(photo, out, GenerateConfig(detections=det, segmenter="box", reconstructor="box-lifter"))
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "failed"
    assert "outside the 320x240 image" in json.dumps(report)
    assert (det.read_bytes(), photo.read_bytes()) == before


class _BrokenReconstructor:
    """A reconstruction server that fell over: every call fails."""

    name = "broken"

    def reconstruct(self, image: object, camera: object, objects: object) -> object:
        from scenemosaic.exceptions import BackendError

        raise BackendError("reconstructor http://sam3d.test/reconstruct failed after 4 attempts: HTTP 503")


def test_a_failing_backend_keeps_what_perception_saw(photo: Path, tmp_path: Path) -> None:
    from scenemosaic.exceptions import BackendError

    det = _coco(tmp_path / "boxes.json", [[10, 10, 50, 50], [100, 60, 120, 150]])
    out = tmp_path / "run"
    with pytest.raises(BackendError, match="HTTP 503"):
        generate(photo, out, GenerateConfig(detections=det, segmenter="box", reconstructor=_BrokenReconstructor()))
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "failed" and report["failed_stage"] == "import"
    kept = json.loads((out / "perception" / "inventory.json").read_text())
    assert [o["id"] for o in kept["objects"]] == ["chair_1", "desk_2"]
    assert sorted(p.name for p in (out / "perception" / "masks").iterdir()) == ["chair_1.png", "desk_2.png"]


def test_lens_from_exif_else_the_default(tmp_path: Path, photo: Path) -> None:
    """A 28 mm (35 mm-equivalent) lens is 65.5 degrees across a 36 mm frame; without EXIF, 60."""
    img = Image.open(photo)
    exif = Image.Exif()
    exif.get_ifd(0x8769)[0xA405] = 28
    shot = tmp_path / "shot.jpg"
    img.save(shot, exif=exif)
    cam = load_image(shot).camera()
    assert cam.source == "exif"
    assert cam.hfov_deg == pytest.approx(2 * np.degrees(np.arctan(18 / 28)), abs=1e-6)
    assert load_image(photo).camera().hfov_deg == pytest.approx(60.0)
    assert load_image(photo).camera(75.0).source == "given"
    with pytest.raises(ImportFormatError, match="field of view"):
        load_image(photo).camera(200.0)

"""`generate --prompt` (text -> image -> scene) and `generate photo.png` on the command line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agent_solvers import solver_answer
from typer.testing import CliRunner

from scenemosaic.cli import app
from scenemosaic.exchange import read_scene
from scenemosaic.metrics import JudgeAgent
from scenemosaic.models import FunctionModel, Message, RequestContext, Usage
from scenemosaic.perception import Inventory, read_detections
from scenemosaic.pipeline import GenerateConfig, generate

DEMO = Path(__file__).resolve().parents[2] / "data" / "images" / "demo_bedroom"


class DrawingModel(FunctionModel):
    """A scripted vision model that also draws: its images endpoint returns the demo render, and
    it lists the render's objects; the structuring and evolving agents get their rule answers."""

    def __init__(self) -> None:
        inventory = Inventory(objects=read_detections(DEMO / "boxes.json", 1024, 768, image_name="photo.png"))

        def answer(messages: list[Message], context: RequestContext | None) -> Any:
            assert context is not None
            if context.agent == "perception":
                return inventory
            if context.agent == "perception_verify":
                return {"requests": []}
            if context.agent == "judge":
                return JudgeAgent().solve(context.evidence)  # type: ignore[arg-type]
            return solver_answer(messages, context)

        super().__init__(answer, name="scripted-vlm")
        self.drawn: list[tuple[str, str, str | None]] = []

    async def generate_image(self, prompt: str, *, size: str = "1024x1024", model: str | None = None) -> tuple[bytes, Usage]:
        self.drawn.append((prompt, size, model))
        return (DEMO / "photo.png").read_bytes(), Usage(requests=1)


def test_prompt_draws_the_room_then_builds_it(tmp_path: Path) -> None:
    model = DrawingModel()
    out = tmp_path / "run"
    prompt = "a bedroom with a desk and a bookshelf"
    config = GenerateConfig(prompt=prompt, image_model="gpt-image-1", model=model, evolve=False)
    result = generate(None, out, config)
    assert (out / "prompt.png").read_bytes() == (DEMO / "photo.png").read_bytes()
    assert json.loads((out / "prompt.json").read_text())["prompt"] == prompt
    assert model.drawn == [(prompt, "1024x1024", "gpt-image-1")]
    coco = json.loads((DEMO / "boxes.json").read_text())
    assert {o.id for o in read_scene(out / "base").objects} == {a["attributes"]["object_id"] for a in coco["annotations"]}
    assert result.report["stages"][0]["detail"]["perception"]["inventory"]["answered_by"] == "model"
    # the same prompt again: the drawing is reused, not paid for twice
    generate(None, out, config)
    assert len(model.drawn) == 1


def test_cli_photo_with_detections_offline(tmp_path: Path) -> None:
    out = tmp_path / "cli"
    args = [
        "generate", str(DEMO / "photo.png"), "--detections", str(DEMO / "boxes.json"),
        "--segmenter", "box", "--reconstructor", "box-lifter", "--no-evolve", "--out", str(out),
    ]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["stages"][0]["detail"]["source_format"] == "image"
    assert (out / "perception" / "masks" / "desk.png").is_file()


def test_cli_refuses_a_photo_without_inventory_and_both_inputs(tmp_path: Path) -> None:
    runner = CliRunner()
    result = runner.invoke(app, ["generate", str(DEMO / "photo.png"), "--out", str(tmp_path / "a")])
    assert result.exit_code == 2
    assert "--detections" in result.output
    result = runner.invoke(app, ["generate", str(DEMO / "photo.png"), "--prompt", "a room", "--out", str(tmp_path / "b")])
    assert result.exit_code == 2
    assert "INPUT or --prompt" in result.output
    result = runner.invoke(app, ["generate", "--prompt", "a room", "--out", str(tmp_path / "c")])
    assert result.exit_code == 2
    assert "cannot draw an image" in result.output


def test_photo_run_replays_from_a_cassette(tmp_path: Path) -> None:
    """The whole image path through a recorded cassette (`--model replay:...`): the perception
    agents' replies and every later agent's are replayed, and the replayed run writes the same
    scenes, variants included. The cassette here is recorded from the scripted model above; a
    real vision model's cassette replays the same way."""
    from scenemosaic.models import ReplayModel

    photo = DEMO / "photo.png"
    cassette = tmp_path / "photo_cassette.json"
    recorder = ReplayModel(DrawingModel(), cassette, "record")
    first = generate(photo, tmp_path / "recorded", GenerateConfig(model=recorder, variants=2))
    recorder.cassette.save()
    agents = {e["agent"] for e in json.loads(cassette.read_text())["entries"].values()}
    assert {"perception", "perception_verify", "critic"} <= agents
    replayed = generate(photo, tmp_path / "replayed", GenerateConfig(model=f"replay:{cassette}", variants=2))
    assert replayed.status == first.status == "ok"
    assert replayed.report["variants_written"] == first.report["variants_written"] == 2
    for folder in ("base", "variant_1", "variant_2"):
        a = (tmp_path / "recorded" / folder / "scene.json").read_bytes()
        b = (tmp_path / "replayed" / folder / "scene.json").read_bytes()
        assert a == b, folder
    assert replayed.report["stages"][0]["detail"]["perception"]["inventory"]["answered_by"] == "model"

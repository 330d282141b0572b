"""A whole-house run on the shipped two-room house (39 objects): what it returns, how its output
reads back, the command line, resuming, that the number of room processes changes nothing, and
the houses delivered ahead of the export stage (in place when the run ends, gone when it fails)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from scenemosaic._processes import WorkerPool
from scenemosaic.cli import app
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.exchange import load_scene
from scenemosaic.pipeline import GenerateConfig, GenerateResult, generate
from scenemosaic.scene import House, Scene

TWO_ROOMS = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor10k_house3703_2room.json"
VARIANTS = 2

runner = CliRunner()


def _delivered(out: Path) -> dict[str, str]:
    """A digest of every delivered file (``base/``, ``variant_<i>/``, the contact sheet), by path."""
    paths = [p for p in out.rglob("*") if p.is_file() and p.relative_to(out).parts[0] not in ("rooms", ".checkpoint", "report.json")]
    return {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest() for p in paths}


def _room_files(out: Path) -> dict[str, bytes]:
    """Every room's delivered base ``scene.json``, by room id."""
    files = sorted((out / "base" / "rooms").glob("*/scene.json"))
    assert files, f"no room scenes under {out / 'base' / 'rooms'}"
    return {p.parent.name: p.read_bytes() for p in files}


@pytest.fixture(scope="module")
def two_room_run(tmp_path_factory: pytest.TempPathFactory) -> GenerateResult:
    """The two-room house with two variants, its rooms in two worker processes."""
    out = tmp_path_factory.mktemp("house") / "out"
    return generate(TWO_ROOMS, out, GenerateConfig(variants=VARIANTS, room_workers=2, overwrite=True))


def test_generate_returns_the_whole_house(two_room_run: GenerateResult) -> None:
    house = two_room_run.scene
    assert isinstance(house, House)
    assert house.room_ids == ["room_2", "room_3"]
    assert len(house.objects) == 39
    assert two_room_run.report["status"] != "failed"
    assert two_room_run.report["house"]["rooms"] == ["room_2", "room_3"]
    for folder in ("base", *(f"variant_{i}" for i in range(1, VARIANTS + 1))):
        index = json.loads((two_room_run.out_dir / folder / "house_scene.json").read_text(encoding="utf-8"))
        assert index["format"] == "scenemosaic-house" and index["rooms"] == ["room_2", "room_3"]


def test_load_scene_reads_the_house_or_one_room(two_room_run: GenerateResult) -> None:
    house = load_scene(two_room_run.out_dir)
    assert isinstance(house, House)
    assert house.room_ids == ["room_2", "room_3"]
    room = load_scene(two_room_run.out_dir, room="room_2")
    assert isinstance(room, Scene) and not isinstance(room, House)
    assert room.id == "room_2"
    assert {o.id for o in room.objects} == {o.id for o in house.room("room_2").objects}


@pytest.mark.house  # two more whole-house runs: make test-houses
@pytest.mark.parametrize("room_workers", [1, 2])
def test_resume_over_a_finished_house_reuses_every_room(
    two_room_run: GenerateResult, tmp_path: Path, room_workers: int
) -> None:
    """Every room of a finished house is reused, whether the resumed run works on its rooms in
    this process (1) or in worker processes (2), and the rooms come out byte for byte the same."""
    out = tmp_path / "resumed"
    shutil.copytree(two_room_run.out_dir, out)
    before = _room_files(out)
    generate(TWO_ROOMS, out, GenerateConfig(variants=VARIANTS, room_workers=room_workers, resume=True))
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert report["status"] != "failed", report["error"]
    for rid, room in report["rooms"].items():
        statuses = {s["name"]: s["status"] for s in room["stages"]}
        assert statuses and set(statuses.values()) == {"reused"}, f"{rid}: {statuses}"
    assert _room_files(out) == before


@pytest.mark.house  # another whole-house run: make test-houses
def test_one_room_process_gives_the_same_rooms_as_two(two_room_run: GenerateResult, tmp_path: Path) -> None:
    result = generate(TWO_ROOMS, tmp_path / "one", GenerateConfig(variants=VARIANTS, room_workers=1, overwrite=True))
    rooms = next(s for s in result.report["stages"] if s["name"] == "rooms")
    assert rooms["detail"]["workers"] == 1 and not rooms["detail"]["processes"]
    two = next(s for s in two_room_run.report["stages"] if s["name"] == "rooms")
    assert two["detail"]["processes"], "the shared run was meant to use worker processes"
    assert _room_files(tmp_path / "one") == _room_files(two_room_run.out_dir)
    # the houses delivered ahead in the workers are those one process delivers at its export
    export = next(s for s in result.report["stages"] if s["name"] == "export")
    assert "delivered_ahead" not in export["detail"]
    delivered = _delivered(tmp_path / "one")
    assert len(delivered) > 100 and delivered == _delivered(two_room_run.out_dir)


def test_houses_delivered_ahead_are_moved_into_place(two_room_run: GenerateResult) -> None:
    export = next(s for s in two_room_run.report["stages"] if s["name"] == "export")
    folders = ["base", *(f"variant_{i}" for i in range(1, VARIANTS + 1))]
    assert export["detail"]["delivered_ahead"] == folders
    assert export["detail"]["deliveries_s"] > 0
    for folder in folders:
        assert (two_room_run.out_dir / folder / "house_scene.json").is_file()
        assert not (two_room_run.out_dir / folder / "partial.json").exists()
    assert not (two_room_run.out_dir / ".checkpoint" / "staged").exists()


def test_a_run_failing_after_the_houses_went_ahead_keeps_only_its_partial_base(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """evaluate fails while the houses are being delivered ahead: they are stopped and dropped,
    and the folder holds what any failed run keeps (the base's native files, marked partial)."""
    import scenemosaic.pipeline._stages as stages
    from scenemosaic.pipeline._workers import WORKER_MODULE

    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("evaluation broke")

    monkeypatch.setattr(stages, "evaluate", broken)
    out = tmp_path / "failed"
    with pytest.raises(RuntimeError, match="evaluation broke"):
        generate(TWO_ROOMS, out, GenerateConfig(variants=1, room_workers=2))
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert report["status"] == "failed" and report["failed_stage"] == "evaluate"
    assert (out / "base" / "partial.json").is_file() and (out / "base" / "house_scene.json").is_file()
    assert not (out / "base" / "scene.xml").exists()  # no simulator file of a house not delivered
    assert not (out / "variant_1").exists()
    assert not (out / ".checkpoint" / "staged").exists()
    assert WorkerPool.kept(WORKER_MODULE) is None  # a failed run's workers leave


def test_a_house_half_failing_in_its_worker_fails_the_export_and_keeps_the_partial_base(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One half of each house's delivery names a part no exporter knows: the worker's error ends
    the run at its export stage, said with the house and the part, and nothing half written stays."""
    import scenemosaic.pipeline._deliveries as deliveries

    monkeypatch.setattr(deliveries, "_lanes", lambda: (("mjcf", "usd", "glb"), ("urdf", "no_such_part")))
    out = tmp_path / "failed"
    with pytest.raises(SceneMosaicError, match=r"house export failed: base: .*no such delivery part: no_such_part"):
        generate(TWO_ROOMS, out, GenerateConfig(variants=1, room_workers=2))
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert report["status"] == "failed" and report["failed_stage"] == "export"
    assert (out / "base" / "partial.json").is_file() and not (out / "base" / "scene.xml").exists()
    assert not (out / "variant_1").exists()
    assert not (out / ".checkpoint" / "staged").exists()


def test_a_house_run_keeps_its_idle_workers_for_the_next_run_in_the_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The next run takes them (no start-up) and gives the same files; they hold no memo between
    runs; a run started in another environment starts its own."""
    from scenemosaic._processes import JobEnd, WorkerJob
    from scenemosaic.pipeline._workers import WORKER_MODULE

    def kept_pids() -> list[int]:
        pool = WorkerPool.kept(WORKER_MODULE)
        assert pool is not None and pool.ready()
        return [w.process.pid for w in pool._running]

    config = GenerateConfig(variants=0, room_workers=2)
    generate(TWO_ROOMS, tmp_path / "first", config)
    first = kept_pids()
    assert len(first) == 2
    generate(TWO_ROOMS, tmp_path / "second", config)
    assert kept_pids() == first  # the same processes ran the second run and wait again
    assert _delivered(tmp_path / "first") == _delivered(tmp_path / "second")
    assert _room_files(tmp_path / "first") == _room_files(tmp_path / "second")
    replies: dict[str, JobEnd] = {}
    forget = [WorkerJob(f"forget#{k}", b'{"kind": "forget"}', slot=k) for k in range(2)]
    kept = WorkerPool.kept(WORKER_MODULE)
    assert kept is not None
    kept.run(forget, workers=2, on_end=lambda job, end: replies.__setitem__(job.name, end))
    assert [json.loads(replies[f"forget#{k}"].reply or b"{}") for k in range(2)] == [{"forgotten": 0}] * 2

    monkeypatch.setenv("SCENEMOSAIC_TEST_OTHER_ENVIRONMENT", "1")  # what a worker would not see
    generate(TWO_ROOMS, tmp_path / "third", config)
    third = kept_pids()
    assert not set(third) & set(first)


@pytest.mark.house  # another whole-house run: make test-houses
def test_cli_generates_the_house_and_prints_its_summary(tmp_path: Path) -> None:
    out = tmp_path / "cli_house"
    result = runner.invoke(app, ["generate", str(TWO_ROOMS), "--out", str(out), "--model", "rules"])
    assert result.exit_code == 0, result.output
    assert any(line.strip().startswith("house:") for line in result.output.splitlines()), result.output
    assert (out / "base" / "house_scene.json").is_file()
    assert sorted(p.name for p in (out / "base" / "rooms").iterdir()) == ["room_2", "room_3"]


def test_cli_room_option_still_runs_one_room(tmp_path: Path) -> None:
    out = tmp_path / "cli_room"
    result = runner.invoke(app, ["generate", str(TWO_ROOMS), "--room", "room|2", "--out", str(out), "--model", "rules"])
    assert result.exit_code == 0, result.output
    assert not any(line.strip().startswith("house:") for line in result.output.splitlines()), result.output
    assert not (out / "base" / "house_scene.json").exists()
    scene = load_scene(out)
    assert isinstance(scene, Scene) and not isinstance(scene, House)
    assert scene.provenance.source_room_id == "room|2"
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert "house" not in report


@pytest.mark.house  # two whole-house runs with clutter: make test-houses
def test_clutter_filled_houses_are_the_same_bytes_for_any_number_of_room_processes(tmp_path: Path) -> None:
    """Rooms worked on in this process (1) or sent to worker processes and back (2) give the same
    files, clutter included: a pose validated again after the trip is not normalized again."""
    four_rooms = TWO_ROOMS.with_name("procthor_4room.json")
    delivered = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        generate(four_rooms, out, GenerateConfig(variants=VARIANTS, clutter="fill", room_workers=workers, overwrite=True))
        delivered[workers] = _delivered(out)
    assert len(delivered[1]) > 100
    assert delivered[1] == delivered[2]

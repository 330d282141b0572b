"""``generate`` end to end on real data: output layout, sizes, report, replayed models, partial results."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from agent_solvers import solver_answer
from pydantic import BaseModel
from typer.testing import CliRunner

from scenemosaic import FunctionModel, GenerateConfig, ReplayModel, generate, load_scene
from scenemosaic.cli import app
from scenemosaic.exceptions import PartialResultError
from scenemosaic.exchange import Y_UP_TO_Z_UP, read_scene
from scenemosaic.models import Message, RequestContext
from scenemosaic.scene import RunFolder

LIVING = "LivingDiningRoom-124277_livingroom.json"
DINING = "DiningRoom-19325_diningroom.json"


@pytest.fixture(scope="module")
def living_run(tmp_path_factory: pytest.TempPathFactory, repo_data: Path) -> tuple[Path, Path]:
    source = repo_data / "layouts" / "physcene" / LIVING
    out = tmp_path_factory.mktemp("living")
    result = CliRunner().invoke(app, ["generate", str(source), "--out", str(out)])
    assert result.exit_code == 0, result.output
    return source, out


def _input_objects(source: Path) -> list[dict[str, Any]]:
    data = json.loads(source.read_text())
    return [o for objs in data["ThreedFront"].values() for o in objs]


def test_output_layout_is_complete(living_run: tuple[Path, Path]) -> None:
    _, out = living_run
    base = out / "base"
    for rel in ["scene.json", "scene.glb", "topdown.png", "scene.xml", "sceneeval/scene_base.json"]:
        assert (base / rel).is_file(), rel
    assert list((base / "sceneeval" / "assets").glob("*.glb"))
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "ok"
    assert [s["name"] for s in report["stages"]] == [
        "import", "assets", "structure", "stabilize", "doors", "evolve", "compose", "validate", "evaluate", "export",
    ]  # fmt: skip
    assert (out / "evolve" / "floor" / "original.json").is_file()
    skipped = {"compose", "doors"}  # no --variants; a room without doors
    assert all(s["seconds"] >= 0 and s["status"] == ("skipped" if s["name"] in skipped else "done") for s in report["stages"])
    assert report["objects"] == 16


def test_glb_objects_match_input_counts_and_sizes(living_run: tuple[Path, Path]) -> None:
    source, out = living_run
    raw = _input_objects(source)
    glb = trimesh.load(out / "base" / "scene.glb", force="scene")
    scene = read_scene(out / "base")
    ids = [o.id for o in scene.objects]
    object_nodes = [n for n in glb.graph.nodes_geometry if n in ids]
    assert len(object_nodes) == len(raw) == len(ids)
    # footprint (x, y) in the object's own frame equals 2 x half extents (x, z of the Y-up input) within 2 %
    expected = sorted((2 * o["size"][0], 2 * o["size"][2], 2 * o["size"][1]) for o in raw)
    measured = []
    for oid in ids:
        transform, geom_name = glb.graph[oid]
        mesh = glb.geometry[geom_name].copy()
        mesh.apply_transform(transform)
        mesh.apply_transform(Y_UP_TO_Z_UP)  # back to our Z-up world frame
        obj = scene.get(oid)
        local = mesh.vertices - np.asarray(obj.pose.position)
        local = local @ obj.pose.rotation  # world -> object frame (rotation only)
        measured.append(tuple(local.max(axis=0) - local.min(axis=0)))
        assert local[:, 2].min() == pytest.approx(0.0, abs=1e-3), oid  # Z-up, origin at the bottom
    for exp, got in zip(expected, sorted(measured), strict=True):
        assert np.allclose(got, exp, rtol=0.02), (exp, got)


def test_base_scene_round_trips_and_is_structured(living_run: tuple[Path, Path]) -> None:
    _, out = living_run
    scene = load_scene(out / "base")
    assert scene.to_json() == read_scene(out / "base" / "scene.json").to_json()
    assert scene.structure is not None and scene.structure.units
    assert all(scene.support_of(o.id) is not None for o in scene.objects)
    assert "structure" in scene.provenance.steps or scene.relations


def test_stabilized_output_is_physically_valid(living_run: tuple[Path, Path]) -> None:
    _, out = living_run
    validation = json.loads((out / "report.json").read_text())["validation"]
    assert validation["collisions"]["pairs"] == []
    assert validation["out_of_bounds"]["objects"] == []
    assert validation["tipped"] == [] and validation["fell"] == []
    assert max(abs(g) for g in validation["support_gaps_m"].values()) < 0.01


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("demo")
    result = CliRunner().invoke(app, ["demo", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "validation: collision pairs 0, out of bounds 0, tipped 0, fell 0" in result.output
    return out


def test_demo_command_writes_a_valid_scene(demo_out: Path) -> None:
    tmp_path = demo_out
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["status"] == "ok" and report["objects"] == 16
    validation = report["validation"]
    assert validation["collisions"]["pairs"] == []
    # the hung lamp and the wall TV are static yet must end on their supports
    assert abs(validation["support_gaps_m"]["pendant_lamp"]) < 0.01
    assert abs(validation["support_gaps_m"]["tv"]) < 0.01
    tree = CliRunner().invoke(app, ["inspect", str(tmp_path / "base")])
    assert tree.exit_code == 0 and "pendant_lamp" in tree.output and "ceiling" in tree.output


def _solver_answer(messages: Sequence[Message], context: RequestContext) -> BaseModel:
    return solver_answer(messages, context)


def test_generate_replays_a_cassette_recorded_from_a_function_model(tmp_path: Path, repo_data: Path) -> None:
    source = repo_data / "layouts" / "physcene" / DINING
    cassette = tmp_path / "dining.cassette.json"
    recorder = ReplayModel(FunctionModel(_solver_answer, name="recorded-fn", vision=False), cassette, "record")
    recorded = generate(source, tmp_path / "rec", GenerateConfig(model=recorder, variants=2))
    assert cassette.is_file()
    result = CliRunner().invoke(
        app, ["generate", str(source), "--out", str(tmp_path / "rep"), "--model", f"replay:{cassette}", "--variants", "2"]
    )
    assert result.exit_code == 0, result.output
    replayed = read_scene(tmp_path / "rep" / "base")
    assert replayed.relations == recorded.scene.relations
    assert replayed.constraints == recorded.scene.constraints
    # the evolution's critic, actor, archetype and pose requests replay too: the same evolved scene
    entries = json.loads(cassette.read_text())["entries"].values()
    assert {"critic", "actor", "archetypes", "pose"} <= {e["agent"] for e in entries}
    assert replayed.objects == recorded.scene.objects
    names = sorted(p.relative_to(tmp_path / "rec" / "evolve") for p in (tmp_path / "rec" / "evolve").rglob("*.json"))
    assert len(names) >= 3  # the floor's original and variant, the ceiling's original
    for name in names:
        assert (tmp_path / "rep" / "evolve" / name).read_text() == (tmp_path / "rec" / "evolve" / name).read_text()


def test_failed_stage_keeps_partial_results(tmp_path: Path, repo_data: Path) -> None:
    source = repo_data / "layouts" / "physcene" / DINING
    missing = tmp_path / "no-such-cassette.json"
    result = CliRunner().invoke(
        app, ["generate", str(source), "--out", str(tmp_path / "o"), "--model", f"replay:{missing}"]
    )
    assert result.exit_code == 2
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["status"] == "failed"
    failed = [s for s in report["stages"] if s["status"] == "failed"]
    assert [s["name"] for s in failed] == ["structure"]
    # the imported scene is not lost, but kept as a partial result: native files and the reason,
    # nothing a simulator would load as a finished scene, and loaders refuse it unless asked
    base = tmp_path / "o" / "base"
    assert sorted(report["partial_files"]) == ["partial.json", "scene.json"]
    assert not (base / "scene.xml").exists() and not (base / "scene.urdf").exists()
    marker = json.loads((base / "partial.json").read_text())
    assert marker["status"] == "failed" and marker["failed_stage"] == "structure"
    with pytest.raises(PartialResultError, match="allow_partial"):
        read_scene(base)
    with pytest.raises(PartialResultError):
        load_scene(tmp_path / "o")
    partial = read_scene(base, allow_partial=True)
    assert len(partial.objects) == 6
    assert not RunFolder.is_delivered(base)


def test_same_seed_gives_identical_scene_files(tmp_path: Path, repo_data: Path) -> None:
    source = repo_data / "layouts" / "physcene" / DINING
    a = generate(source, tmp_path / "a", GenerateConfig(seed=3))
    b = generate(source, tmp_path / "b", GenerateConfig(seed=3))
    assert (a.base_dir / "scene.json").read_bytes() == (b.base_dir / "scene.json").read_bytes()


def test_sceneeval_support_types_follow_the_support_relations(demo_out: Path) -> None:
    state = json.loads((demo_out / "base" / "sceneeval" / "scene_base.json").read_text())
    support = {o["id"]: o["sceneeval"]["supportType"] for o in state["scene"]["object"]}
    assert support["pendant_lamp"] == "ceiling"
    assert support["tv"] == "wall"
    assert support["mug"] == support["laptop"] == support["table_lamp"] == "object"
    assert support["bed"] == support["desk"] == support["wardrobe"] == "ground"


# -- the structured base scene, seen through SceneEval and through `scenemosaic inspect` --------

_SUPPORT_TYPE = {"floor": "ground", "ceiling": "ceiling"}


def _expected_support_type(scene: Any, oid: str) -> str:
    rel = scene.support_of(oid)
    assert rel is not None, oid
    if rel.parent in _SUPPORT_TYPE:
        return _SUPPORT_TYPE[rel.parent]
    return "wall" if scene.anchor_kind(rel.parent) == "wall" else "object"


@pytest.mark.parametrize("which", ["living_run", "demo_out"])
def test_sceneeval_export_of_a_structured_scene_matches_scene_glb(which: str, request: pytest.FixtureRequest) -> None:
    """SceneEval's view of the exported base scene: same geometry as scene.glb to 1 mm, support from the tree."""
    from scipy.spatial import cKDTree

    fixture = request.getfixturevalue(which)
    out: Path = fixture[1] if isinstance(fixture, tuple) else fixture
    base = out / "base"
    scene = read_scene(base)
    assert scene.structure is not None
    state = json.loads((base / "sceneeval" / "scene_base.json").read_text())
    body = state["scene"]
    assert state["format"] == "sceneState" and body["up"] == [0, 0, 1] and body["unit"] == 1.0
    objects = body["object"]
    assert [o["id"] for o in objects] == [o.id for o in scene.objects]
    assert sorted(o["index"] for o in objects) == list(range(len(objects)))
    # arch: the structured room, not a placeholder
    assert scene.room is not None
    floor = next(e for e in body["arch"]["elements"] if e["type"] == "Floor")
    assert [p[:2] for p in floor["points"]] == [list(p) for p in scene.room.floor]
    walls = [e for e in body["arch"]["elements"] if e["type"] == "Wall"]
    assert [w["points"] for w in walls] == [[[*w.start, 0.0], [*w.end, 0.0]] for w in scene.room.walls]
    glb = trimesh.load(base / "scene.glb", force="scene")
    kinds = set()
    for o in objects:
        assert o["sceneeval"]["supportType"] == _expected_support_type(scene, o["id"]), o["id"]
        kinds.add(o["sceneeval"]["supportType"])
        asset = trimesh.load(base / "sceneeval" / "assets" / f"{o['modelId'][len('scenemosaic.'):]}.glb", force="mesh")
        m = np.asarray(o["transform"]["data"]).reshape(4, 4).T
        np.testing.assert_allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-9)  # rigid
        ours = trimesh.transform_points(asset.vertices, m)
        # the object's node and, for furniture that opens, its parts' nodes ``<id>/<part>`` (closed)
        nodes = [o["id"], *(n for n in glb.graph.nodes_geometry if n.startswith(f"{o['id']}/"))]
        ref = np.vstack([
            trimesh.transform_points(glb.geometry[glb.graph[n][1]].vertices, Y_UP_TO_Z_UP @ glb.graph[n][0]) for n in nodes
        ])  # fmt: skip
        np.testing.assert_allclose(ours.min(axis=0), ref.min(axis=0), atol=1e-3, err_msg=o["id"])
        np.testing.assert_allclose(ours.max(axis=0), ref.max(axis=0), atol=1e-3, err_msg=o["id"])
        assert cKDTree(ref).query(ours)[0].max() < 1e-3, o["id"]
        assert cKDTree(ours).query(ref)[0].max() < 1e-3, o["id"]
    assert {"ground", "ceiling"} <= kinds  # both rooms hang a lamp from the ceiling


def _tree_parents(text: str) -> dict[str, str]:
    """Child id -> the id on the line it is nested under, read from format_tree's drawing."""
    parents: dict[str, str] = {}
    stack: list[str] = []
    for line in text.splitlines():
        if "── " not in line:
            continue
        depth = line.index("── ") // 4
        name = line[line.index("── ") + 3 :].split(" ")[0]
        del stack[depth:]
        if depth:
            assert name not in parents, f"{name} listed twice"
            parents[name] = stack[depth - 1]
        stack.append(name)
    return parents


def test_inspect_prints_the_whole_tree_units_and_constraints(demo_out: Path) -> None:
    from scenemosaic.scene import format_tree

    scene = read_scene(demo_out / "base")
    assert scene.structure is not None and scene.constraints
    result = CliRunner().invoke(app, ["inspect", str(demo_out / "base")])
    assert result.exit_code == 0, result.output
    # the command prints format_tree's text (the console may wrap long lines)
    assert " ".join(result.output.split()) == " ".join(format_tree(scene).split())
    text = format_tree(scene)
    # every object appears once, nested under its support parent
    parents = _tree_parents(text)
    assert parents == {o.id: scene.support_of(o.id).parent for o in scene.objects}  # type: ignore[union-attr]
    lines = text.splitlines()
    assert f"units: {len(scene.structure.units)}" in lines
    for u in scene.structure.units:
        assert f"  {u.anchor_id} ({u.anchor_kind}, {u.projection}): {', '.join(u.children)}" in lines
    for c in scene.constraints:
        assert f"  {c.id} [{c.kind}] {c.description}" in lines
        for clause in (c.anchor_a, c.anchor_b):
            rel = ", ".join(clause.related_objects) or "-"
            assert f"    @{clause.anchor_id}: [{rel}] {clause.layout_note}" in lines
    # --json carries the same units and constraints, machine-readable
    as_json = CliRunner().invoke(app, ["inspect", str(demo_out / "base"), "--json"])
    assert as_json.exit_code == 0, as_json.output
    payload = json.loads(as_json.output)
    assert [u["anchor_id"] for u in payload["units"]] == [u.anchor_id for u in scene.structure.units]
    assert [c["id"] for c in payload["constraints"]] == [c.id for c in scene.constraints]


async def test_cancelling_generate_keeps_the_report_and_the_last_good_scene(tmp_path: Path, repo_data: Path) -> None:
    import asyncio

    from scenemosaic import agenerate

    asked = asyncio.Event()

    async def never_answers(messages: list[Message], context: RequestContext) -> BaseModel:
        asked.set()
        await asyncio.Event().wait()  # a model that hangs until the run is cancelled
        raise AssertionError("unreachable")

    source = repo_data / "layouts" / "physcene" / DINING
    model = FunctionModel(never_answers, vision=False)
    task = asyncio.create_task(agenerate(source, tmp_path, GenerateConfig(model=model)))
    await asyncio.wait_for(asked.wait(), timeout=30)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):  # a cancel, even one the agents' task graph saw first
        await task
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["status"] == "interrupted" and report["failed_stage"] == "structure"
    assert [s["name"] for s in report["stages"] if s["status"] == "interrupted"] == ["structure"]
    assert len(read_scene(tmp_path / "base", allow_partial=True).objects) == 6  # the imported scene is kept, marked partial
    assert json.loads((tmp_path / "base" / "partial.json").read_text())["status"] == "interrupted"

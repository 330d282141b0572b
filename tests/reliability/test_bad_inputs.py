"""Every hostile or broken input through the CLI: a one-line error naming the field, exit 2, nothing leaked."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import report, run_cli


def _obj(oid: str, *, position: list[float] | None = None, extents: list[float] | None = None, **asset: Any) -> dict[str, Any]:
    return {
        "id": oid,
        "category": "box",
        "asset": {"kind": "box", **asset, "extents": extents or [0.5, 0.5, 0.5]},
        "pose": {"position": position or [1.0, 1.0, 0.0], "quaternion": [1, 0, 0, 0], "scale": [1, 1, 1]},
    }


ROOM = {"id": "room", "floor": [[0, 0], [4, 0], [4, 4], [0, 4]], "ceiling_height": 2.6}


def _scene_file(folder: Path, objects: list[dict[str, Any]]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.json"
    path.write_text(json.dumps({"id": "bad", "room": ROOM, "objects": objects}), encoding="utf-8")
    return path


def _refused(tmp_path: Path, source: Path, *needles: str) -> None:
    out = tmp_path / "out"
    done = run_cli(["generate", str(source), "--out", str(out)], tmp_path)
    assert done.code == 2, (done.code, done.stderr[-2000:])
    assert "Traceback" not in done.stderr
    flat = " ".join(done.stderr.split())
    for needle in needles:
        assert needle in flat, (needle, flat[-1500:])
    assert report(out)["status"] == "failed"


def test_a_mesh_uri_escaping_the_scene_folder_is_refused_and_nothing_is_copied(tmp_path: Path) -> None:
    source = _scene_file(tmp_path / "in", [_obj("thief", kind="mesh", uri="../../../../../../etc/passwd")])
    _refused(tmp_path, source, "objects[0].asset.uri")
    leaked = [p for p in (tmp_path / "out").rglob("*") if p.is_file() and p.name == "passwd"]
    assert leaked == []


def test_a_symlink_loop_is_an_error_not_a_traceback(tmp_path: Path) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    os.symlink(folder / "b.glb", folder / "a.glb")
    os.symlink(folder / "a.glb", folder / "b.glb")
    source = _scene_file(folder, [_obj("loop", kind="mesh", uri="a.glb")])
    _refused(tmp_path, source, "objects[0].asset.uri")
    inspected = run_cli(["inspect", str(source)], tmp_path)
    assert inspected.code == 2 and "Traceback" not in inspected.stderr


def test_a_one_nanometre_object_is_refused_naming_the_field(tmp_path: Path) -> None:
    source = _scene_file(tmp_path / "in", [_obj("speck", extents=[2e-9, 0.5, 0.5])])
    _refused(tmp_path, source, "speck")


def test_a_position_of_a_hundred_thousand_km_is_refused(tmp_path: Path) -> None:
    source = _scene_file(tmp_path / "in", [_obj("far", position=[1e8, 1.0, 0.0])])
    _refused(tmp_path, source, "far")


def test_more_objects_than_the_limit_is_refused_naming_the_limit(tmp_path: Path) -> None:
    objects = [_obj(f"o{i}", position=[0.5 + (i % 20) * 0.15, 0.5 + (i // 20) * 0.12, 0.0], extents=[0.1, 0.1, 0.1]) for i in range(513)]
    source = _scene_file(tmp_path / "in", objects)
    _refused(tmp_path, source, "512")


def test_a_nan_pose_is_refused_naming_the_object(tmp_path: Path) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    text = json.dumps({"id": "bad", "room": ROOM, "objects": [_obj("ghost")]}).replace("[1.0, 1.0, 0.0]", "[NaN, 1.0, 0.0]")
    (folder / "scene.json").write_text(text, encoding="utf-8")
    _refused(tmp_path, folder / "scene.json", "ghost")


@pytest.mark.parametrize("pair", [("mug!", "mug?"), ("椅子", "桌子")])
def test_ids_that_differ_only_in_punctuation_or_script_stay_distinct(pair: tuple[str, str], tmp_path: Path) -> None:
    """A SAM3D pose file (ids are identities there) with such ids imports with two distinct ids."""
    import trimesh

    folder = tmp_path / "in"
    (folder / "meshes").mkdir(parents=True)
    trimesh.creation.box(extents=(0.2, 0.2, 0.2)).export(folder / "meshes" / "cube.glb")
    poses = {
        "format": "sam3d",
        "room": {"floor": [[-2, -2], [2, -2], [2, 2], [-2, 2]], "ceiling_height": 2.5},
        "objects": [
            {"id": pair[0], "label": "mug", "mesh": "meshes/cube.glb", "position": [0.0, 0.0, 0.1], "quaternion": [1, 0, 0, 0]},
            {"id": pair[1], "label": "mug", "mesh": "meshes/cube.glb", "position": [1.0, 0.0, 0.1], "quaternion": [1, 0, 0, 0]},
        ],
    }
    (folder / "poses.json").write_text(json.dumps(poses, ensure_ascii=False), encoding="utf-8")
    out = tmp_path / "out"
    done = run_cli(["generate", str(folder), "--out", str(out)], tmp_path)
    assert done.code == 0, done.stderr[-2000:]
    ids = [o["id"] for o in json.loads((out / "base" / "scene.json").read_text(encoding="utf-8"))["objects"]]
    assert len(ids) == 2 and len(set(ids)) == 2, ids


@pytest.mark.parametrize("kind", ["device", "fifo"])
def test_a_device_or_a_fifo_as_input_is_refused_at_once(kind: str, tmp_path: Path) -> None:
    if kind == "fifo":
        source = tmp_path / "scene.json"
        os.mkfifo(source)  # opening it would wait for a writer for ever
    else:
        source = Path("/dev/zero")  # reading it would never end
    done = run_cli(["generate", str(source), "--out", str(tmp_path / "out")], tmp_path, timeout=60)
    assert done.code == 2, done.stderr[-2000:]
    what = "a FIFO (named pipe)" if kind == "fifo" else "a character device"
    assert f"is {what}, not a regular file" in " ".join(done.stderr.split())
    assert done.seconds < 15 and "Traceback" not in done.stderr
    assert not (tmp_path / "out").exists()


def test_a_fifo_named_as_a_mesh_is_not_a_regular_file_rather_than_not_found(tmp_path: Path) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    os.mkfifo(folder / "chair.glb")
    source = _scene_file(folder, [_obj("chair", kind="mesh", uri="chair.glb")])
    _refused(tmp_path, source, "objects[0].asset.uri", "chair.glb is a FIFO (named pipe), not a regular file")


def test_an_input_over_its_size_limit_is_refused_unless_the_limit_is_raised(tmp_path: Path) -> None:
    source = _scene_file(tmp_path / "in", [_obj("a")])
    source.write_text(source.read_text() + " " * 2_000_000, encoding="utf-8")  # 2 MB of trailing blanks
    done = run_cli(["generate", str(source), "--out", str(tmp_path / "out"), "--max-input-mb", "1"], tmp_path)
    assert done.code == 2, done.stderr[-2000:]
    assert "over the 1 MB limit for a scene file; raise it with --max-input-mb" in " ".join(done.stderr.split())
    done = run_cli(["generate", str(source), "--out", str(tmp_path / "out"), "--max-input-mb", "3", "--no-evolve"], tmp_path)
    assert done.code == 0, done.stderr[-2000:]


def test_control_characters_from_an_input_are_shown_escaped_never_raw() -> None:
    from scenemosaic.cli import escape

    shown = escape("object 'a\x00b' in [/x] \x1b[31mred")
    assert "\x00" not in shown and "\x1b" not in shown
    assert shown == "object 'a\\x00b' in \\[/x] \\x1b[31mred"


def test_a_401_digit_integer_in_a_procthor_house_is_a_format_error(tmp_path: Path) -> None:
    """An integer past any float (one the JSON parser reads whole) names its field, exit 2."""
    house = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor" / "procthor_1room_bedroom.json"
    source = tmp_path / "house.json"
    text = house.read_text(encoding="utf-8")
    assert '"x": 0.0' in text
    source.write_text(text.replace('"x": 0.0', '"x": ' + "9" * 401, 1), encoding="utf-8")
    _refused(tmp_path, source, "must be finite", "integer of about 401 digits", "the report is in")
    assert not (tmp_path / "out" / "base").exists()  # nothing to keep: the line says the report only

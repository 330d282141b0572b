"""The one id sanitization, the one file-confinement check and the atomic scene-file writer."""

from __future__ import annotations

import errno
import os
import re
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from scenemosaic.exceptions import AssetError, OutputSpaceError, UnsafePathError
from scenemosaic.scene import (
    ID_HASH_CHARS,
    MAX_ID_LENGTH,
    OBJECT_ID_PATTERN,
    confined_path,
    real_path,
    sanitize_id,
    unique_id,
    write_atomic,
)

# -- ids -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("raw", ["chair_1", "Bed.2-0", "a" * MAX_ID_LENGTH])
def test_ids_in_the_alphabet_are_kept(raw: str) -> None:
    assert sanitize_id(raw) == raw


@pytest.mark.parametrize(
    ("raw", "expected"),
    [
        ("Bed|2|0", "Bed_2_0"),  # ProcTHOR's separators: no hash, as before
        ("throw pillow-0|sofa-0", "throw_pillow-0_sofa-0"),  # Holodeck's
        ("  lamp  ", "lamp"),
        ("café", "cafe"),  # transliterated
        ("Ｃｈａｉｒ", "Chair"),  # full-width letters
    ],
)
def test_separators_and_accents_need_no_hash(raw: str, expected: str) -> None:
    assert sanitize_id(raw) == expected


def _hash_suffixed(out: str, stem: str) -> bool:
    return re.fullmatch(rf"{re.escape(stem)}_[0-9a-f]{{{ID_HASH_CHARS}}}", out) is not None


@pytest.mark.parametrize(
    ("a", "b", "stem"),
    [("mug!", "mug?", "mug"), ("椅子", "桌子", "object"), ("chair🙂", "chair😀", "chair")],
)
def test_ids_differing_only_in_dropped_characters_stay_distinct(a: str, b: str, stem: str) -> None:
    sa, sb = sanitize_id(a), sanitize_id(b)
    assert sa != sb
    assert _hash_suffixed(sa, stem) and _hash_suffixed(sb, stem), (sa, sb)
    assert sanitize_id(a) == sa  # stable: the same text always gives the same id


def test_a_lone_unicode_id_gets_a_hash_not_a_bare_fallback() -> None:
    out = sanitize_id("椅子🙂")
    assert out != "object" and _hash_suffixed(out, "object")
    assert _hash_suffixed(sanitize_id("客厅", fallback="scene"), "scene")


def test_sanitized_ids_fit_the_model() -> None:
    for raw in ["x" * 200, "é" * 100, "!" * 300, "a b" * 50, "家具" * 40]:
        out = sanitize_id(raw)
        assert re.match(OBJECT_ID_PATTERN, out) and len(out) <= MAX_ID_LENGTH, out


def test_unique_id_steers_around_taken_and_anchor_ids() -> None:
    taken = {"chair"}
    assert unique_id("chair", taken) == "chair_2"
    assert unique_id("floor", taken) == "floor_2"
    assert unique_id("wall_3", taken) == "wall_3_2"
    assert {"chair", "chair_2", "floor_2", "wall_3_2"} <= taken


# -- confinement -----------------------------------------------------------------------------------


@pytest.fixture
def scene_dir(tmp_path: Path) -> Path:
    folder = tmp_path / "scene"
    (folder / "meshes").mkdir(parents=True)
    (folder / "meshes" / "chair.obj").write_text("v 0 0 0\n")
    (tmp_path / "secret.txt").write_text("secret")
    return folder


def test_files_inside_the_folder_are_accepted(scene_dir: Path) -> None:
    inside = scene_dir / "meshes" / "chair.obj"
    assert confined_path(scene_dir, "meshes/chair.obj") == inside.resolve()
    assert confined_path(scene_dir, "meshes/../meshes/chair.obj") == inside.resolve()
    assert confined_path(scene_dir, str(inside)) == inside.resolve()  # absolute, but inside
    assert confined_path(scene_dir, "meshes/not_yet.obj").name == "not_yet.obj"  # need not exist


@pytest.mark.parametrize("uri", ["../secret.txt", "../../../../../../etc/passwd", "/etc/passwd", "meshes/../../x"])
def test_files_outside_the_folder_are_refused(scene_dir: Path, uri: str) -> None:
    with pytest.raises(UnsafePathError, match="outside") as info:
        confined_path(scene_dir, uri)
    assert info.value.reference == uri
    assert isinstance(info.value, AssetError)


def test_an_allowed_root_admits_its_files(scene_dir: Path, tmp_path: Path) -> None:
    library = tmp_path / "library"
    library.mkdir()
    assert confined_path(scene_dir, str(library / "a.glb"), roots=[library]) == (library / "a.glb").resolve()
    with pytest.raises(UnsafePathError):
        confined_path(scene_dir, str(tmp_path / "secret.txt"), roots=[library])


def test_the_resolved_path_is_checked_through_symlinks(scene_dir: Path, tmp_path: Path) -> None:
    (scene_dir / "meshes" / "link.obj").symlink_to(tmp_path / "secret.txt")
    (scene_dir / "escape").symlink_to(tmp_path, target_is_directory=True)
    for uri in ["meshes/link.obj", "escape/secret.txt"]:
        with pytest.raises(UnsafePathError, match=r"secret\.txt"):
            confined_path(scene_dir, uri)
    # a link that stays inside is fine
    (scene_dir / "alias.obj").symlink_to(scene_dir / "meshes" / "chair.obj")
    assert confined_path(scene_dir, "alias.obj") == (scene_dir / "meshes" / "chair.obj").resolve()


def test_a_symlink_loop_is_a_clean_error(scene_dir: Path) -> None:
    (scene_dir / "a.obj").symlink_to(scene_dir / "b.obj")
    (scene_dir / "b.obj").symlink_to(scene_dir / "a.obj")
    with pytest.raises(UnsafePathError, match="symlink loop"):
        confined_path(scene_dir, "a.obj")
    with pytest.raises(UnsafePathError, match="symlink loop"):
        real_path(scene_dir / "b.obj")


@pytest.mark.parametrize("uri", ["", "   ", "file:///etc/passwd", "https://example.com/chair.glb"])
def test_empty_and_url_references_are_refused(scene_dir: Path, uri: str) -> None:
    with pytest.raises(UnsafePathError):
        confined_path(scene_dir, uri)


def test_a_nul_byte_is_a_clean_error(scene_dir: Path) -> None:
    with pytest.raises(UnsafePathError, match="cannot resolve"):
        confined_path(scene_dir, "chair\x00.obj")


# -- writing ---------------------------------------------------------------------------------------


@pytest.fixture
def umask_022() -> Iterator[None]:
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


def test_write_atomic_gives_the_mode_of_a_plain_open(tmp_path: Path, umask_022: None) -> None:
    target = write_atomic(tmp_path / "scene.json", "{}\n")
    assert target.read_text() == "{}\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    write_atomic(target, b"[]\n")  # replacing keeps the mode rule
    assert target.read_bytes() == b"[]\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["scene.json"]  # no temporary left behind


def test_write_atomic_respects_a_stricter_umask(tmp_path: Path) -> None:
    old = os.umask(0o077)
    try:
        target = write_atomic(tmp_path / "private.json", "{}")
    finally:
        os.umask(old)
    assert stat.S_IMODE(target.stat().st_mode) == 0o600


def test_write_atomic_replaces_a_planted_symlink_instead_of_writing_through_it(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere.xml"
    elsewhere.write_text("keep me")
    target = tmp_path / "out" / "scene.xml"
    target.parent.mkdir()
    target.symlink_to(elsewhere)
    write_atomic(target, "<mujoco/>")
    assert not target.is_symlink() and target.read_text() == "<mujoco/>"
    assert elsewhere.read_text() == "keep me"


def test_a_full_disk_leaves_the_old_file_and_no_temporary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = write_atomic(tmp_path / "report.json", '{"status": "ok"}')

    def full(fh: object, payload: bytes, tmp: Path) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("scenemosaic.scene._files._write_all", full)
    with pytest.raises(OutputSpaceError, match=r"^no space left on device writing .*report.json: free space, or choose another --out$") as info:
        write_atomic(target, '{"status": "failed"}')
    assert isinstance(info.value, OSError) and info.value.errno == errno.ENOSPC
    assert target.read_text() == '{"status": "ok"}'
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]


def test_checkpoint_records_get_the_ordinary_file_mode(tmp_path: Path, umask_022: None) -> None:
    from scenemosaic.dag import FileRunStore, StoredOutput

    FileRunStore(tmp_path / ".checkpoint").put("manager", "abc123", StoredOutput(output={"plan": []}, output_hash="h"))
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in (tmp_path / ".checkpoint").rglob("*") if p.is_file()}
    assert modes and set(modes.values()) == {0o644}, modes

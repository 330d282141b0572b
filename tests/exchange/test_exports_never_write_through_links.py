"""Every delivered file is written through a temporary name and renamed: a symlink planted at a
target (say, in an interrupted run's output before ``--resume``) is replaced, never written
through, in every export format."""

from __future__ import annotations

from pathlib import Path

from scenemosaic.exchange import deliver_scene, load_scene
from tests.conftest import PHYSCENE_DIR


def test_links_at_every_delivered_target_are_replaced_not_followed(tmp_path: Path) -> None:
    scene = load_scene(PHYSCENE_DIR / "DiningRoom-19325_diningroom.json")
    first = tmp_path / "first"
    deliver_scene(scene, first, None)
    written = sorted(p.relative_to(first).as_posix() for p in first.rglob("*") if p.is_file())
    outside = tmp_path / "outside"
    outside.mkdir()
    out = tmp_path / "out"
    planted: dict[Path, Path] = {}
    for rel in written:
        if (first / rel).is_file():
            victim = outside / rel.replace("/", "__")
            victim.write_text("not yours")
            target = out / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.symlink_to(victim)
            planted[target] = victim
    assert len(planted) >= 12  # scene.json/.xml/.glb/.urdf/.sdf/.usda, topdown.png, the formats' mesh files
    deliver_scene(scene, out, None)
    for target, victim in planted.items():
        assert victim.read_text() == "not yours", f"{target.name} was written through its link"
        assert not target.is_symlink() and target.is_file(), target

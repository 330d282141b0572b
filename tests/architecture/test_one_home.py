"""One home per concept, for the things a tool cannot see in imports: each agent prompt exists once,
as package data beside the agents that read it."""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _tracked(pattern: str) -> list[Path]:
    listed = subprocess.run(["git", "ls-files", pattern], cwd=ROOT, capture_output=True, text=True, check=False)
    if listed.returncode == 0 and listed.stdout.strip():
        return [ROOT / line for line in listed.stdout.splitlines()]
    return [p for p in ROOT.rglob(pattern) if ".venv" not in p.parts and ".git" not in p.parts]


def test_every_prompt_lives_once_in_the_package() -> None:
    prompts = sorted((ROOT / "scenemosaic").glob("*/prompts/*.md"))
    assert len(prompts) >= 10  # the structuring, evolve, perception and judge agents' templates
    by_digest = {hashlib.sha256(p.read_bytes()).hexdigest(): p for p in prompts}
    copies = [
        f"{p.relative_to(ROOT)} repeats {by_digest[d].relative_to(ROOT)}"
        for p in _tracked("*.md")
        if (d := hashlib.sha256(p.read_bytes()).hexdigest()) in by_digest and p != by_digest[d]
    ]
    assert not copies, "prompt copies outside their one home:\n" + "\n".join(copies)
    assert not (ROOT / "prompts").exists()  # no second, unread prompt folder at the top


def test_no_layer_above_the_readers_looks_into_a_formats_metadata() -> None:
    """A source's facts (room type, source ids, asset ids, import warnings) are typed
    ``Provenance`` fields; only ``exchange/`` (the readers, and the reading of older files) knows
    where a format keeps them in ``metadata``."""
    import re

    pattern = re.compile(r"metadata(\.get\(|\[)\s*['\"](procthor|holodeck|front3d|sceneeval|sam3d)['\"]")
    offences = [
        f"{p.relative_to(ROOT)}:{n}: {line.strip()}"
        for p in sorted((ROOT / "scenemosaic").rglob("*.py"))
        if "exchange" not in p.relative_to(ROOT / "scenemosaic").parts
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), start=1)
        if pattern.search(line)
    ]
    assert not offences, "format metadata read outside exchange/:\n" + "\n".join(offences)

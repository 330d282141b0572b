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

"""Helpers of the batch tests: the shipped PhyScene rooms, manifests, the delivered scene files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

ROOMS = Path(__file__).resolve().parents[2] / "data" / "layouts" / "physcene"
DINING = ROOMS / "DiningRoom-19325_diningroom.json"
BEDROOM = ROOMS / "Bedroom-33922_bedroom.json"
BEDROOM_2 = ROOMS / "Bedroom-11659_bedroom.json"


def write_manifest(path: Path, jobs: list[dict[str, Any]]) -> Path:
    """Write jobs (dicts; ``Path`` values become strings) as a JSONL manifest at ``path``."""
    lines = [json.dumps({k: str(v) if isinstance(v, Path) else v for k, v in job.items()}) for job in jobs]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def scene_files(out: Path) -> dict[str, bytes]:
    """Every delivered ``scene.json`` (base and variants) under a batch's output folder, by relative path."""
    return {
        p.relative_to(out).as_posix(): p.read_bytes()
        for p in sorted(out.glob("*/*/scene.json"))
        if p.parent.name == "base" or p.parent.name.startswith("variant_")
    }

"""A one-file plugin agent (``examples/custom_agent.py``) runs inside ``generate`` beside the built-ins."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import ModuleType

from scenemosaic import DEFAULT_AGENTS, GenerateConfig, generate

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "custom_agent.py"
DINING = Path(__file__).resolve().parents[2] / "data/layouts/physcene/DiningRoom-19325_diningroom.json"


def _example() -> ModuleType:
    spec = importlib.util.spec_from_file_location("custom_agent_example", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_plugin_is_one_short_file() -> None:
    assert len(EXAMPLE.read_text(encoding="utf-8").splitlines()) < 60


def test_plugin_output_reaches_scene_json_beside_the_builtin_agents(tmp_path: Path) -> None:
    plugin = _example().CrowdingAgent()
    result = generate(DINING, tmp_path, GenerateConfig(agents=[*DEFAULT_AGENTS, plugin], stabilize=False))
    saved = json.loads((tmp_path / "base" / "scene.json").read_text(encoding="utf-8"))
    crowding = saved["metadata"]["crowding"]
    ids = {o["id"] for o in saved["objects"]}
    assert 0 < crowding["covered_fraction"] < 1 and set(crowding["largest"]) <= ids
    assert len(crowding["largest"]) == 3
    # the built-in agents ran too: every object has a parent and the tree exists
    assert result.scene.structure is not None
    assert all(result.scene.support_of(o.id) is not None for o in result.scene.objects)
    # the plugin depends on the room agent only; the verification agent ran after it
    assert "crowding" in result.scene.metadata

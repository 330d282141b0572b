"""Every ```python block in docs/ runs as written (fragments use ```text or another language tag)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
BLOCK = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)

BLOCKS = [
    pytest.param(code, id=f"{path.name}#{i}")
    for path in sorted(DOCS.glob("*.md"))
    for i, code in enumerate(BLOCK.findall(path.read_text(encoding="utf-8")))
]


@pytest.mark.parametrize("code", BLOCKS)
def test_doc_block_runs(code: str) -> None:
    namespace: dict[str, object] = {"__name__": "__doc_block__"}
    exec(compile(code, "<doc block>", "exec"), namespace)

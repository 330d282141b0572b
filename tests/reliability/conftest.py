"""Fixtures of the reliability suite (helpers live in ``cli_helpers.py``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import DINING


@pytest.fixture()
def dining() -> Path:
    """The shipped 6-object PhyScene dining room."""
    return DINING

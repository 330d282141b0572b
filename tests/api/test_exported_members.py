"""The public API: ``__all__`` lists exactly the public names, and each has a docstring."""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

import scenemosaic

SUBPACKAGES = [
    "scene",
    "assets",
    "render",
    "models",
    "dag",
    "agents",
    "structure",
    "physics",
    "exchange",
    "pipeline",
]


def test_all_matches_public_names() -> None:
    """``__all__`` and ``dir()`` agree, every listed name resolves, and nothing else is public."""
    listed = set(scenemosaic.__all__)
    assert listed == {n for n in dir(scenemosaic) if not n.startswith("_")} | {"__version__"}
    for name in listed:
        assert getattr(scenemosaic, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute"):
        scenemosaic.add_agent_nodes  # noqa: B018 - a runtime internal stays in its sub-package


def test_the_public_surface_is_short() -> None:
    assert 30 <= len(scenemosaic.__all__) <= 45, len(scenemosaic.__all__)


def test_importing_the_package_loads_no_heavy_backend() -> None:
    """``import scenemosaic`` and the CLI's ``--help`` must not import MuJoCo, CoACD or scipy.signal (0.7 s)."""
    code = (
        "import sys, scenemosaic, scenemosaic.cli; "
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('mujoco', 'coacd') or m.startswith('scipy.signal')); "
        "print(','.join(heavy))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    assert done.stdout.strip() == "", done.stdout


@pytest.mark.parametrize("package", SUBPACKAGES)
def test_subpackage_all_resolves(package: str) -> None:
    module = importlib.import_module(f"scenemosaic.{package}")
    assert module.__all__, package
    assert len(module.__all__) == len(set(module.__all__)), f"duplicates in scenemosaic.{package}.__all__"
    for name in module.__all__:
        assert hasattr(module, name), f"scenemosaic.{package}.{name} is listed but missing"


def test_public_callables_and_classes_are_documented() -> None:
    missing = [
        name
        for name in scenemosaic.__all__
        if (inspect.isclass(obj := getattr(scenemosaic, name)) or inspect.isfunction(obj)) and not inspect.getdoc(obj)
    ]
    assert not missing, f"public names without docstrings: {missing}"


def test_every_error_derives_from_the_root() -> None:
    from scenemosaic import exceptions

    for name in exceptions.__all__:
        assert issubclass(getattr(exceptions, name), scenemosaic.SceneMosaicError), name

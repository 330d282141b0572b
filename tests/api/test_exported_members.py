"""The public API: ``__all__`` lists exactly the public names, and each has a docstring."""

from __future__ import annotations

import importlib
import inspect

import pytest

import scenemosaic

SUBPACKAGES = ["scene", "importers", "assets", "models", "dag", "agents", "physics", "render", "export"]


def test_all_matches_public_names() -> None:
    public = {
        name
        for name, value in vars(scenemosaic).items()
        if not name.startswith("_") and not inspect.ismodule(value)
    }
    assert set(scenemosaic.__all__) - {"__version__"} == public


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

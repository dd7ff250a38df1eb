"""Specification of the package docstrings: each is a map of its package."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest


@pytest.mark.parametrize("package", ["latent_model", "dlo_env.dataset"])
def test_a_package_docstring_names_every_module_of_its_package(package):
    module = importlib.import_module(package)
    names = sorted(p.stem for p in Path(module.__file__).parent.glob("*.py")
                   if p.stem != "__init__")
    unnamed = [n for n in names if f"``{n}``" not in module.__doc__]
    assert not unnamed, f"{package}'s docstring does not name {unnamed}"

"""Fixtures shared by the tests: toy models, so no planner or harness test needs a trained
checkpoint."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from toy_models import ToyHeadModel  # noqa: E402


@pytest.fixture
def toy_model() -> ToyHeadModel:
    """The two-dimensional toy latent model for the default 20-point cord."""
    return ToyHeadModel()

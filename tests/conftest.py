"""Fixtures shared by the tests: toy models, so no planner or harness test needs a trained
checkpoint."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from toy_models import ToyHeadModel  # noqa: E402


@pytest.fixture
def one_torch_thread():
    """Torch on one thread for the test (small networks run faster so, and other jobs share
    the machine); the thread count is restored after."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture
def toy_model() -> ToyHeadModel:
    """The two-dimensional toy latent model for the default 20-point cord."""
    return ToyHeadModel()

"""Shared tiny fixtures for the latent_model tests (everything on CPU, seconds at most)."""

from __future__ import annotations

import numpy as np
import pytest

from dlo_env.shapes import random_cord_shape
from latent_model.config import ModelConfig, TrainConfig


@pytest.fixture(autouse=True)
def _one_thread(one_torch_thread):
    # Every test here runs torch on one thread (the shared fixture in tests/conftest.py).
    yield


@pytest.fixture(scope="session")
def cord_shapes() -> np.ndarray:
    """300 random cord shapes of the default cord (20 points, 1 m), float32."""
    rng = np.random.default_rng(0)
    return np.stack([random_cord_shape(rng) for _ in range(300)])


@pytest.fixture
def tiny_config() -> ModelConfig:
    return ModelConfig(width=32, depth=2)


@pytest.fixture
def tiny_train_config() -> TrainConfig:
    return TrainConfig(batch_size=64, encoder_batch_size=64, d_steps=1, eval_every=1000,
                       eval_reference=40, eval_inversion=10, threads=1)
